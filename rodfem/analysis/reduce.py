"""Structure-preserving reduction of the linear port-Hamiltonian model by tangential interpolation.

The full model (rodfem/analysis/linearize.py) is the PH descriptor system

    E x' = (J - R) Q x + B u,    y = B^T Q x (= C x),    H = 1/2 x^T E^T Q x,

G(s) = C (s E - A)^{-1} B its transfer function, A = (J - R) Q.  The reduced model of order r is the
Petrov-Galerkin projection x ~ V x_r tested with W = Q V (the effort constraint of Polyuga & van der
Schaft, "Structure preserving model reduction of port-Hamiltonian systems by moment matching at
infinity", Automatica 46 (2010) 665-672, doi:10.1016/j.automatica.2010.01.018; with V from
tangential rational Krylov directions as in Gugercin, Polyuga, Beattie & van der Schaft,
"Structure-preserving tangential interpolation for model reduction of port-Hamiltonian systems",
Automatica 48 (2012) 1963-1974, doi:10.1016/j.automatica.2012.05.052), written in the same
descriptor form:

    E_r = V^T Q^T E V,   J_r = W^T J W,   R_r = W^T R W,   Q_r = I,   B_r = W^T B,   C_r = B_r^T = C V,

so that E_r x_r' = (J_r - R_r) x_r + B_r u, y_r = B_r^T x_r, H_r = 1/2 x_r^T E_r x_r.  It is port-
Hamiltonian by construction: J_r is skew, R_r = W^T R W >= 0 and E_r^T Q_r = V^T (E^T Q) V is
symmetric and >= 0 wherever the full model's E^T Q is (J_r and R_r are made exactly skew and
symmetric; the round-off they drop is reported).  Hence the reduced model is passive and can be
interconnected like the full one.  (With E = I this is the reduced model of Gugercin et al., in the
basis x_r' = (V^T Q V) x_r of theirs.)

Interpolation (right tangential, for any W): with V containing v_j = (s_j E - A)^{-1} B b_j,

    G_r(s_j) b_j = G(s_j) b_j       (and at the conjugate points: V is real, spanned by Re v_j, Im v_j)

because (s_j E_r - A_r) xi = B_r b_j is solved by V xi = v_j.  Each complex point gives two real
columns: order r uses r/2 points.  The points (the default of `points`): s_j = alpha + i omega_j at
the full model's first r/2 natural frequencies omega_j (rodfem/analysis/linearize.py, natural_modes),
alpha = ALPHA omega_1 (just off the imaginary axis, where an undamped model's G has its poles); the
direction b_j: the leading right singular vector of G(s_j) (at a repeated frequency the next one, so
that a symmetric pair of modes -- the hanging cable's two pendulum planes -- gets both directions).
The basis is orthonormal in the energy product E^T Q where that is positive on it (then E_r = I:
the reduced model is x_r' = (J_r - R_r) x_r + B_r u, H_r = |x_r|^2 / 2, and well conditioned), else in
the Euclidean product; a rank-deficient one is refused.
"""
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from rodfem.errors import ParameterError

ALPHA = 0.05     # the interpolation points' real part, as a fraction of the first natural frequency
REPEATED = 1e-6  # two frequencies closer than this (relative) are one repeated frequency


class FullModel:
    """The full linear PH model (sparse E, J, R, Q, B, C) and its transfer function."""

    def __init__(self, E, J, R, Q, B, C):
        self.E, self.J, self.R, self.Q = (sp.csc_matrix(M) for M in (E, J, R, Q))
        self.B, self.C = np.asarray(sp.csr_matrix(B).todense()), np.asarray(sp.csr_matrix(C).todense())
        self.A = ((self.J - self.R) @ self.Q).tocsc()
        self.n, self.m = self.B.shape
        if self.m == 0:
            raise ParameterError("reduce: the scene has no input ports (no loads): nothing to reduce towards")

    def solve(self, s, rhs):
        """(s E - A)^{-1} rhs (complex sparse LU)."""
        lu = spla.splu((s * self.E - self.A).astype(complex).tocsc())
        return lu.solve(np.asarray(rhs, dtype=complex))

    def transfer(self, s):
        return self.C @ self.solve(s, self.B)

    def energy_product(self):
        """S = (E^T Q + Q^T E)/2: x^T S x / 2 is the linear model's H."""
        EQ = (self.E.T @ self.Q).tocsr()
        return 0.5 * (EQ + EQ.T)


