"""The oscillatory eigenvalues of a sparse matrix pencil, A y = s E y, each one verified.

E is singular: a descriptor system's algebraic rows (constraints, constitutive relations, a
viscoelastic branch's internal strains) have E = 0.  Wanted are the oscillations

    s = -zeta |s| + i omega,    omega > OSCILLATORY |s|,   Re s <= GROWTH |s|,

of lowest omega (the damped frequencies and damping ratios zeta of rodfem/analysis/linearize.py).
Not wanted, and never to be confused with them: the infinite eigenvalues of the algebraic rows
(Jordan chains of length up to 3 for position-level constraints), the real ones (a mechanism's
double zero, the relaxation of a Maxwell branch: a 3n-fold -1/(tau (1 + alpha)) for n elements)
and the roundoff that perturbs both.

Equilibration.  A strain row carries EA/h ~ 1e9, a kinematic row 1: D_r (A, E) D_c (Ruiz: unit
max-norm rows and columns of |A| + |E|) has the same eigenvalues and the eigenvectors
x = D_c y.  Everything below works on it (QZ on the raw pencil of four-bar-2d at 50 elements
was 2e-4 off in its 6th frequency).

Dense: QZ of the whole pencil (scipy.linalg.eigvals): complete, every eigenvalue is seen.

SLEPc: Krylov-Schur on the real operator T = (A - sigma E)^-1 E, sigma > 0 (SHIFT) to the right
of a stable spectrum, so A - sigma E is regular even with a mechanism's zero eigenvalues.  An
eigenvalue theta of T is s = sigma + 1/theta, so

    Im theta = -omega / |s - sigma|^2,   = 0 for every real s,   theta = 0 for every infinite s:

the eigenvalues of largest |Im theta| (`LARGEST_IMAGINARY`) are the oscillations with omega
nearest sigma on a log scale (omega / (omega^2 + sigma^2) falls on both sides of sigma); neither
the real eigenvalues, however clustered or many, nor the infinite ones compete (shift-invert about
a target by |s - target| drowns in the relaxation cluster when it lies nearer than the first
frequency, and about 0 factors a singular A).  The start vector is T^3 r (no component on the
Jordan chains of the infinite eigenvalues), the vectors are purified once more, y = T v.  As
usual for a Krylov method, the nev converged pairs are taken to be all eigenvalues with |Im theta|
above the nev-th one's: for light damping every oscillation with omega in the band
(sigma^2 / omega_hi, omega_hi).  A heavily damped mode has a smaller |Im theta| than an undamped
one of its frequency and may be missed (the dense solver has no such limit).  With sigma far
below the spectrum (a stiff mechanism: T's largest eigenvalues are its zeros at -1/sigma, the
wanted ones sink toward the roundoff of the infinite ones) a failed pass is repeated once about
half the lowest frequency it found.

Refinement (both solvers): each estimate (s0, y0) takes two steps of inverse iteration with the
complex LU of A - s0 E, and s = s0 + 1/(y^H (A - s0 E)^-1 E y); an estimate that moves by more
than REFINE_TOL |s0| is discarded.  Dense and SLEPc then agree to ~1e-14.

Verification (both solvers): the backward error

    eta = |A y - s E y|_1 / ((|A|_1 + |s| |E|_1) |y|_1) <= RESIDUAL_TOL    (equilibrated pencil)

and the row-wise one: every row i of A y - s E y is small against its own terms,

    omega = max_i |A y - s E y|_i / (r_i + ROW_FLOOR max_j r_j) <= ROW_TOL,   r = |A| |y| + |s| |E| |y|.

The second test is needed: a pair that roundoff made out of an infinite eigenvalue (SLEPc
converges such pairs at |theta| ~ eps^(1/3) |T| once the finite spectrum near the shift is
exhausted, e.g. the slider crank's, which has only a double zero) has a small eta (any huge s has),
but leaves some row wholly unbalanced: omega = 1, against omega <= 5e-6 for the true modes of
four-bar-2d, viscoelastic-cantilever-2d/3d.  A pair that fails either test is not a result.
"""
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

OSCILLATORY = 1e-4    # omega > 1e-4 |s|: an oscillation (the roundoff on a real cluster stays below 1e-6)
GROWTH = 1e-6         # Re s <= 1e-6 |s|: not growing (a flutter or an unstable state is not a natural mode)
ZERO = 1e-9           # |s| <= 1e-9 of the median |s|: a zero eigenvalue (neutral; no sign to read)
SHIFT = 1.0           # rad/s: the real shift sigma of the SLEPc operator
RESIDUAL_TOL = 1e-10  # backward error of a verified eigenpair
ROW_TOL = 1e-3        # row-wise backward error of a verified eigenpair
ROW_FLOOR = 1e-6      # rows below 1e-6 of the largest one are measured against 1e-6 of it
TOL_SLEPC = 1e-12     # Krylov-Schur's relative tolerance on theta (`refine` does the rest)
REFINE_TOL = 1e-4     # an estimate that refinement moves by more than 1e-4 |s| is not one


