"""Static equilibrium of the SAME discrete port-Hamiltonian model, by Newton with load continuation.

A rest state x of the discrete model is a step with x_n = x_{n+1} = x: every
rate is zero, the kinematic rows (d_t q = v) give v = 0, and the balance
rows, tested with the velocity test functions, become the discrete
equilibrium at x.  The rows that the time stepping writes in RATE form
(strains, stresses, velocity-level constraints) are empty at rest; each
model replaces them by TOTAL-form rows of the configuration
(``model.static_fields`` names the test fields of those rows,
``model.static_rows(x, ref, test, dx, ds)`` writes them; see forms/):

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

import numpy as np
import ufl
from dolfinx import fem
from petsc4py import PETSc

from rodfem.core.integrators import Step, _flatten, _unflatten
from rodfem.nls.newton import Newton, NewtonFailure
from rodfem.core.problem import compile_forms
from rodfem.app.scene import ParameterError

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

    def effort(self, energy, names):
        like = [self.x1[n] for n in names]
        X = ufl.variable(_flatten(like))
        return _unflatten(ufl.diff(energy(*_unflatten(X, like)), X), like)


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


def bodies_of(target):
    """[(name, body)] of a System, or [("", problem)]."""
    refs = getattr(target, "bodies", None)
    return [(n, r.body) for n, r in refs.items()] if isinstance(refs, dict) else [("", target)]


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

    def __init__(self, target, options=None):
        self.target = target
        self.system = isinstance(getattr(target, "bodies", None), dict)
        if self.system:
            target.build()
        self.bodies = bodies_of(target)
        self.refs = {}
        forms = {}
        for name, body in self.bodies:
            ref = fem.Function(body.space.V)
            ref.x.array[:] = body.x0.x.array
            self.refs[name] = ref
            F = rest_form(body, body.x1, ref)
            forms[(name, "F")], forms[(name, "J")] = F, ufl.derivative(F, body.x1)
        if self.system and target.lam_space is not None:
            dl = ufl.TestFunction(target.lam_space)
            zero = fem.Constant(target.lam_space.mesh, 0.0)
            F = zero * ufl.inner(target.lam, dl) * ufl.dx
            forms[("joints", "F")], forms[("joints", "J")] = F, ufl.derivative(F, target.lam)
        compiled = compile_forms(forms)
        opts = dict(OPTIONS, **(options or {}))
        if self.system:
            # A second BlockAssembler indexes the joints again (new, equal index arrays on each
            # joint); the System's own assembler caches positions by id() of the old arrays, so
            # they are put back: freed arrays' ids could be reused and hit that cache.
            kept = [(j.q_index, j.v_index, j.lam_index) for j in target.joints]
            self.assembler = StaticBlockAssembler(target, compiled)
            for j, (q, v, lam) in zip(target.joints, kept):
                j.q_index, j.v_index, j.lam_index = q, v, lam
            self.newton = Newton(assembler=self.assembler, options=opts, prefix=PREFIX)
            self.unknown = self.assembler.X1
        else:
            self.newton = Newton(compiled[("", "F")], compiled[("", "J")], target.x1, target.bcs,
                                 options=opts, prefix=PREFIX)
            self.unknown = self.newton.xv

    # -- the inputs at load factor mu ------------------------------------------------
    def set_load(self, mu, t):
        for _, body in self.bodies:
            for load in body.loads:
                load.constant.value = mu * np.asarray(load.value(t), dtype=float)
        if self.system:
            self.assembler.mu, self.assembler.t = mu, t

    def _get(self):
        return self.unknown.getArray(readonly=True).copy()

    def _set(self, values):
        self.unknown.getArray()[:] = values
        self.unknown.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)

    # -- Newton with load continuation ------------------------------------------------
    def solve(self, t=0.0, steps=1, adaptive=True, min_step=1e-5):
        """Equilibrium under the inputs at time t: mu = 0 -> 1 in load steps starting at 1/steps
        (fixed if not `adaptive`).  The solution is left as x_n (and x_{n+1}) of the problem,
        at rest.  Returns a StaticResult; raises StaticFailure."""
        res = StaticResult(t=t)
        if self.system:
            dyn = self.target.assembler
            self._set(dyn.X0.getArray(readonly=True))
        else:
            self.target.x1.x.array[:] = self.target.x0.x.array
        mu, dmu = 0.0, 1.0 / max(int(steps), 1)
        x_cur, x_prev, mu_prev = self._get(), None, None
        last = (0, float("nan"), "")
        k = 0
        while mu < 1.0 - 1e-12:
            d = min(dmu, 1.0 - mu)
            if 1.0 - mu - d < 1e-12:
                d = 1.0 - mu
            solved = None
            starts = [x_cur] if x_prev is None else [x_cur + (d / (mu - mu_prev)) * (x_cur - x_prev), x_cur]
            for start in starts:
                self._set(start)
                self.set_load(mu + d, t)
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
            dmu = min(2.0 * d, 1.0) if adaptive and solved.iterations <= 4 else d
        self._set(x_cur)
        self.set_load(1.0, t)
        self._commit()
        return res

    def _commit(self):
        """x_n = x_{n+1} = the equilibrium (the time loop starts from it)."""
        if self.system:
            self.assembler.update(self.unknown)
            dyn = self.target.assembler
            self.unknown.copy(dyn.X1)
            self.unknown.copy(dyn.X0)
            dyn.push(dyn.X1, "x1")
            dyn.push(dyn.X0, "x0")
        else:
            x = self.target
            x.x1.x.scatter_forward()
            x.x0.x.array[:] = x.x1.x.array


def solve(target, t=0.0, steps=1, adaptive=True, options=None):
    """Static equilibrium of `target` (Problem or System) at time t, left in its state; returns
    (Statics, StaticResult)."""
    statics = Statics(target, options)
    return statics, statics.solve(t, steps, adaptive)


def _add(A, rows, cols, values):
    A.setValues(np.asarray(rows, dtype=PETSc.IntType), np.asarray(cols, dtype=PETSc.IntType),
                np.ascontiguousarray(values, dtype=PETSc.ScalarType), addv=PETSc.InsertMode.ADD)


def _import_block():
    from rodfem.core.system import BlockAssembler
    return BlockAssembler


class StaticBlockAssembler(_import_block()):
    """The System's block residual at rest: the bodies' static forms, and per joint the reactions
    G(q)^T lambda on the momentum rows and the position-level rows g(q) - mu g_p(t)."""
    mu, t = 1.0, 0.0

    def _static_terms(self):
        vals = self._values(self.X1)
        if self.comm.rank != 0:
            return []
        out = []
        for j in self.joints:
            q, lam = self._pick(vals, j.q_index), self._pick(vals, j.lam_index)
            G = np.einsum("kij,j->ki", j.Q, q) + j.c
            g = 0.5 * np.einsum("i,kij,j->k", q, j.Q, q) + j.c @ q + j.e - self.mu * j.prescribed(self.t)
            out.append((j, G.T @ lam, g, np.einsum("k,kij->ij", lam, j.Q), G))
        return out

    def residual(self, xin, b):
        from dolfinx.fem import petsc as fpetsc
        self.update(xin)
        with b.localForm() as bl:
            bl.set(0.0)
        fpetsc.assemble_vector_block(b, self.F, self.J, bcs=self.bcs, x0=self.X1, scale=-1.0)
        for j, r_v, r_lam, _, _ in self._static_terms():
            keep = [k for k, g in enumerate(j.v_index) if int(g) not in self.fixed]
            b.setValues(j.v_index[keep].astype(PETSc.IntType), np.ascontiguousarray(r_v[keep]), addv=PETSc.InsertMode.ADD)
            b.setValues(j.lam_index.astype(PETSc.IntType), np.ascontiguousarray(r_lam), addv=PETSc.InsertMode.ADD)
        b.assemblyBegin()
        b.assemblyEnd()
        self.joint_work = 0.0

    def jacobian(self, xin, A):
        from dolfinx.fem import petsc as fpetsc
        A.zeroEntries()
        fpetsc.assemble_matrix_block(A, self.J, bcs=self.bcs)
        A.assemble(PETSc.Mat.AssemblyType.FLUSH)
        for j, _, _, drv_dq, G in self._static_terms():
            rows = [k for k, g in enumerate(j.v_index) if int(g) not in self.fixed]
            qcols = [k for k, g in enumerate(j.q_index) if int(g) not in self.fixed]
            lam = list(range(j.size))
            if rows and qcols:
                _add(A, j.v_index[rows], j.q_index[qcols], drv_dq[np.ix_(rows, qcols)])
            if rows:
                _add(A, j.v_index[rows], j.lam_index, G.T[rows, :])
            if qcols:
                _add(A, j.lam_index, j.q_index[qcols], G[np.ix_(lam, qcols)])
        A.assemble()


# -- a scene's equilibrium, from the command line (rodfem static SCENE) -----------------------

def run_static(scene, overrides=None, out=None, t=None, steps=1, adaptive=True, comm=None):
    """The static equilibrium of `scene` under its inputs at time t (default: t_end, the full load).

    Writes into `out` (if given): summary.json (load steps, Newton iterations, the observables
    at equilibrium and, for scenes with an exact solution, the error against it), loadsteps.csv
    (mu, Newton iterations, residual per load step), centreline.pvd (the initial and the
    equilibrium shape), shapes.png, and checkpoint.npz: the equilibrium as the state at step 0,
    from which ``rodfem run --resume out`` starts a dynamic run (at rest, pre-stressed).
    Returns (problem, StaticResult, summary)."""
    import os
    import time
    from contextlib import nullcontext

    from mpi4py import MPI

    from rodfem import __version__
    from rodfem.io import checkpoint
    from rodfem.io.output import OutDir, RunWriter, plot_shapes, write_json
    from rodfem.app.scene import Scene, load

    comm = comm or MPI.COMM_WORLD
    if not isinstance(scene, Scene):
        scene = load(scene)
    p = scene.values(overrides)
    t = p["t_end"] if t is None else float(t)
    if steps < 1:
        raise ParameterError(f"--load-steps must be an integer >= 1 (got {steps})")
    outdir = OutDir(out, comm) if out else None
    started = {"scene": scene.name, "mode": "static", "status": "running", "parameters": p, "t": t,
               "mpi_ranks": comm.size, "pid": os.getpid()}
    with outdir.claimed(started) if outdir else nullcontext():
        problem = scene.build(p, comm)
        writer = RunWriter(outdir, problem, 1, 2, p.get("section", 0.0)) if outdir else None
        if writer:
            writer.frame(0.0)
        t0 = time.perf_counter()
        statics = Statics(problem)
        try:
            result = statics.solve(t, steps, adaptive)
        except StaticFailure as fail:
            if outdir:
                outdir.do("write summary.json", write_json, outdir.file("summary.json"),
                          dict(started, status="static-failure", failure=str(fail)))
            raise
        wall = time.perf_counter() - t0
        obs = problem.observe()
        summary = {"scene": scene.name, "mode": "static", "status": "completed", "rodfem_version": __version__,
                   "parameters": p, "t": t, "load_steps": len(result.steps), "load_steps_halved": result.failed,
                   "initial_load_steps": steps, "adaptive": adaptive, "newton_its": result.newton_its,
                   "wall_time_s": wall, "dofs": problem.dofs, "n_elements": problem.n_elements,
                   "mpi_ranks": comm.size, "equilibrium": obs}
        ref = scene.reference(p) if scene.reference and t == p["t_end"] else None
        if ref:
            scale = ref.get("scale", 1.0)
            errs = {k: abs(obs[k] - v) for k, v in ref.items() if k != "scale" and k in obs}
            summary["reference"] = ref
            summary["error"] = max(errs.values()) if errs else None
            summary["error_relative"] = summary["error"] / scale if errs else None
        if outdir:   # the equilibrium as a checkpoint at step 0: `rodfem run --resume out` starts from it
            checkpoint.save(outdir, problem, checkpoint._Layout(problem), 0, None, problem.hamiltonian(), 0.0,
                            {"scene": scene.name, "parameters": p, "checkpoint_every": 0, "static_time": t})
            writer.frame(1.0)

            def write_loadsteps(path):
                with open(path, "w") as f:
                    f.write("mu,newton_its,residual\n")
                    for s in result.steps:
                        f.write(f"{s.mu!r},{s.iterations},{s.residual!r}\n")
            outdir.do("write loadsteps.csv", write_loadsteps, outdir.file("loadsteps.csv"))
            outdir.do("write summary.json", write_json, outdir.file("summary.json"), summary)
            outdir.do("write shapes.png", plot_shapes, outdir.file("shapes.png"), writer.snapshots,
                      writer.dim, writer.width)
    return problem, result, summary
