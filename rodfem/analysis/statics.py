"""Static equilibrium of the SAME discrete port-Hamiltonian model, by Newton with load continuation.

A rest state x of the discrete model is a step with x_n = x_{n+1} = x: every
rate is zero, the kinematic rows (d_t q = v) give v = 0, and the balance
rows, tested with the velocity test functions, become the discrete
equilibrium at x.  The rows that the time stepping writes in RATE form
(strains, stresses, velocity-level constraints) are empty at rest; each
model replaces them by TOTAL-form rows of the configuration
(``model.static_fields`` names the test fields of those rows,
``model.static_rows(x, ref, test, dx, ds)`` writes them; see forms/)::

    planar beam   Gamma = Pi(A^T r' - e1),  kappa = Pi(phi')
    string        C = |r'|^2
    3D rod        C_N (N - N_ref) = Pi(Gamma(q) - Gamma(q_ref)),  C_M (M - M_ref) = Pi(K(q) - K(q_ref)),
                  d_i . d_j = delta_ij at the nodes
    rigid body    d_i . d_j = delta_ij

(q_ref: the reference state, the body's state when the solver is made: the
stress-free initial configuration of a scene.)  Joints of a System give
their position-level rows g(q) - g_p instead of the velocity-level ones,
and their reactions G(q)^T lambda.  So the static solution is the
equilibrium of the discrete model with only the spatial discretization
error: no load-step error, whatever the number of load steps.  It is also
a rest state of the time stepping (the balance rows are the same, the
total-form rows are the invariants of the rate rows), so it can start a
dynamic run (`Statics.solve` leaves it in x_n).

Load continuation: the inputs (loads and driven joints) at time t are
scaled by a load factor mu, 0 -> 1, in load steps; after a step Newton
starts from the secant prediction of the last two solutions.  Adaptive: a
step that fails is halved (down to `min_step`), one that converges in at
most 4 iterations lets the next one double.  NOT implemented: arc-length
continuation (needed only past limit points of the load path; none of the
scenes has one: end moments and dead loads on rods and cables are
monotone).  A failure ends with a one-line `StaticFailure` (exit code 3).
"""
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np
import ufl
from dolfinx import fem

from rodfem.common import interrupts
from rodfem.common.limits import check_load_steps
from rodfem.core.bodycontact import BodyContacts, fixed_dofs
from rodfem.core.integrators import Step, flatten, unflatten
from rodfem.core.servo import Servo
from rodfem.core.system import Couplings, JointRows
from rodfem.errors import NewtonFailure, ParameterError
from rodfem.fem.assembly import BlockAssembler, BodyBlock
from rodfem.fem.jit import compile_forms
from rodfem.nls.newton import Newton

# full Newton (no chord: the 3D scenes' lagged Jacobian is for time steps), own option prefix
OPTIONS = {"snes_max_it": 30}
PREFIX = "rodfem_static_"


class StaticFailure(NewtonFailure):
    """The load continuation could not reach mu = 1."""

    def __init__(self, mu, step, residual, iterations, reason):
        self.mu = mu
        why = (f"the tangent matrix is singular ({reason}): a free rigid motion or a mechanism has no "
               "unique equilibrium" if reason == "DIVERGED_LINEAR_SOLVE" else
               f"load step {step:.3g} below the minimum: residual {residual:.3e} after {iterations} "
               f"Newton iterations ({reason})")
        RuntimeError.__init__(self, f"static solve failed at load factor {mu:.6g}: {why}")
        self.step, self.t, self.residual, self.iterations, self.reason = 0, mu, residual, iterations, reason


class RestStep(Step):
    """A step at rest: x_n = x_{n+1} = X.  Rates are zero (statics) or the given fields `rates`
    (the linearization: E d_t x).  Efforts are dW/dx at X (the midpoint rule at x_m = X)."""

    def __init__(self, X, rates=None):
        self.x0 = self.x1 = X
        self.rates, self.rule, self.h = rates, "midpoint", 0.0   # h -> 0: the time-continuous rows

    def mid(self, name):
        return self.x1[name]

    def rate(self, name):
        if self.rates is not None:
            return self.rates[name]
        return ufl.zero(*self.x1[name].ufl_shape)

    def effort(self, energy, names, weights=None):
        like = [self.x1[n] for n in names]
        X = ufl.variable(flatten(like))
        return unflatten(ufl.diff(energy(*unflatten(X, like)), X), like)


def static_fields(model):
    fields = getattr(model, "static_fields", None)
    if fields is None or not hasattr(model, "static_rows"):
        raise ParameterError(f"model {type(model).__name__} has no total-form rows for statics "
                             "(static_fields, static_rows in forms/)")
    return tuple(fields)


def _drop_zero(F):
    """The form without integrals whose integrand is identically zero (rows whose tests were removed)."""
    keep = [i for i in F.integrals() if not isinstance(i.integrand(), ufl.constantvalue.Zero)]
    return ufl.Form(keep)