class NotVerified(Exception):
    """The SLEPc result cannot be certified (too few verified pairs, no convergence, a PETSc error)."""


class SingularPencil(Exception):
    """A - sigma E is singular at two shifts: the pencil is singular (det(A - s E) = 0 for all s)."""


@dataclass
class Modes:
    """The k lowest verified oscillations: eigenvalues s (Im s ascending), vectors x (columns, the
    pencil's own variables), their backward errors eta; `info` says how they were found."""
    s: np.ndarray
    vectors: np.ndarray
    residuals: np.ndarray
    info: dict = field(default_factory=dict)


def equilibrate(A, E, sweeps=5):
    """Diagonal scalings (d_r, d_c) with unit max-norm rows and columns of diag(d_r) (|A| + |E|) diag(d_c)."""
    M = (abs(A) + abs(E)).tocsr()
    dr, dc = np.ones(M.shape[0]), np.ones(M.shape[1])
    for _ in range(sweeps):
        rows = np.sqrt(abs(sp.diags(dr) @ M @ sp.diags(dc)).max(axis=1).toarray().ravel())
        dr /= np.where(rows > 0, rows, 1.0)
        cols = np.sqrt(abs(sp.diags(dr) @ M @ sp.diags(dc)).max(axis=0).toarray().ravel())
        dc /= np.where(cols > 0, cols, 1.0)
    return dr, dc


def oscillating(s):
    """The wanted eigenvalues: omega = Im s > OSCILLATORY |s| and Re s <= GROWTH |s|."""
    return (s.imag > OSCILLATORY * np.abs(s)) & (s.real <= GROWTH * np.abs(s))


def _solver(lu, complex_lu):
    """B -> lu^-1 B for real or complex B (a real LU solves the real and imaginary parts apart)."""
    def solve(B):
        if np.iscomplexobj(B) and not complex_lu:
            return lu.solve(np.ascontiguousarray(B.real)) + 1j * lu.solve(np.ascontiguousarray(B.imag))
        return lu.solve(np.ascontiguousarray(B, dtype=complex if complex_lu else float))
    return solve


class Pencil:
    """The equilibrated pencil (A, E): its LUs, refinement and verification of eigenpairs."""

    def __init__(self, A, E):
        self.dr, self.dc = equilibrate(A, E)
        Dr, Dc = sp.diags(self.dr), sp.diags(self.dc)
        self.A, self.E = (Dr @ A @ Dc).tocsc(), (Dr @ E @ Dc).tocsc()
        self.n = self.A.shape[0]
        self.norm_A, self.norm_E = sp.linalg.norm(self.A, 1), sp.linalg.norm(self.E, 1)

    def solver(self, s):
        """B -> (A - s E)^-1 B (a sparse LU), or None if A - s E is exactly singular."""
        M = (self.A - s * self.E).tocsc()
        try:
            lu = splu(M.astype(complex) if np.iscomplexobj(s) else M)
        except RuntimeError:   # "Factor is exactly singular"
            return None
        return _solver(lu, np.iscomplexobj(s))

    def shift_invert(self, sigma):
        """(sigma, x -> T x) with T = (A - sigma E)^-1 E, at sigma or 1.37 sigma if that is an eigenvalue."""
        for shift in (sigma, 1.37 * sigma):
            solve = self.solver(shift)
            if solve is not None:
                return shift, lambda x, solve=solve: solve(self.E @ x)
        raise SingularPencil(f"A - s E is singular at s = {sigma:g} and {1.37 * sigma:g}")

    def refine(self, s0, y0):
        """(s, y) from an estimate (s0, y0): two steps of inverse iteration y <- (A - s0 E)^-1 E y and
        the Rayleigh quotient of that operator, 1/(s - s0) = y^H (A - s0 E)^-1 E y (|y| = 1); None
        if s moved by more than REFINE_TOL |s0| (s0 was not an eigenvalue's estimate)."""
        solve = self.solver(complex(s0)) or self.solver(complex(s0) * (1 + 1e-12))
        if solve is None:
            return None
        y = solve(self.E @ y0)
        y /= np.linalg.norm(y) or 1.0
        z = solve(self.E @ y)
        nu = np.vdot(y, z)
        s = s0 + 1.0 / nu if nu != 0 else np.inf
        if not abs(s - s0) <= REFINE_TOL * abs(s0):
            return None
        return s, z / np.linalg.norm(z)

    def verify(self, s, y):
        """(eta, omega): the backward error and the row-wise one of the pair (s, y) (module docstring)."""
        R = abs(self.A @ y - s * (self.E @ y))
        eta = R.sum() / ((self.norm_A + abs(s) * self.norm_E) * np.linalg.norm(y, 1))
        rows = abs(self.A) @ abs(y) + abs(s) * (abs(self.E) @ abs(y))
        omega = np.max(R / (rows + ROW_FLOOR * rows.max()))
        return eta, omega

    def verified(self, estimates, k):
        """The first k verified pairs (s ascending in Im s) refined from `estimates` [(s0, y0)], and
        (the number that failed, the lowest frequency that failed or inf)."""
        keep, failed, lowest = [], 0, np.inf
        for s0, y0 in sorted(estimates, key=lambda e: e[0].imag):
            if len(keep) == k:
                break
            pair = self.refine(s0, y0)
            if pair is not None and oscillating(np.array([pair[0]]))[0]:
                eta, omega = self.verify(*pair)
                if eta <= RESIDUAL_TOL and omega <= ROW_TOL:
                    keep.append((pair[0], pair[1], eta))
                    continue
            failed, lowest = failed + 1, min(lowest, s0.imag)
        return keep, failed, lowest

    def modes(self, pairs, info):
        """Modes of verified (s, y, eta), the vectors back in the pencil's own variables x = D_c y."""
        s = np.array([p[0] for p in pairs], dtype=complex)
        Y = np.column_stack([p[1] for p in pairs]) if pairs else np.zeros((self.n, 0), complex)
        return Modes(s, self.dc[:, None] * Y, np.array([p[2] for p in pairs], dtype=float), info)