def basis(raw, S, order):
    """An orthonormal basis of the columns `raw`: in the energy product S (then E_r = I) when S is positive
    on them, else in the Euclidean one.  Gram-Schmidt, twice, column by column; a column that is
    (numerically) in the span of the others is refused."""
    def orthonormal(X, product):
        V = np.zeros_like(X)
        for k in range(X.shape[1]):
            v = X[:, k] / np.sqrt(abs(product(X[:, k], X[:, k])))
            size = 1.0
            for _ in range(2):
                v = v - V[:, :k] @ np.array([product(V[:, i], v) for i in range(k)]) if k else v
                size = product(v, v)
            if not size > 1e-20:
                return None
            V[:, k] = v / np.sqrt(size)
        return V
    energy = lambda x, y: float(x @ (S @ y))    # noqa: E731
    euclid = lambda x, y: float(x @ y)          # noqa: E731
    positive = all(energy(raw[:, k], raw[:, k]) > 1e-12 * abs(S).max() * (raw[:, k] @ raw[:, k])
                   for k in range(raw.shape[1]))
    V = orthonormal(raw, energy) if positive else None
    V = V if V is not None else orthonormal(raw, euclid)
    if V is None:
        raise ParameterError(f"reduce: the interpolation directions are linearly dependent (order {order}); "
                             "ask for a lower --order or other points")
    return V


@dataclass
class Reduced:
    """The reduced model (dense matrices, see the module docstring), its basis V and the interpolation data."""
    E: np.ndarray
    J: np.ndarray
    R: np.ndarray
    Q: np.ndarray
    B: np.ndarray
    C: np.ndarray
    V: np.ndarray
    points: np.ndarray
    directions: np.ndarray
    checks: dict = field(default_factory=dict)

    @property
    def order(self):
        return self.E.shape[0]

    @property
    def A(self):
        return (self.J - self.R) @ self.Q

    def transfer(self, s):
        return self.C @ np.linalg.solve(s * self.E - self.A, self.B.astype(complex))

    def frequencies(self, floor=1e-8):
        """The reduced model's natural frequencies: Im s > 0 of the finite eigenvalues s of (A_r, E_r),
        ascending (those below floor * the largest |s| left out: the rate form's zero eigenvalues)."""
        s = la.eig(self.A, self.E, right=False)
        s = s[np.isfinite(s)]
        big = np.max(np.abs(s)) if len(s) else 1.0
        return np.sort(s.imag[(s.imag > floor * big)])

    def matrices(self):
        return {k: getattr(self, k) for k in ("E", "J", "R", "Q", "B", "C")}


def interpolation_points(omega, count, alpha=None):
    """s_j = alpha + i omega_j for the first `count` frequencies (alpha = ALPHA omega_1 by default)."""
    omega = np.asarray(omega, dtype=float)
    if len(omega) < count:
        raise ParameterError(f"reduce: {count} interpolation points need {count} natural frequencies of the full "
                             f"model, it has {len(omega)} verified ones; ask for a lower --order")
    alpha = ALPHA * omega[0] if alpha is None else float(alpha)
    return alpha + 1j * omega[:count]


