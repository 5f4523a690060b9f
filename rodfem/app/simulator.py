"""The step interface: a scene or a System driven one step at a time from the user's own loop.

    sim = rodfem.Simulator("robot-arm-control", controller="external")
    out = sim.step({"beam.hub moment": 0.3}, 0.01)      # u held over the step
    out.y["beam.hub moment"]                             # its conjugate output y = B^T z
    state = sim.save(); ...; sim.restore(state)          # back to x_n (an RL reset, a co-simulation rollback)

One call of `step(u, h)` is one step of the time loop (rodfem/analysis/timeloop.py, `attempt`:
the same predictor, Newton and retry), from x_n at t_n to x_{n+1} at t_{n+1} = t_n + h, with the
inputs u of the driven ports held constant over the step (zero-order hold: Load values are read at
the midpoint, so u is u_{n+1/2} of the rule).  The ports are the bodies' Loads (rodfem/core/ports.py),
named ``body.load`` in a System (the load's name in a Problem); a port not given in `u` keeps its
last value, and a port never driven its scene's own u(t) (gravity keeps acting).  The outputs are
the ports' conjugate outputs of the step,

    y_j = <e_j, B(x_{n+1/2})^T z_{n,n+1}>_Gamma      (the load's pairing with u = e_j)

so that h u.y is the work the port supplied in the step (the history's `supplied` is the sum over
the ports), and the history row of x_{n+1} (H, supplied, dissipated, balance_error, the scene's
observables).  The discrete energy balance H_{n+1} - H_n + h d_n = h y.u is checked as in `run`:
`sim.history` is a `Result` with one row per step (columns u[port] and y[port] added), its
`max_balance_error` the largest |balance| so far.

`save()` returns the whole state of the loop (x_n, the control laws' states, t, the loop's sums,
the predictor's x_{n-1}, the held inputs, the length of the history); `restore(state)` puts it back
and cuts the history to that length: a rollback.  `reset()` restores the initial state; `reset(params)`
rebuilds the scene with other parameter values (a System given directly cannot be rebuilt).

Under mpirun every rank calls `step` with the same sequence of steps; the inputs of rank 0 are used
(broadcast: the other ranks may pass None) and the outputs are returned on every rank (collective
assembly).  A step whose Newton fails is split into 2, 4, ... equal sub-steps from x_n as in the
time loop (rodfem/analysis/stepping.py, down to `dt_min`, default h/1024; the outputs then are the sub-steps' mean, so
that h u.y is still the step's work); below that NewtonFailure is raised with the state left at x_n.
"""
from dataclasses import dataclass, field

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from rodfem.analysis.stepping import SPLIT_MAX, StepState
from rodfem.analysis.timeloop import Result, attempt
from rodfem.errors import NewtonFailure, ParameterError
from rodfem.fem.jit import compile_forms


@dataclass
class StepOutput:
    """What one step returns: t_{n+1}, the conjugate outputs y (port -> array), the history row
    (`row`: H, supplied, balance_error, the observables) and Newton's iterations."""
    t: float
    y: dict
    row: dict
    newton_its: int

    def vector(self) -> np.ndarray:
        """The outputs of all ports, flat, in the order of `Simulator.ports`."""
        return np.concatenate([np.ravel(v) for v in self.y.values()]) if self.y else np.zeros(0)


@dataclass
class SavedState:
    """The loop's state (`Simulator.save`); the arrays are this rank's part."""
    snapshot: tuple
    t: float
    sums: tuple          # H, supplied, dissipated
    previous: object     # x_{n-1} (the predictor's), or None
    h_prev: float
    held: dict
    rows: int
    steps: int
    extra: dict = field(default_factory=dict)


class Port:
    """A Load as an input port: its name, its size, the compiled output forms y_j and its held value."""

    def __init__(self, name, body, load):
        self.name, self.body, self.load = name, body, load
        self.shape = tuple(load.constant.value.shape)
        self.size = int(np.prod(self.shape)) if self.shape else 1
        # the time function the port reads: an actuator's (forms/actuators.py) `history`, a Load's `value`
        self.attribute = "history" if hasattr(load, "history") else "value"
        self.original = getattr(load, self.attribute)
        self.held = None

    def output_forms(self):
        """The forms h-free y_j = power(u = e_j) (the load's pairing is linear in u)."""
        saved, forms = self.load.constant, []
        for j in range(self.size):
            e = np.zeros(self.size)
            e[j] = 1.0
            self.load.constant = fem.Constant(self.body.mesh, e.reshape(self.shape))
            forms.append(self.load.power(self.body.step, self.body.dx, self.body.ds))
        self.load.constant = saved
        return forms

    def hold(self, value, t=None):
        """Hold u = value from now on; with `t`, checked by the port itself at t (e.g. a tendon's tension
        >= 0: ParameterError, and the port keeps what it held)."""
        value = np.asarray(value, dtype=float)
        if value.size != self.size:
            raise ParameterError(f"input '{self.name}' must have {self.size} number(s) (got {value.size})")
        if not np.all(np.isfinite(value)):
            raise ParameterError(f"input '{self.name}' must be finite (got {value.ravel().tolist()})")
        before = self.held
        self.held = value.reshape(self.shape).copy()
        setattr(self.load, self.attribute, lambda t, v=self.held: v)
        if t is not None:
            try:
                self.load.update(t)
            except ParameterError:
                self.release() if before is None else self.hold(before)
                raise

    def release(self):
        self.held = None
        setattr(self.load, self.attribute, self.original)