def growing_eigenvalues(p, limit=50):
    """The verified eigenvalues with Re s > GROWTH |s| (real or complex: an unstable equilibrium's
    divergence e^{sigma t}, or a flutter), from QZ of the whole pencil, ascending in |s|, and the
    number of finite eigenvalues |s| <= ZERO of the median |s| (a mechanism's or free body's
    zeros: neutral, neither growing nor decaying, and too close to 0 for a sign).  Of the
    candidates (at most `limit`, smallest |s| first) each is refined and verified as the modes
    are (`refine`, `verify`): roundoff images of the infinite eigenvalues are not results.
    Returns (s verified, zeros, candidates tried, candidates rejected)."""
    import scipy.linalg
    w = scipy.linalg.eigvals(p.A.toarray(), p.E.toarray())
    w = w[np.isfinite(w)]
    if not len(w):
        return np.zeros(0, complex), 0, 0, 0
    scale = float(np.median(np.abs(w)))
    zero = np.abs(w) <= ZERO * scale
    candidates = w[~zero & (w.real > GROWTH * np.abs(w)) & (w.imag >= 0)]
    candidates = candidates[np.argsort(np.abs(candidates))][:limit]
    rng = np.random.default_rng(12)
    keep, rejected = [], 0
    for s0 in candidates:
        pair = p.refine(complex(s0), rng.standard_normal(p.n) + 0j)
        if pair is not None and pair[0].real > GROWTH * abs(pair[0]):
            eta, omega = p.verify(*pair)
            if eta <= RESIDUAL_TOL and omega <= ROW_TOL:
                keep.append(pair[0])
                continue
        rejected += 1
    return np.array(keep, dtype=complex), int(np.sum(zero)), len(candidates), rejected


def dense_modes(p, k):
    """The k lowest verified oscillations by QZ (all eigenvalues; vectors by `refine` from random ones)."""
    import scipy.linalg
    w = scipy.linalg.eigvals(p.A.toarray(), p.E.toarray())
    w = w[np.isfinite(w)]
    real = np.abs(w.imag) <= OSCILLATORY * np.abs(w)
    growing = int(np.sum((w.imag > OSCILLATORY * np.abs(w)) & (w.real > GROWTH * np.abs(w))))
    candidates = np.sort_complex(w[oscillating(w)] * -1j) * 1j          # ascending Im s
    rng = np.random.default_rng(12)
    keep, failed, lowest = [], 0, np.inf
    for start in range(0, len(candidates), k):                           # k at a time: failures need more
        random = [rng.standard_normal(p.n) + 1j * rng.standard_normal(p.n) for _ in candidates[start:start + k]]
        more, fails, low = p.verified(list(zip(candidates[start:start + k], random)), k - len(keep))
        keep, failed, lowest = keep + more, failed + fails, min(lowest, low)
        if len(keep) == k or failed > k + 20:
            break
    info = {"solver": "dense", "finite_eigenvalues": len(w), "real_eigenvalues": int(np.sum(real)),
            "growing_oscillations": growing, "oscillations": len(candidates), "rejected": failed,
            "rejected_below_rad_s": float(lowest) if keep and lowest < keep[-1][0].imag else None}
    return p.modes(keep, info)