def rest_form(body, x, ref, rates=None, total=True, loads=True):
    """The body's residual at rest in x (a Function on its space): the model's rows with
    x_n = x_{n+1} = x (rates zero, or the Function `rates`), the loads' input maps, and with
    `total` the model's total-form rows (state `ref` as reference) in place of its rate rows."""
    S, model = body.space, body.model
    X = S.split(x)
    test = S.split(ufl.TestFunction(S.V))
    fields = static_fields(model) if total else ()
    kept = {n: (ufl.zero(*t.ufl_shape) if n in fields else t) for n, t in test.items()}
    step = RestStep(X, None if rates is None else S.split(rates))
    F = model.residual(step, kept, body.dx, body.ds)
    rows = model.static_rows(X, S.split(ref), test, body.dx, body.ds) if fields else None
    if rows is not None:
        F = F + rows
    if loads:
        for load in body.loads:
            F = F + load.input_map(step, test, body.dx, body.ds)
    return _drop_zero(F)


@dataclass
class LoadStep:
    mu: float
    iterations: int
    residual: float


@dataclass
class StaticResult:
    steps: list = field(default_factory=list)     # accepted load steps
    failed: int = 0                               # load steps halved
    t: float = 0.0

    @property
    def newton_its(self):
        return sum(s.iterations for s in self.steps)


class Statics:
    """Static equilibrium of a Problem or a System under its inputs at time t.

        statics = Statics(problem)           # reference state = the problem's current x_n
        result = statics.solve(t=1.0, steps=4)
        run(problem, dt, t_end)              # starts at rest in the equilibrium
    """

    def __init__(self, target, options: Optional[dict] = None):
        refuse_servos(target, "statics")
        self.target = target.build()
        self.bodies = target.body_items()
        self.refs = {}
        forms = {}
        for name, body in self.bodies:
            ref = fem.Function(body.space.V)
            ref.x.array[:] = body.x0.x.array
            self.refs[name] = ref
            F = rest_form(body, body.x1, ref)
            forms[(name, "F")], forms[(name, "J")] = F, ufl.derivative(F, body.x1)
        compiled = compile_forms(forms)
        blocks = [BodyBlock(compiled[(name, "F")], compiled[(name, "J")], body.x1, body.bcs)
                  for name, body in self.bodies]
        self.joint_rows = StaticJointRows(target.points) if (target.joints or getattr(target, "components", None)) else None
        # contact between bodies at rest: the force grad V(x) of the iterate (rodfem/core/bodycontact.py)
        contacts = (BodyContacts(target.contacts, [r for r in target.bodies.values()], target.layout,
                                 fixed_dofs(target, target.layout), target.layout.create_vector(), rest=True)
                    if getattr(target, "contacts", None) else None)
        parts = [c for c in (self.joint_rows, contacts) if c is not None]
        self.assembler = BlockAssembler(target.layout, blocks, (parts[0] if len(parts) == 1 else Couplings(parts))
                                        if parts else None)
        self.newton = Newton(assembler=self.assembler, options=dict(OPTIONS, **(options or {})), prefix=PREFIX)
        self.unknown = self.assembler.vector

    # -- the inputs at load factor mu ------------------------------------------------
    def set_load(self, mu, t):
        for _, body in self.bodies:
            for load in body.loads:
                load.constant.value = mu * np.asarray(load.value(t), dtype=float)
        if self.joint_rows is not None:
            self.joint_rows.mu, self.joint_rows.t = mu, t

    def _get(self):
        return self.unknown.getArray(readonly=True).copy()

    def _set(self, values):
        self.unknown.getArray()[:] = values

    # -- Newton with load continuation ------------------------------------------------
    def solve(self, t: float = 0.0, steps: int = 1, adaptive: bool = True, min_step: float = 1e-5,
              on_step: Optional[Callable] = None) -> "StaticResult":
        """Equilibrium under the inputs at time t: mu = 0 -> 1 in load steps starting at 1/steps
        (fixed if not `adaptive`; at most MAX_STEPS of them).  The solution is left as x_n (and
        x_{n+1}) of the problem, at rest.  `on_step(LoadStep)` is called after every accepted
        load step.  Inside `rodfem.common.interrupts.deferred` a signal stops the continuation
        between two load steps (`rodfem.errors.Interrupted`).  Returns a StaticResult; raises
        StaticFailure."""
        check_load_steps(steps)
        res = StaticResult(t=t)
        self.target.predict(None)          # x_n from the bodies
        self._set(self.target.X0.getArray(readonly=True))
        mu, dmu = 0.0, 1.0 / max(int(steps), 1)
        x_cur, x_prev, mu_prev = self._get(), None, None
        last = (0, float("nan"), "")
        k = 0
        while mu < 1.0 - 1e-12:
            interrupts.check(self.target.comm, k, t, f"after load step {k} (load factor {mu:.6g})")
            d = min(dmu, 1.0 - mu)
            if 1.0 - mu - d < 1e-12:
                d = 1.0 - mu
            solved = None
            starts = [x_cur] if x_prev is None else [x_cur + (d / (mu - mu_prev)) * (x_cur - x_prev), x_cur]
            for start in starts:
                self._set(start)
                self.set_load(mu + d, t)
                self._fit_multipliers()
                try:
                    solved = self.newton.solve(k + 1, mu + d)
                    break
                except NewtonFailure as fail:
                    last = (fail.iterations, fail.residual, fail.reason)
                    if fail.reason == "DIVERGED_LINEAR_SOLVE":   # singular: smaller steps do not help
                        self._set(x_cur)
                        self.set_load(mu, t)
                        raise StaticFailure(mu, d, fail.residual, fail.iterations, fail.reason) from None
            if solved is None:
                res.failed += 1
                dmu = 0.5 * d
                if dmu < min_step:
                    self._set(x_cur)
                    self.set_load(mu, t)
                    raise StaticFailure(mu, dmu, last[1], last[0], last[2])
                continue
            k += 1
            x_prev, mu_prev, x_cur = x_cur, mu, self._get()
            mu += d
            res.steps.append(LoadStep(mu, solved.iterations, solved.residual))
            if on_step:
                on_step(res.steps[-1])
            dmu = min(2.0 * d, 1.0) if adaptive and solved.iterations <= 4 else d
        self._set(x_cur)
        self.set_load(1.0, t)
        self._commit(t)
        return res

    def _fit_multipliers(self):
        """lambda <- argmin |F(x, lambda)| at the current x: F is affine in lambda (the reactions
        G(q)^T lambda on the momentum rows), so n_lambda + 1 residuals give the fit exactly.  A
        mechanism held only by its joints (a hanging pendulum of point masses) has a singular
        tangent at lambda = 0 (its stiffness is lambda . Q); from the fitted reactions Newton starts
        with the right one."""
        layout = self.target.layout
        n = len(layout.multipliers)
        if not n:
            return
        k, at = layout.owned_multipliers()   # (this rank's multipliers: all on rank 0, or a joint's on its rank)
        b = self.unknown.duplicate()

        def residual(lam):
            self.unknown.getArray()[at] = lam[k]
            self.assembler.residual(self.unknown, b)
            return np.concatenate(self.comm.allgather(b.getArray(readonly=True).copy()))
        r0 = residual(np.zeros(n))
        columns = []
        for i in range(n):
            columns.append(residual(np.eye(n)[i]) - r0)
        lam = np.linalg.lstsq(np.column_stack(columns), -r0, rcond=None)[0]
        self.unknown.getArray()[at] = lam[k]
        b.destroy()

    @property
    def comm(self):
        return self.target.comm

    def _commit(self, t):
        """x_n = x_{n+1} = the equilibrium (the time loop starts from it); the joints' read-out
        (constraint_residual) at time t, where the driven joints hold."""
        self.target.set_state(self.unknown)
        points = getattr(self.target, "points", None)
        if points is not None:
            points.step(self.target.X0, t, t, points.times[2])


