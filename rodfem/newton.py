"""Newton's method for the step residual F(x_{n+1}) = 0 with a petsc4py SNES.

Jacobian J = dF/dx_{n+1} from ufl.derivative; forms are compiled once and
reused every step.  Direct LU: PETSc's own in serial (3x faster than MUMPS on
these banded systems), MUMPS in parallel.  PETSc's LU does not pivot, so a
zero pivot (saddle points: multipliers, zero densities in statics) makes it
fail; the solver then switches once, for the rest of the run, to a pivoting
LU (serial SuperLU, measured 1.45x faster than MUMPS on the 3D rod; MUMPS in
parallel) and repeats the step (`Newton.linear_solver` tells which one ran).
(Not superlu_dist: it crashes at exit on this stack.)  Every setting can be overridden
from the PETSc options database with the prefix ``rodfem_`` (e.g.
``PETSC_OPTIONS="-rodfem_snes_atol 1e-12"``).
"""
import os
import re
import time
from dataclasses import dataclass

from dolfinx.fem import petsc as fpetsc
from petsc4py import PETSc

from . import compat
from .errors import InputError

# Converged when |F| <= 1e-10, |F| <= 1e-12 |F_0|, or the Newton update is at
# round-off, |dx| <= 1e-14 |x| (stiff problems: the residual carries round-off
# ~ eps * stiffness, e.g. 2e-9 for EA = 1e7, while x is converged to the last digit).
DEFAULTS = {"snes_type": "newtonls", "snes_linesearch_type": "basic",
            "snes_atol": 1e-10, "snes_rtol": 1e-12, "snes_stol": 1e-14, "snes_max_it": 25,
            "ksp_type": "preonly", "pc_type": "lu"}


class NewtonFailure(RuntimeError):
    """Newton did not converge in a time step."""

    def __init__(self, step, t, residual, iterations, reason):
        self.step, self.t, self.residual, self.iterations, self.reason = step, t, residual, iterations, reason
        super().__init__(f"Newton failed at step {step} (t = {t:.6g}): residual {residual:.3e} "
                         f"after {iterations} iterations ({reason})")


@dataclass
class Solve:
    iterations: int
    residual: float


_REASONS = {v: k for k, v in vars(PETSc.SNES.ConvergedReason).items() if not k.startswith("_")}


def petsc_error(error, what):
    """InputError for an error PETSc raised (a refused option, a solver package it lacks, no memory):
    what failed, PETSc's last message line (the reason) and PETSC_OPTIONS."""
    lines = [ln.strip() for ln in str(error).splitlines() if ln.strip()]
    reason = re.sub(r"^\[\d+\]\s*", "", lines[-1]) if lines else str(error)
    options = f" (PETSC_OPTIONS={os.environ['PETSC_OPTIONS']!r})" if os.environ.get("PETSC_OPTIONS") else ""
    return InputError(f"{what}{options}: {reason}; rodfem's solver options have the prefix -rodfem_, "
                      f"e.g. -rodfem_snes_max_it 50")


class FormAssembler:
    """F(x) and J(x) of one mixed space: compiled forms F, J, the state Function x, Dirichlet bcs."""

    def __init__(self, F, J, x, bcs):
        self.F, self.J, self.x, self.bcs = F, J, x, bcs
        self.comm = x.function_space.mesh.comm
        self.vector = compat.petsc_vec(x)   # the unknown, as the PETSc vector Newton iterates on

    def create_vector(self):
        return compat.create_vector(self.F)

    def create_matrix(self):
        return fpetsc.create_matrix(self.J)

    def update(self, xin):
        """Make the forms see the iterate xin (copied into x, ghosts updated)."""
        xin.copy(self.vector)
        self.vector.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)

    def residual(self, xin, b):
        self.update(xin)
        with b.localForm() as bl:
            bl.set(0.0)
        fpetsc.assemble_vector(b, self.F)
        fpetsc.apply_lifting(b, [self.J], bcs=[self.bcs], x0=[self.vector], scale=-1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fpetsc.set_bc(b, self.bcs, self.vector, -1.0)

    def jacobian(self, xin, A):
        A.zeroEntries()
        fpetsc.assemble_matrix(A, self.J, bcs=self.bcs)
        A.assemble()


class Newton:
    """Solves F(x) = 0 for the Function `x` (F, J compiled forms, bcs Dirichlet conditions),
    or, with `assembler=`, for any unknown an assembler provides (a system of bodies)."""

    def __init__(self, F=None, J=None, x=None, bcs=(), options=None, prefix="rodfem_", assembler=None):
        self.assembler = assembler or FormAssembler(F, J, x, list(bcs))
        comm = self.assembler.comm
        self.b = self.assembler.create_vector()
        self.A = self.assembler.create_matrix()
        self.xv = self.assembler.vector
        self.settings = dict(DEFAULTS)
        self.settings["pc_factor_mat_solver_type"] = "petsc" if comm.size == 1 else "mumps"
        self.settings.update(options or {})
        self.prefix = prefix
        self.snes = PETSc.SNES().create(comm)
        self.snes.setOptionsPrefix(prefix)
        self.timings = {"F": 0.0, "J": 0.0}   # seconds spent assembling residuals and Jacobians
        self.snes.setFunction(self._residual, self.b)
        self.snes.setJacobian(self._jacobian, self.A)
        self._configure(self.settings)
        self._work, self._start = self.xv.duplicate(), self.xv.duplicate()

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
        self.timings["J"] += time.perf_counter() - t0

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
        return self.snes.getKSP().getPC().getFactorSolverType()

    def solve(self, step, t):
        """Solve in place for x; raise NewtonFailure (never return a NaN state).

        A chord Newton (``snes_lag_jacobian`` > 1: the Jacobian and its LU reused over
        iterations) that fails repeats the step with a fresh Jacobian every iteration.
        """
        self.xv.copy(self._start)  # the initial guess (the callbacks overwrite x with each iterate)
        return self._solve(step, t)

    def _solve(self, step, t):
        self._start.copy(self._work)
        try:
            self.snes.solve(None, self._work)
        except PETSc.Error as e:  # not a divergence (that is a converged reason), but PETSc giving up
            raise petsc_error(e, f"PETSc stopped at step {step} (t = {t:.6g})") from None
        reason = self.snes.getConvergedReason()
        if reason == PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE and self.linear_solver == "petsc":
            self.settings["pc_factor_mat_solver_type"] = "superlu" if self.snes.comm.size == 1 else "mumps"
            pc = self.snes.getKSP().getPC()
            pc.reset()
            pc.setFactorSolverType(self.settings["pc_factor_mat_solver_type"])
            return self._solve(step, t)
        its = self.snes.getIterationNumber()
        res = self.snes.getFunctionNorm()
        if reason == PETSc.SNES.ConvergedReason.DIVERGED_FNORM_NAN:
            res = float("nan")  # PETSc leaves the last finite norm (0 at the first iteration)
        if reason <= 0 or res != res:
            if int(self.settings.get("snes_lag_jacobian", 1)) > 1:
                return self._solve_full_newton(step, t)
            raise NewtonFailure(step, t, res, its, _REASONS.get(reason, str(reason)))
        self.assembler.update(self._work)
        return Solve(its, res)

    def _solve_full_newton(self, step, t):
        chord = self.settings
        self.settings = {**chord, "snes_lag_jacobian": 1}
        self._configure(self.settings)
        try:
            return self._solve(step, t)
        finally:
            chord["pc_factor_mat_solver_type"] = self.settings["pc_factor_mat_solver_type"]
            self.settings = chord
            self._configure(chord)
