"""Newton's method for the step residual F(x_{n+1}) = 0 with a petsc4py SNES.

Jacobian J = dF/dx_{n+1} from ufl.derivative; forms are compiled once and
reused every step; a single body's Jacobian is assembled by rodfem/fem/fastassembly.py
(DOLFINx's matrix, without its per-entry search).  Direct solves: in serial PETSc's
own LU in RCM order (3x faster than MUMPS on these banded systems; a structure that is no
band, a net of strings, the partial LU below: rodfem/la/lu_chain.py's first_lu); in parallel
the exact Schur complement over the rank interfaces of rodfem/la/schur.py
(MUMPS, the former parallel default, was 4-10x slower than serial and ran out of
workspace at 10^4 elements).  PETSc's LU does not pivot, so a zero pivot (saddle
points: multipliers, zero densities in statics) makes it fail; the serial solver
then switches once, for the rest of the run, to the next LU of `LU_CHAIN` and
repeats the step: the partial LU of rodfem/la/partial_lu.py (it orders each multiplier
after the dofs it constrains; on the 3D rod 4x faster to factor than SuperLU), PETSc's
LU in AMD order, then the pivoting LUs SuperLU and MUMPS; the parallel solver does
the same inside the ranks (`Newton.linear_solver` tells which one ran).  (Not
superlu_dist: it crashes at exit on this stack.)  Every setting can be overridden
from the PETSc options database with the prefix ``rodfem_`` (e.g.
``PETSC_OPTIONS="-rodfem_snes_atol 1e-12"``; MUMPS in parallel:
``-rodfem_pc_type lu -rodfem_pc_factor_mat_solver_type mumps``).
"""
import atexit
import itertools
import time
import weakref
from dataclasses import dataclass

from petsc4py import PETSc

from rodfem.errors import NewtonFailure, petsc_error
from rodfem.la.lu_chain import LU_CHAIN, PIVOTING, backward_error, first_lu, lu_name, mumps_options, next_lu

# Converged when |F| <= 1e-10, |F| <= 1e-12 |F_0|, or the Newton update is at
# round-off, |dx| <= 1e-14 |x| (stiff problems: the residual carries round-off
# ~ eps * stiffness, e.g. 2e-9 for EA = 1e7, while x is converged to the last digit).
# Globalized by a backtracking line search (bt: the full step when it decreases |F| enough,
# else a cubic backtrack).  Measured on the scenes' defaults (issue 25; three of them checked by
# tests/analysis/test_stepping.py): the
# same mean Newton iterations as the full steps of the basic line search on flying-spaghetti-2d/3d,
# four-bar-2d, slider-crank-3d, crane-manoeuvre, roll-up-2d, cantilever-2d, spring-damper-chain,
# robot-arm-control and flexible-robot-arm-2d (the full step is always taken there), while it
# carries the robot arm at h = 0.1 through the step where the full steps diverge (issue 25).
# A chord Newton (LARGE_SETTINGS, the 3D rod's lag) keeps the full steps: an old Jacobian's
# direction need not descend |F| (measured: the helix's converged moments moved by 1e-5); its
# retry with full Newton after a failure has the line search.
DEFAULTS = {"snes_type": "newtonls", "snes_linesearch_type": "bt",
            "snes_atol": 1e-10, "snes_rtol": 1e-12, "snes_stol": 1e-14, "snes_max_it": 25,
            "ksp_type": "preonly"}