def reduce(full: FullModel, order: int, points) -> Reduced:
    """The reduced model of `order` (even, 2 <= order <= n) interpolating G at `points` (order/2 complex
    numbers, Im > 0) in the directions of the module docstring."""
    if not (isinstance(order, (int, np.integer)) and order >= 2 and order % 2 == 0):
        raise ParameterError(f"--order must be an even integer >= 2 (got {order!r})")
    if order > full.n:
        raise ParameterError(f"--order must be at most the full model's {full.n} states (got {order})")
    points = np.asarray(points, dtype=complex)
    if len(points) != order // 2:
        raise ParameterError(f"reduce: order {order} needs {order // 2} interpolation points (got {len(points)})")
    columns, directions, used = [], [], {}
    for s in points:
        X = full.solve(s, full.B)
        _, _, Vh = np.linalg.svd(full.C @ X)
        key = next((k for k in used if abs(k - s) <= REPEATED * abs(s)), s)
        k = used.get(key, 0)
        used[key] = k + 1
        b = Vh[k % Vh.shape[0]].conj()
        v = X @ b
        columns += [v.real, v.imag]
        directions.append(b)
    V = basis(np.column_stack(columns), full.energy_product(), order)
    W = np.asarray(full.Q @ V)
    M = W.T @ (full.J @ W)
    N = W.T @ (full.R @ W)
    Er = V.T @ (full.Q.T @ (full.E @ V))
    Jr, Rr, Esym = 0.5 * (M - M.T), 0.5 * (N + N.T), 0.5 * (Er + Er.T)
    Br = W.T @ full.B
    scale = max(np.max(np.abs(M)), np.max(np.abs(N)), 1e-300)
    checks = {"J_dropped_symmetric_part": float(np.max(np.abs(M + M.T)) / 2 / scale),
              "R_dropped_skew_part": float(np.max(np.abs(N - N.T)) / 2 / scale),
              "E_dropped_skew_part": float(np.max(np.abs(Er - Er.T)) / 2 / max(np.max(np.abs(Er)), 1e-300)),
              "output_map_residual": float(np.max(np.abs(full.C @ V - Br.T)) / max(np.max(np.abs(Br)), 1e-300))}
    red = Reduced(Esym, Jr, Rr, np.eye(order), Br, Br.T.copy(), V, points, np.array(directions), checks)
    red.checks.update(passivity(red))
    return red


def passivity(red: Reduced) -> dict:
    """The PH conditions of the reduced model: J skew, R symmetric >= 0, Q = I, E^T Q symmetric (>= 0:
    its lowest eigenvalue relative to its largest)."""
    eR = np.linalg.eigvalsh(red.R) if red.order else np.zeros(1)
    EQ = red.E.T @ red.Q
    eE = np.linalg.eigvalsh(0.5 * (EQ + EQ.T))
    return {"J_skew": bool(np.array_equal(red.J, -red.J.T)), "R_symmetric": bool(np.array_equal(red.R, red.R.T)),
            "R_lowest_eigenvalue": float(eR.min()), "R_largest_eigenvalue": float(eR.max()),
            "Q_identity": bool(np.array_equal(red.Q, np.eye(red.order))),
            "EtQ_lowest_eigenvalue_relative": float(eE.min() / max(abs(eE).max(), 1e-300)),
            "passive": bool(eR.min() >= -1e-12 * max(abs(eR).max(), 1.0) and eE.min() >= -1e-12 * abs(eE).max())}


def response(model, grid):
    """[G(s) for s in grid] (an array grid x outputs x inputs)."""
    return np.array([model.transfer(s) for s in grid])


def frequency_error(G_full, G_red):
    """Errors of the reduced response on a grid: 'max_relative' = max_s |G - G_r|_2 / max_s |G|_2 (an H-infinity
    error on the grid), 'median_pointwise' = median over s of |G - G_r|_2 / |G|_2; and the curves."""
    norm = lambda X: np.array([np.linalg.norm(x, 2) for x in X])   # noqa: E731
    full, err = norm(G_full), norm(G_full - G_red)
    return {"max_relative": float(err.max() / full.max()),
            "median_pointwise": float(np.median(err / np.maximum(full, 1e-300)))}, full, err


def plot_bode(path, omega, curves, full, alpha, title):
    """Bode-type plot on the line s = alpha + i omega: |G|_2 of the full and the reduced models (upper), the
    error |G - G_r|_2 (lower); `curves`: order -> (|G_r|_2, |G - G_r|_2, interpolation points), the
    interpolation frequencies marked."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7.5, 6.5), sharex=True)
    ax1.loglog(omega, full, "k-", lw=2.2, label="full")
    for k, (r, (mag, err, pts)) in enumerate(sorted(curves.items())):
        ax1.loglog(omega, mag, "--", color=f"C{k}", lw=1.3, label=f"r = {r}")
        ax2.loglog(omega, err, "-", color=f"C{k}", lw=1.3, label=f"r = {r}")
        ax2.plot(pts.imag, np.full(len(pts), err.min() if err.min() > 0 else 1e-16), "|", color=f"C{k}", ms=10)
    ax1.set_ylabel("|G(alpha + i omega)|_2")
    ax2.set_ylabel("|G - G_r|_2")
    ax2.set_xlabel(f"omega [rad/s]   (alpha = {alpha:.3g} 1/s; ticks: interpolation points)")
    ax1.set_title(title)
    ax1.legend(fontsize=8)
    ax2.legend(fontsize=8)
    for ax in (ax1, ax2):
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