def solve(target, t: float = 0.0, steps: int = 1, adaptive: bool = True, options: Optional[dict] = None):
    """Static equilibrium of `target` (Problem or System) at time t, left in its state; returns
    (Statics, StaticResult)."""
    statics = Statics(target, options)
    return statics, statics.solve(t, steps, adaptive)


def refuse_servos(target, what):
    """A servo constraint (rodfem/core/servo.py) is an inverse-dynamics problem of a run: refuse it."""
    servos = [j.name for j in getattr(target, "joints", ()) if isinstance(j, Servo)]
    if servos:
        raise ParameterError(f"{what} does not take servo constraints ({', '.join(servos)}): they prescribe a "
                             "motion in time; use run")


class StaticJointRows(JointRows):
    """The joints at rest: the reactions G(q)^T lambda on the momentum rows and the position-level
    rows g(q) - mu g_p(t) (the load factor mu scales a driven joint's motion); the springs'
    forces G(q)^T psi'(xi(q)) (dampers exert none at rest)."""
    mu, t = 1.0, 0.0

    PAIRS = (("v", "q"), ("v", "lam"), ("lam", "q"))
    COMPONENT_PAIRS = (("v", "q"),)

    def update(self, X):
        vals = self.points.values(X)
        self._terms = []
        if self.comm.rank == 0:
            for j in self.joints:
                q, lam = vals[j.q_at], vals[j.lam_at]
                G = np.einsum("kij,j->ki", j.Q, q) + j.c
                g = 0.5 * np.einsum("i,kij,j->k", q, j.Q, q) + j.c @ q + j.e - self.mu * j.prescribed(self.t)
                blocks = (("v", "q", np.einsum("k,kij->ij", lam, j.Q)), ("v", "lam", G.T), ("lam", "q", G))
                self._terms.append((j, G.T @ lam, g, blocks, 0.0, 0.0))
            for c in self.components:   # springs at rest: G(q)^T psi'(xi(q)); dampers: nothing
                r_v, dr_dq = c.at_rest(vals[c.q_at], self.t)
                self._terms.append((c, r_v, np.zeros(0), (("v", "q", dr_dq),), 0.0, 0.0))