# The linear solver: serial, PETSc's own LU in reverse Cuthill-McKee order (on these banded
# systems 25 % faster to factor and twice as fast to solve as the nested dissection default,
# and more accurate: no pivoting, and RCM keeps the band's natural pivots); in parallel the
# exact elimination over the rank interfaces of rodfem/la/schur.py.
SERIAL = {"pc_type": "lu", "pc_factor_mat_solver_type": "petsc", "pc_factor_mat_ordering_type": "rcm"}
PARALLEL = {"pc_type": "python", "pc_python_type": "rodfem.la.schur.InterfaceSchur"}
# Large systems (>= LARGE unknowns) reuse the Jacobian and its factorization for five Newton
# iterations, the count going on across steps (a model's own options win, e.g. the 3D rod's lag
# 8): there the factorization is most of the cost, and every one costs the parallel solver its
# interface solves too.  Measured on flying-spaghetti-2d (dt = 0.1, serial / mpirun -n 2, ms per
# step): 10^4 elements full Newton 98 / 86 (3 iterations), lag 2 74 / 57, lag 3 53 / 42, lag 5
# 43 / 32 (5 iterations, one factorization a step); 10^5 elements 930 / 839, 711 / 472, 532 / 368,
# 465 / 297; the energy balance unchanged (Newton's tolerance).  A step this fails repeats with
# full Newton.
LARGE = 10_000
LARGE_SETTINGS = {"snes_lag_jacobian": 5, "snes_lag_jacobian_persists": True}
# The matrix patterns (with a zero on the diagonal) of the last KEEP Jacobians on which PETSc's LU met
# a zero pivot in this process, and the LU Newton went on to (Newton._skip_doomed_lu).
KEEP = 8
# An unpivoted LU reached after a zero pivot whose Newton then fails hands over to the next LU only if its
# factor is inaccurate (backward error above this): a step too large for Newton fails with any LU, and the
# pivoting LUs are 3-10x slower for the rest of the run (measured: chain-1000 at 256 links, 200 steps, serial
# 76 ms/step after SuperLU took over at the first failed step, against 27 on two ranks, whose partial LUs stay).
ACCURATE_LU = 1e-8
_ZERO_PIVOTS = {}


def pattern_key(A):
    """A digest of a sequential AIJ matrix's nonzero pattern (its size and CSR structure)."""
    import hashlib

    from rodfem.fem import petsc_raw
    i, j = petsc_raw.rowij(petsc_raw.blocks(A)[0])
    h = hashlib.sha256()
    h.update(i)   # (rowij: contiguous copies)
    h.update(j)
    return (A.getSize(), h.hexdigest())


@dataclass
class Solve:
    iterations: int
    residual: float


_REASONS = {v: k for k, v in vars(PETSc.SNES.ConvergedReason).items() if not k.startswith("_")}
_LIVE = weakref.WeakSet()      # the Newtons alive: their SNES are destroyed before PETSc finalizes
_COUNTER = itertools.count()   # (rodfem/la/schur.py's _clean_up frees the ones Python has dropped)


@atexit.register   # registered after petsc4py's finalization, so it runs before it
def _destroy_solvers():
    """Destroy the SNES of every Newton still alive at exit (a script's global System), collectively,
    while Python still runs: PETSc's finalization would otherwise destroy a parallel solver's
    Python preconditioner (rodfem/la/schur.py) by calling back into a finished interpreter
    (a segmentation fault at exit, after the results)."""
    if PETSc.Sys.isInitialized() and not PETSc.Sys.isFinalized():
        for newton in sorted(_LIVE, key=lambda nw: nw.serial):
            if newton.snes is not None:
                newton.snes.destroy()
                newton.snes = None