class Simulator:
    """A scene (or its name, with parameter values `params`) or a System, stepped from Python (see
    the module docstring).  `dt`: the default step of `step` (a scene's dt by default); `dt_min`: the
    smallest sub-step a failing step is split into (default h/1024; dt_min = h: no splitting)."""

    def __init__(self, scene_or_system, dt=None, comm=MPI.COMM_WORLD, dt_min=None, **params):
        from rodfem.app.scene import Scene, load
        self.comm = comm
        if isinstance(scene_or_system, (str, Scene)):
            self.scene = scene_or_system if isinstance(scene_or_system, Scene) else load(scene_or_system)
            self.params = dict(params)
        else:
            if params:
                raise ParameterError(f"parameters ({', '.join(params)}) need a scene, not a System")
            self.scene, self.params = None, {}
        self._system = None if self.scene is not None else scene_or_system
        self.dt, self.dt_min = dt, dt_min
        self._make()

    # -- building ---------------------------------------------------------------------------
    def _make(self):
        from rodfem.app.driver import build
        if self.scene is not None:
            p = self.scene.values(self.params)
            self.values = p
            problem = build(self.scene, p, self.comm)
            self.default_dt = p["dt"]
        else:
            problem = self._system.build()
            self.values, self.default_dt = {}, None
        self.problem = problem
        named = problem.named_bodies
        self.ports = {}
        for name, body in problem.body_items():
            for load in body.loads:
                port = Port(f"{name}.{load.name}" if named else load.name, body, load)
                if port.name in self.ports:
                    raise ParameterError(f"two input ports are named {port.name!r}: name the loads apart")
                self.ports[port.name] = port
        forms = {(p.name, j): f for p in self.ports.values() for j, f in enumerate(p.output_forms())}
        self._outputs = compile_forms(forms) if forms else {}
        self.dissipates = getattr(problem, "dissipates", False)
        self.history = Result()
        self._state = StepState()
        self._previous, self._sums = None, (problem.hamiltonian(), 0.0, 0.0)
        row = {"t": problem.t, "H": self._sums[0], "supplied": 0.0,
               **({"dissipated": 0.0} if self.dissipates else {}), "newton_its": 0, "balance_error": 0.0,
               **self._port_columns(None), **problem.observe()}
        self.history.rows.append(row)
        self._initial = self.save()

    @property
    def t(self) -> float:
        return self.problem.t

    @property
    def system(self):
        """The System (or Problem) being stepped."""
        return self.problem

    def _port_columns(self, y):
        out = {}
        for p in self.ports.values():
            u = np.ravel(p.held) if p.held is not None else np.ravel(p.load.constant.value)
            for j in range(p.size):
                suffix = f"[{j}]" if p.size > 1 else ""
                out[f"u[{p.name}]{suffix}"] = float(u[j])
                out[f"y[{p.name}]{suffix}"] = float(y[p.name][j]) if y is not None else 0.0
        return out

    # -- stepping ---------------------------------------------------------------------------
    def _inputs(self, u):
        """dict port -> value from `u` (a dict, or a flat array over all ports in their order)."""
        if u is None:
            return {}
        if isinstance(u, dict):
            unknown = [k for k in u if k not in self.ports]
            if unknown:
                raise ParameterError(f"unknown input port(s) {', '.join(map(repr, unknown))}; the ports are "
                                     f"{', '.join(map(repr, self.ports)) or 'none'}")
            return u
        flat = np.ravel(np.asarray(u, dtype=float))
        size = sum(p.size for p in self.ports.values())
        if flat.size != size:
            raise ParameterError(f"the inputs u must be a dict by port or {size} numbers (ports "
                                 f"{', '.join(map(repr, self.ports))}), got {flat.size}")
        out, k = {}, 0
        for p in self.ports.values():
            out[p.name] = flat[k:k + p.size]
            k += p.size
        return out

    def step(self, u=None, dt=None) -> StepOutput:
        """One step of size dt (default: the scene's dt) with the inputs u held over it (see the module
        docstring); collective.  Returns the outputs of the step."""
        u = self.comm.bcast(u, root=0)
        h = dt if dt is not None else (self.dt or self.default_dt)
        if h is None or not (isinstance(h, (int, float)) and np.isfinite(h) and h > 0):
            raise ParameterError(f"the step dt must be a number > 0 (got {h!r})")
        h = float(h)
        problem, state = self.problem, self._state
        t = problem.t
        for name, value in self._inputs(u).items():
            self.ports[name].hold(value, t + 0.5 * h)
        t1 = t + h
        n = self.history.steps + 1
        H = self._sums[0]
        k, failed = state.split, False
        while True:
            try:
                its, H_new, work, lost, y, worst = self._substeps(h, k, t, t1, n, H)
                break
            except NewtonFailure:
                state.rejected += 1
                if h / (2 * k) < (self.dt_min or h / SPLIT_MAX) * (1 - 1e-12):
                    raise
                k, failed = 2 * k, True
        state.split = k if failed else max(1, k // 2)
        state.split_steps += k > 1
        state.max_substep_balance = max(state.max_substep_balance, worst)
        supplied, dissipated = self._sums[1] + work, self._sums[2] + lost
        row = {"t": t1, "H": H_new, "supplied": supplied, **({"dissipated": dissipated} if self.dissipates else {}),
               "newton_its": its, "balance_error": H_new - H + lost - work, **self._port_columns(y),
               **problem.observe()}
        self._previous = problem.accept()
        problem.t = t1
        state.h_prev = h / k
        state.substeps += k
        self._sums = (H_new, supplied, dissipated)
        self.history.rows.append(row)
        self.history.steps = n
        return StepOutput(t1, y, row, its)

    def _substeps(self, h, k, t, t1, n, H):
        """[t, t1] in k equal sub-steps from x_n (the time loop's split, rodfem/analysis/timeloop.py), the last
        one not accepted: (iterations, H, work, dissipated, y, largest sub-step balance), y the mean of the
        sub-steps' outputs (u is held: h u.y is the work of the step); on a failure x_n is put back."""
        problem, state = self.problem, self._state
        snap = problem.snapshot() if k > 1 else None
        previous, ratio = self._previous, (h / k) / (state.h_prev or h / k)
        its, work, lost, worst = 0, 0.0, 0.0, 0.0
        y = {name: np.zeros(p.size) for name, p in self.ports.items()}
        for i in range(k):
            a, b = t + i * h / k, (t1 if i == k - 1 else t + (i + 1) * h / k)
            try:
                s_its, H_new, w, d = attempt(problem, state, b - a, a, b, previous, ratio, n, self.dissipates)
            except NewtonFailure:
                if snap is not None:
                    problem.restore(snap)
                raise
            for name, p in self.ports.items():
                y[name] += np.array([self.comm.allreduce(fem.assemble_scalar(self._outputs[(name, j)]), op=MPI.SUM)
                                     for j in range(p.size)]) / k
            its, work, lost = its + s_its, work + w, lost + d
            worst, H = max(worst, abs(H_new - H + d - w)), H_new
            if i < k - 1:
                previous, ratio = problem.accept(), 1.0
        return its, H, work, lost, y, worst

    # -- save, restore, reset ---------------------------------------------------------------
    def save(self) -> SavedState:
        """The loop's state now (x_n, the laws' states, t, sums, predictor, held inputs, history length)."""
        return SavedState(self.problem.snapshot(), self.problem.t, self._sums,
                          None if self._previous is None else self._previous.copy(), self._state.h_prev,
                          {k: (None if p.held is None else p.held.copy()) for k, p in self.ports.items()},
                          len(self.history.rows), self.history.steps, {"split": self._state.split})

    def restore(self, state: SavedState):
        """Back to a state of `save()` (of this simulator): x_n, t, the inputs held then; the history
        is cut back to its length then."""
        self.problem.restore(state.snapshot)
        self.problem.t = state.t
        self._sums = state.sums
        self._previous = None if state.previous is None else state.previous.copy()
        self._state.h_prev = state.h_prev
        self._state.split = state.extra.get("split", 1)
        for name, p in self.ports.items():
            if state.held.get(name) is None:
                p.release()
            else:
                p.hold(state.held[name])
        del self.history.rows[state.rows:]
        self.history.steps = state.steps

    def reset(self, params=None):
        """Back to the initial state; with `params` (dict name -> value) the scene rebuilt with them
        (merged into the parameters given so far)."""
        if params:
            if self.scene is None:
                raise ParameterError("reset(params) needs a scene: a System given directly cannot be rebuilt")
            self.params = {**self.params, **params}
            self._make()
            return
        self.restore(self._initial)

    @property
    def inputs(self):
        """[(port name, size)] in the order of a flat input vector."""
        return [(p.name, p.size) for p in self.ports.values()]