def slepc_modes(p, k, shift=SHIFT):
    """The k lowest verified oscillations by Krylov-Schur on T (LARGEST_IMAGINARY), or NotVerified.

    If the pass at `shift` fails and its lowest oscillation lies above 10 shift (the shift far
    below the spectrum, where T's largest eigenvalues are a mechanism's zeros and the wanted ones
    sink to the roundoff of the infinite ones), a second pass shifts to half that frequency."""
    try:
        return _slepc_pass(p, k, shift)
    except NotVerified as first:
        lowest = getattr(first, "lowest", np.inf)
        if not (np.isfinite(lowest) and lowest > 10 * shift):
            raise
        try:
            return _slepc_pass(p, k, lowest / 2)
        except NotVerified as second:
            raise NotVerified(f"{first}; {second}") from None


def _slepc_pass(p, k, shift):
    sigma, T = p.shift_invert(shift)
    nev = min(2 * k + 4, p.n - 1)
    theta, V = _krylov_schur(T, p.n, nev)
    if len(theta) < nev:
        raise NotVerified(f"SLEPc converged {len(theta)} of {nev} eigenvalues")
    order = np.argsort(-np.abs(theta.imag), kind="stable")[:nev]
    theta, V = theta[order], V[:, order]
    s = sigma + 1.0 / theta
    wanted = np.flatnonzero(oscillating(s))
    keep, failed, lowest = p.verified([(s[j], T(V[:, j])) for j in wanted], k)
    if len(keep) < k or (failed and lowest < keep[-1][0].imag):
        why = NotVerified(f"{failed} of the {len(wanted)} oscillations SLEPc found about {sigma:.4g} rad/s fail the "
                          f"residual check, the lowest at {lowest:.4g} rad/s" if failed else
                          f"SLEPc found {len(wanted)} oscillations of {k} about {sigma:.4g} rad/s")
        why.lowest = min([lowest] + [s[j].imag for j in wanted])
        raise why
    level = abs(theta[-1].imag)
    hi = (1 / level + np.sqrt(max(1 / level**2 - 4 * sigma**2, 0.0))) / 2 if level > 0 else np.inf
    return p.modes(keep, {"solver": "slepc", "shift": sigma, "band_rad_s": [sigma**2 / hi, hi],
                          "rejected": failed, "converged": int(nev)})


def _krylov_schur(T, n, nev):
    """(theta, V): the converged eigenpairs of T (a function x -> T x) by SLEPc, largest |Im theta| first."""
    import slepc4py
    slepc4py.init()
    from petsc4py import PETSc
    from slepc4py import SLEPc

    class Operator:
        def mult(self, mat, x, y):
            y.setArray(T(x.getArray(readonly=True)))

    start = np.random.default_rng(3).standard_normal(n)
    for _ in range(3):            # no component on the Jordan chains of the infinite eigenvalues
        start = T(start)
    M = PETSc.Mat().createPython([n, n], Operator(), comm=PETSc.COMM_SELF)
    M.setUp()
    eps = SLEPc.EPS().create(comm=PETSc.COMM_SELF)
    vr, vi = M.createVecs()
    x0 = M.createVecs("right")
    try:
        eps.setOperators(M)
        eps.setProblemType(SLEPc.EPS.ProblemType.NHEP)
        eps.setDimensions(nev=nev, ncv=min(max(2 * nev + 10, 30), n))
        eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_IMAGINARY)
        eps.setTolerances(TOL_SLEPC, 1000)
        x0.setArray(start / np.linalg.norm(start))
        eps.setInitialSpace([x0])
        eps.solve()
        pairs = [(eps.getEigenpair(i, vr, vi), vr.getArray() + 1j * vi.getArray()) for i in range(eps.getConverged())]
    except PETSc.Error as e:
        lines = str(e).strip().splitlines()
        raise NotVerified(f"SLEPc failed ({lines[-1] if lines else 'PETSc error'})") from None
    finally:
        for obj in (eps, M, vr, vi, x0):
            obj.destroy()
    theta = np.array([t for t, _ in pairs], dtype=complex)
    V = np.column_stack([v for _, v in pairs]) if pairs else np.zeros((n, 0), complex)
    return theta, V