class Newton:
    """Solves F(X) = 0 for the unknown of `assembler` (rodfem/fem/assembly.py: a system of
    bodies), or for the Function `x` of the compiled forms F, J = dF/dx with Dirichlet
    conditions bcs (one block)."""

    def __init__(self, F=None, J=None, x=None, bcs=(), options=None, prefix="rodfem_", assembler=None):
        self.standalone = assembler is None   # a form of its own: x is the state between solves
        if assembler is None:
            from rodfem.fem.assembly import BlockAssembler, BlockLayout, BodyBlock
            assembler = BlockAssembler(BlockLayout(x.function_space.mesh.comm, [x.function_space]),
                                       [BodyBlock(F, J, x, bcs)])
        self.assembler = assembler
        comm = self.assembler.comm
        self.b = self.assembler.create_vector()
        self.A = self.assembler.create_matrix()
        self.xv = self.assembler.vector
        self.settings = dict(DEFAULTS, **(SERIAL if comm.size == 1 else PARALLEL))
        if self.A.getSize()[0] >= LARGE:
            self.settings.update(LARGE_SETTINGS)
        self.settings.update(options or {})
        self.line_search = self.settings["snes_linesearch_type"]
        if int(self.settings.get("snes_lag_jacobian", 1)) > 1 and "snes_linesearch_type" not in (options or {}):
            # a chord Newton's direction (an old Jacobian) need not descend |F|: its full steps (basic), as before
            self.settings["snes_linesearch_type"] = "basic"
        self.prefix = prefix
        self.timings = {"F": 0.0, "J": 0.0}   # seconds spent assembling residuals and Jacobians
        self._first_serial_lu = comm.size == 1 and lu_name(self.settings) == "petsc"
        self._pattern = None   # (its digest, when the first Jacobian has a zero on its diagonal)
        self.snes = None
        self.restart()
        self.serial = next(_COUNTER)   # the order of creation: the same on every rank
        _LIVE.add(self)
        self._work, self._start = self.xv.duplicate(), self.xv.duplicate()

    def restart(self):
        """A new SNES with the same settings, matrix and vectors: what a resumed run starts with
        (a chord Newton's lagged Jacobian then restarts at the same step in both runs)."""
        snes = PETSc.SNES().create(self.assembler.comm)
        snes.setOptionsPrefix(self.prefix)
        snes.setFunction(self._residual, self.b)
        snes.setJacobian(self._jacobian, self.A)
        if self.snes is not None:
            self.snes.destroy()
        self.snes = snes
        self._configure(self.settings)

    @property
    def bcs(self):
        return self.assembler.bcs

    def _residual(self, snes, xin, b):
        t0 = time.perf_counter()
        self.assembler.residual(xin, b)
        self.timings["F"] += time.perf_counter() - t0

    def _jacobian(self, snes, xin, A, P):
        t0 = time.perf_counter()
        self.assembler.jacobian(xin, A)
        if self._first_serial_lu:
            self._first_serial_lu = False
            if self._petsc_lu_as_set():
                if first_lu(A) == "schur":   # (a net: no band)
                    self.use_lu("schur")
                else:
                    self._skip_doomed_lu(A)
        self.timings["J"] += time.perf_counter() - t0

    def _skip_doomed_lu(self, A):
        """The first Jacobian, serial, PETSc's LU running as set, a zero on the diagonal (multipliers): if
        PETSc's LU met a zero pivot on this matrix pattern before in this process (a system built
        again: a parameter study, a scene run again), go straight to the LU Newton went on to then,
        before the PC is set up.  (A zero diagonal alone does not doom PETSc's LU in RCM order: the
        four-bar's joint multipliers get their pivots from the fill.)  A failed factorization costs
        the first step a factorization and a repeated Newton solve (issue 26: 1.4 of the 6.6 ms of
        the 16-element 3D rod's first step)."""
        from rodfem.fem import petsc_raw
        diagonal = A.getDiagonal()
        try:
            zero = not diagonal.getArray(readonly=True).all()
        finally:
            diagonal.destroy()
        if not zero or not petsc_raw.usable():
            return
        self._pattern = pattern_key(A)
        following = _ZERO_PIVOTS.get(self._pattern)
        if following is not None:
            self.use_lu(following)

    def _petsc_lu_as_set(self):
        """Whether PETSc's LU runs as Newton set it (the user's -rodfem_pc_* options may have chosen another)."""
        opts = PETSc.Options()   # (ours are removed after each configuration: what is left is the user's)
        if any(opts.hasName(self.prefix + key) for key in ("pc_type", "pc_factor_mat_solver_type",
                                                           "pc_factor_mat_ordering_type")):
            return False
        pc = self.snes.getKSP().getPC()
        return pc.getType() == "lu" and pc.getFactorSolverType() == "petsc"

    def _configure(self, settings):
        """Apply `settings` through the options database for this SNES only: the user's own
        -rodfem_* options win, and ours are removed again so that they do not leak into the
        next Problem of the process."""
        opts, ours = PETSc.Options(), []
        for key, value in settings.items():
            if not opts.hasName(self.prefix + key):
                opts[self.prefix + key] = value
                ours.append(self.prefix + key)
        try:
            self.snes.setFromOptions()
            self.snes.getKSP().setFromOptions()
        except PETSc.Error as e:
            raise petsc_error(e, "PETSc refused an option") from None
        finally:
            for name in ours:
                opts.delValue(name)

    @property
    def linear_solver(self):
        pc = self.snes.getKSP().getPC()
        if pc.getType() == "python":
            context = pc.getPythonContext()
            return context.describe() if hasattr(context, "describe") else "python"
        solver = pc.getFactorSolverType()
        return lu_name(self.settings) if solver == "petsc" else solver

    def use_lu(self, name):
        """Factor with LU_CHAIN[name] from now on (the PC set up again at the next solve)."""
        for key in ("pc_type", "pc_python_type", "pc_factor_mat_solver_type", "pc_factor_mat_ordering_type"):
            self.settings.pop(key, None)
        self.settings.update(LU_CHAIN[name])
        if name == "mumps":
            mumps_options(self.prefix)
        pc = self.snes.getKSP().getPC()   # (the rest of the SNES keeps its configuration)
        pc.reset()
        pc.setType(LU_CHAIN[name]["pc_type"])
        if name == "schur":
            from rodfem.fem import petsc_raw
            pc.setPythonType(LU_CHAIN[name]["pc_python_type"])
            petsc_raw.pc_set_failed(pc, False)
            return
        pc.setFactorSolverType(LU_CHAIN[name]["pc_factor_mat_solver_type"])
        if "pc_factor_mat_ordering_type" in LU_CHAIN[name]:
            pc.setFactorOrdering(LU_CHAIN[name]["pc_factor_mat_ordering_type"])

    def solve(self, step, t):
        """Solve in place for x; raise NewtonFailure, x left at the initial guess (never a NaN state).

        A chord Newton (``snes_lag_jacobian`` > 1: the Jacobian and its LU reused over
        iterations) that fails repeats the step with a fresh Jacobian every iteration.
        """
        if self.standalone:
            self.assembler.pull()
        self.xv.copy(self._start)  # the initial guess (the callbacks overwrite x with each iterate)
        return self._solve(step, t)

    def _solve(self, step, t):
        self._start.copy(self._work)
        try:
            self.snes.solve(None, self._work)
        except PETSc.Error as e:  # not a divergence (that is a converged reason), but PETSc giving up
            raise petsc_error(e, f"PETSc stopped at step {step} (t = {t:.6g})") from None
        reason = self.snes.getConvergedReason()
        lu = lu_name(self.settings)
        switched = lu != "petsc" and lu not in PIVOTING   # an unpivoted LU reached after a zero pivot
        serial_chain = self.A.getComm().getSize() == 1 and lu in LU_CHAIN   # (the parallel solver's is inside it)
        if serial_chain and (reason == PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE
                             or (reason <= 0 and switched and not self._lu_accurate())):
            following = next_lu(self.A, lu)
            if following is not None:
                if lu == "petsc" and self._pattern is not None:   # (remembered for the next Newton on it)
                    _ZERO_PIVOTS.pop(self._pattern, None)
                    if len(_ZERO_PIVOTS) >= KEEP:
                        _ZERO_PIVOTS.pop(next(iter(_ZERO_PIVOTS)))
                    _ZERO_PIVOTS[self._pattern] = following
                self.use_lu(following)
                return self._solve(step, t)
        its = self.snes.getIterationNumber()
        res = self.snes.getFunctionNorm()
        if reason == PETSc.SNES.ConvergedReason.DIVERGED_FNORM_NAN:
            res = float("nan")  # PETSc leaves the last finite norm (0 at the first iteration)
        if reason <= 0 or res != res:
            if int(self.settings.get("snes_lag_jacobian", 1)) > 1:
                return self._solve_full_newton(step, t)
            self.assembler.update(self._start)   # x back to the initial guess, not the last iterate
            raise NewtonFailure(step, t, res, its, _REASONS.get(reason, str(reason)))
        self.assembler.update(self._work)
        return Solve(its, res)

    def _lu_accurate(self):
        """Whether the last factor of the Jacobian solves to a backward error <= ACCURATE_LU (an unpivoted
        LU's small pivot loses digits; a Newton failure with an accurate factor is the step's, not the
        LU's: a pivoting LU fails it too, slower).  A Jacobian with non-finite entries (a diverged
        iterate) says nothing of the LU: accurate."""
        e = backward_error(self.A, self.snes.getKSP().solve)
        return not e > ACCURATE_LU   # (nan: accurate)

    def _solve_full_newton(self, step, t):
        chord = self.settings
        self.settings = {**chord, "snes_lag_jacobian": 1, "snes_linesearch_type": self.line_search}
        self._configure(self.settings)
        try:
            return self._solve(step, t)
        finally:
            for key in ("pc_type", "pc_python_type", "pc_factor_mat_solver_type", "pc_factor_mat_ordering_type"):
                chord.pop(key, None)
                if key in self.settings:
                    chord[key] = self.settings[key]
            self.settings = chord
            self._configure(chord)
