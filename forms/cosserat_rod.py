"""3D Cosserat rod with directors as a port-Hamiltonian system (mixed, compliance form).

Kinon, Eugster & Betsch, Comput. Methods Appl. Mech. Engrg. 458 (2026) 118966, doi 10.1016/j.cma.2026.118966 (arXiv 2512.19408).

Configuration q = (phi, d1, d2, d3) in R^12 (phi: centreline, field "r"),
R(d) = [d1 d2 d3]; d1 is the axis (tangent of the stress-free straight rod),
d2, d3 span the cross-section (the convention of the helix data of Harsch et
al. 2021).  Independent velocities v = (v_phi, v_d) = (v, w1, w2, w3),
stress resultants N (N1 axial, N2, N3 shear) and M (M1 torsion, M2, M3
bending), multipliers lambda (6) of the orthonormality constraints.

Objective strain measures, bilinear in the directors and their derivatives
(' = d/ds), equal to R^T phi' - e1 and axial(R^T R') when R^T R = I:

    Gamma_i = d_i . phi' - delta_i1
    K_i     = 1/2 eps_ijk d_j' . d_k      (K1 = 1/2 (d2'.d3 - d3'.d2), ...)

Their rates give the operators of the paper (v_d = (w1, w2, w3)):

    d_t Gamma = R^T v' + J_N^T v_d,         (J_N^T v_d)_i = phi' . w_i
    d_t K     = J_K v_d,                    (J_K v_d)_i  = 1/2 eps_ijk (w_j'.d_k + d_j'.w_k)

Hamiltonian (quadratic, constant mass matrix):

    H = int 1/2 rhoA |v|^2 + 1/2 sum_i m_i |w_i|^2 + 1/2 N.C_N N + 1/2 M.C_M M ds

The director masses m_i reproduce the rotary inertia (rhoJ_1, rhoJ_2, rhoJ_3)
about (d1, d2, d3): with d_i' = omega x d_i, sum m_i |w_i|^2 = sum_k (m - m_k)
omega_k^2 (m = sum m_i), so m_k = (rhoJ_1 + rhoJ_2 + rhoJ_3)/2 - rhoJ_k, all
>= 0 by the triangle inequality of an inertia tensor.  A thin cross-section
(rhoJ_1 = rhoJ_2 + rhoJ_3) has m_1 = 0: the axis director is massless, w1 is
fixed by the constraints and its row fixes lambda_11, lambda_12, lambda_13
(the Newton matrix stays regular).

Local PH equations (balance of momentum, orthonormality on velocity level,
compliance equations in rate form):

    rhoA d_t v = d_s(R N) + f
    M_rho d_t v_d = -J_N N - J_M M - G_d^T lambda + B_m m,   (J_M = J_K^*, the formal adjoint)
    0 = G_d v_d,           (G_d v_d)_ij = d_i . w_j + d_j . w_i   (i <= j)
    C_N d_t N = R^T d_s v + J_N^T v_d,     C_M d_t M = J_K v_d
    d_t q = v

with diagonal compliances C_N = diag(1/EA, 1/GA_2, 1/GA_3), C_M =
diag(1/GJ, 1/EI_2, 1/EI_3).  An entry may be ZERO: its row becomes the
constraint d_t Gamma_i = 0 (inextensible, shear-rigid) or d_t K_i = 0, and
N_i (M_i) its multiplier.  N, M start at zero in the stress-free reference
configuration, which may be curved: the rate form never needs the reference
strains Gamma^0, K^0.

Discretization (Kinon, Eugster & Betsch 2026): q, v in P2, N, M in DG1, lambda in P2 collocated
at the nodes: the constraint rows AND the reaction forces use the 3-point
Gauss-Lobatto rule whose points are the P2 nodes (dolfinx-notes.md §3), so
g(d_m, w_m) = 0 holds node by node.  Midpoint rule, everything at x_{n+1/2}
(lambda at t_{n+1}).  Testing with (v_m, w_m, N_m, M_m, lambda) gives

    H_{n+1} - H_n = h y.u          (exactly: H quadratic, J skew)

and, because d_i.d_j is bilinear and d_{n+1} - d_n = h w_m at the nodes,

    (d_i.d_j)_{n+1} - (d_i.d_j)_n = h g_ij(d_m, w_m) = 0     at every node,

so orthonormality holds at the nodes for all time.  The strains stay
compatible: C_N N_n - Pi(Gamma(q_n)) and C_M M_n - Pi(K(q_n)) (Pi: L2
projection on DG1) are constant in time, since Gamma, K are bilinear.
Objectivity: every term is built from dot products of (d, phi', w, v'), so
the scheme is invariant under superposed rotations and the total angular
momentum L = int rhoA phi x v + sum_i m_i d_i x w_i ds is conserved when no
load acts.

Materials (forms/rod_materials.py): a complementary energy W*(N, M), strains
gamma = dW*/dN, kappa = dW*/dM (from the stress-free reference), stored energy
U = N.gamma + M.kappa - W* (its Legendre transform), so d_t U = N.d_t gamma + M.d_t kappa
and the compliance rows are d_t (dW*/dN) = R^T d_s v + J_N^T v_d, d_t (dW*/dM) = J_K v_d.

* `linear` (or C_N, C_M given directly): the rows above, bit for bit (same forms).
* a quadratic W* (e.g. `stretch_twist`, a non-diagonal C): C d_t (N, M) = strain
  rate with C (N, M) = dW*/d(N, M), exact under both rules (H quadratic).
* any other W*: dW*/d(N, M) is no polynomial, so it cannot be tested with DG1
  functions.  The strains (gamma, kappa) become DG1 fields (starting at 0) and

      int [(gamma_{n+1} - gamma_n)/h - (R^T v' + J_N^T v_d)_m] . dgamma = 0      (and kappa)
      int [gamma_m - z_N] . dN + [kappa_m - z_M] . dM = 0,   (z_N, z_M) = the step's effort of W*

  with the momentum rows on N_m, M_m as before.  With the discrete gradient,
  z = Gonzalez' grad_bar W*(x_n, x_{n+1}) (rodfem/core/integrators.py, in the metric of
  RodMaterial.weights), and testing the first rows with N_m (a DG1 function: gamma
  and N share the space), the second with N_{n+1} - N_n (DG1) gives

      U_{n+1} - U_n = int N_m.(gamma_{n+1} - gamma_n) + (N_{n+1} - N_n).gamma_m - (W*_{n+1} - W*_n)
                    = h int N_m.(strain rate)_m + int (N_{n+1} - N_n).z_N - (W*_{n+1} - W*_n) = h N_m.(strain rate)_m,

  so H_{n+1} - H_n = h y.u exactly, whatever W* (with the same quadrature rule
  in H and the residual).  With the midpoint rule z = dW*(x_m) leaves
  int dW*(x_m).dx - (W*_{n+1} - W*_n) = O(|dx|^3) per step.  The strain fields are
  the compatible ones: gamma_n - Pi(Gamma(q_n)) stays constant (as C_N N above).
  N_n at the time levels meets dW*/dN(N_n) = gamma_n only to O(h^2) (the rows tie
  the midpoint values); the history's H is U(N_n, gamma_n) as defined above.
  A component of zero compliance (W* does not depend on it) has weight 0 in the
  discrete gradient: its strain stays 0 and its stress is a multiplier.

Viscoelasticity (generalized Maxwell in compliance form, forms/viscoelastic.py):
`branches` = [maxwell(tau_k, C_N=..., C_M=...), ...] adds per branch k its
stress resultants N_k and/or M_k (fields "N_k", "M_k", DG1, starting at 0:
relaxed) with the complementary energy 1/2 N_k.C_Nk N_k + 1/2 M_k.C_Mk M_k
(branch compliances > 0).  The momentum rows see N + sum N_k, M + sum M_k;
the branch's spring strain C_Nk N_k plus its dashpot strain (rate N_k/eta,
eta = tau_k/C_Nk) is the rod's strain:

    C_Nk (d_t N_k + N_k/tau_k) = R^T d_s v + J_N^T v_d,     C_Mk (d_t M_k + M_k/tau_k) = J_K v_d
    (rows scaled by tau_k/(tau_k + h): viscoelastic.row_scale).

Midpoint rule, tested with (N_k, M_k)_m: H_{n+1} - H_n = -h d_n + h y.u with
h d_n = h int sum_k (N_k.C_Nk N_k + M_k.C_Mk M_k)_m / tau_k ds (`dissipation`).
The equilibrium branch may keep zero compliances (a constraint with its
multiplier): the branch rows do not care.  A branch on N is pointless for an
inextensible, shear-rigid rod (its strain rate is zero, N_k stays 0): give
it C_M only.

Kelvin-Voigt and Rayleigh damping (forms/damping.py): `damping` = kelvin_voigt(tau_d, C_N, C_M)
(viscosities D_N = tau_d C_N^-1, D_M = tau_d C_M^-1 componentwise, none where a compliance is 0),
rayleigh(alpha, beta, C_N, C_M) or damping.KelvinVoigt([6 viscosities], alpha) adds to the resultants
of the momentum rows (not of the compliance rows) the viscous stresses of the step's strain rates
as the compliance rows give them, the midpoint rates projected on DG1 (Pi) like the stresses:

    N_v = D_N e_N,  M_v = D_M e_M,   (e_N, e_M) = Pi (R^T d_s v + J_N^T v_d, J_K v_d)_m
                                    = (C_N d_t N, C_M d_t M)   (linear; dW*/d(N, M) at (d_t N, d_t M)
                                      for a quadratic W*; (d_t gamma, d_t kappa) for any other),

and the forces alpha (rhoA v, m_i w_i)_m (Rayleigh's mass part): R = B^* Pi^* D Pi B >= 0 on the
velocity efforts.  Testing the momentum rows with (v_m, w_m) and the compliance rows with (N_v, M_v)
(DG1 fields) gives, for both rules,

    H_{n+1} - H_n = -h d_n + h y.u,
    h d_n = h int e_N.D_N e_N + e_M.D_M e_M + alpha (rhoA |v|^2 + sum m_i |w_i|^2)_m ds >= 0.

A constrained strain (zero compliance) has e = 0: no dashpot.  Soromox (github.com/tud-phi/soromox)
writes D = eta diag(J, 3I, 3I, 3A, A, A) (torsion, bending, axial, shear) for an incompressible
material (E = 3G): our D with tau_d = eta/G.  Zero damping builds nothing.

Ports: a spatial moment m acts on the directors through
<m, 1/2 sum_i d_i x w_i> (= m . omega, see `spatial_moment`); a body-fixed
moment M_B is m = sum_i M_B,i d_i (`body_moment`).  A force pairs with v.
"""
import numpy as np
import ufl

from rodfem.core.joints import Frame
from rodfem.core.materials import ParameterSet
from rodfem.core.model import Field
from rodfem.errors import ParameterError
from rodfem.forms import damping as kv
from rodfem.forms.rod_materials import COMPLIANCES, RodMaterial
from rodfem.forms.viscoelastic import Maxwell, active, row_scale

DIRECTORS = ("d1", "d2", "d3")
RATES = ("w1", "w2", "w3")
# index pairs (i, j), i <= j, of the 6 orthonormality constraints g_ij = d_i . d_j - delta_ij
PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
EPS = ((0, 1, 2), (1, 2, 0), (2, 0, 1))   # cyclic (i, j, k): K_i = 1/2 (d_j'.d_k - d_k'.d_j)


def gll(dx):
    """The 3-point Gauss-Lobatto measure on the mesh of `dx`: points = the P2 nodes."""
    return ufl.Measure("dx", domain=dx.ufl_domain(),
                       metadata={"quadrature_rule": "GLL", "quadrature_degree": 2})


def frame(d):
    """R = [d1 d2 d3] (columns)."""
    return ufl.as_matrix([[d[j][i] for j in range(3)] for i in range(3)])


def curvature(d):
    """K_i = 1/2 eps_ijk d_j' . d_k (objective; = axial(R^T R') for R in SO(3))."""
    return ufl.as_vector([0.5 * (ufl.inner(d[j].dx(0), d[k]) - ufl.inner(d[k].dx(0), d[j])) for i, j, k in EPS])


def curvature_rate(d, w):
    """J_K w: the derivative of K(d) in the direction w (bilinear in (d, w))."""
    return ufl.as_vector([0.5 * (ufl.inner(w[j].dx(0), d[k]) + ufl.inner(d[j].dx(0), w[k])
                                 - ufl.inner(w[k].dx(0), d[j]) - ufl.inner(d[k].dx(0), w[j])) for i, j, k in EPS])


def shear_strain(r, d):
    """Gamma_i + delta_i1 = d_i . phi'."""
    return ufl.as_vector([ufl.inner(d[i], r.dx(0)) for i in range(3)])


def constraint_rate(d, w):
    """G_d w: g_ij = d_i . w_j + d_j . w_i for the 6 pairs i <= j."""
    return ufl.as_vector([ufl.inner(d[i], w[j]) + ufl.inner(d[j], w[i]) for i, j in PAIRS])


def orthonormality(d):
    """g_ij = d_i . d_j - delta_ij for the 6 pairs i <= j (position level; its rate is constraint_rate)."""
    return ufl.as_vector([ufl.inner(d[i], d[j]) - (1.0 if i == j else 0.0) for i, j in PAIRS])


def angular_velocity(d, w):
    """omega = 1/2 sum_i d_i x w_i (= omega if w_i = omega x d_i, d orthonormal)."""
    return 0.5 * sum((ufl.cross(d[i], w[i]) for i in range(3)), ufl.zero(3))


def spatial_moment(u, xm, w):
    """Pairing <m, B(x)^T w> = m . 1/2 sum_i d_i x w_i of a spatial moment m (use with Load(pairing=))."""
    d = [xm[n] for n in DIRECTORS]
    return ufl.inner(u, angular_velocity(d, [w[n] for n in RATES]))


def body_moment(u, xm, w):
    """Pairing of a body-fixed moment M_B: the spatial moment m = sum_i M_B,i d_i (midpoint directors)."""
    d = [xm[n] for n in DIRECTORS]
    m = sum((u[i] * d[i] for i in range(3)), ufl.zero(3))
    return ufl.inner(m, angular_velocity(d, [w[n] for n in RATES]))


def director_frame(q, position, offset=()):
    """The point x = phi + sum_i X_i d_i at `offset` X (body frame) and the directors (numbers)."""
    d = [np.asarray(q[n], dtype=float) for n in DIRECTORS]
    x = np.asarray(q[position], dtype=float) + sum((X * di for X, di in zip(offset, d)), np.zeros(3))
    return Frame(x=x, d=d)


def director_masses(rhoJ):
    """m_k = (rhoJ_1 + rhoJ_2 + rhoJ_3)/2 - rhoJ_k, the director masses of the rotary inertia rhoJ."""
    J = np.asarray(rhoJ, dtype=float)
    m = 0.5 * J.sum() - J
    if np.any(m < -1e-14 * max(J.max(), 1.0)):
        raise ValueError(f"rotary inertia {tuple(J)} violates the triangle inequality rhoJ_k <= sum of the others")
    return np.maximum(m, 0.0)


def compliances(EA, GA2, GA3, GJ, EI2, EI3):
    """C_N = (1/EA, 1/GA2, 1/GA3), C_M = (1/GJ, 1/EI2, 1/EI3); an infinite stiffness gives 0."""
    inv = [0.0 if np.isinf(k) else 1.0 / k for k in (EA, GA2, GA3, GJ, EI2, EI3)]
    return tuple(inv[:3]), tuple(inv[3:])


def maxwell(tau, C_N=None, C_M=None):
    """A Maxwell branch on the stress resultants: springs with compliances C_N = (C_N1, C_N2, C_N3)
    and/or C_M = (C_M1, C_M2, C_M3) (entries > 0; None: the branch does not act on N, resp. M)
    in series with dashpots of relaxation time tau."""
    parts = {}
    for name, c in (("N", C_N), ("M", C_M)):
        if c is None:
            continue
        c = np.asarray(c, dtype=float)
        if c.shape != (3,) or not np.all(np.isfinite(c)) or np.any(c <= 0):
            raise ValueError(f"Maxwell branch: C_{name} must be three compliances > 0 (got {c!r}); "
                             f"leave it out (None) for no branch on {name}")
        parts[name] = c
    stiffness = [1.0 / c for name in ("N", "M") if name in parts for c in parts[name]]
    return Maxwell(tau, parts, stiffness, name="maxwell")


def _stiffnesses(C_N, C_M):
    """1/C per component (inf for a zero compliance: a constrained strain gets no dashpot)."""
    C = np.concatenate([np.asarray(C_N, dtype=float), np.asarray(C_M, dtype=float)])
    if C.shape != (6,) or np.any(C < 0) or not np.all(np.isfinite(C)):
        raise ParameterError(f"damping: C_N, C_M must be three compliances >= 0 each (got {C_N!r}, {C_M!r})")
    return np.where(C > 0, 1.0 / np.where(C > 0, C, 1.0), np.inf)


def kelvin_voigt(tau, C_N, C_M):
    """Kelvin-Voigt damping with retardation time tau = eta/E >= 0: viscosities tau/C_N, tau/C_M
    (N_v = tau C_N^-1 Gamma_dot, M_v = tau C_M^-1 K_dot; none where a compliance is 0)."""
    return kv.retardation(tau, _stiffnesses(C_N, C_M))


def rayleigh(alpha, beta, C_N, C_M):
    """Rayleigh damping alpha M + beta K: mass-proportional rate alpha, viscosities beta/C_N, beta/C_M."""
    return kv.retardation(beta, _stiffnesses(C_N, C_M), alpha=alpha)


class CosseratRod:
    """Director-based Cosserat rod: line density rhoA, rotary inertia rhoJ = (rhoJ_1, rhoJ_2, rhoJ_3)
    about (d1, d2, d3), compliances C_N = (C_N1, C_N2, C_N3) and C_M = (C_M1, C_M2, C_M3) (entries >= 0),
    or a `material` W*(N, M) (forms/rod_materials.py; then C_N, C_M are its small-strain diagonal).
    """
    supports = {"clamped": ["r", *DIRECTORS, "v", *RATES, "lam"], "pinned": ["r", "v"]}
    position = "r"
    kinematics = {"r": "v", "d1": "w1", "d2": "w2", "d3": "w3"}   # configuration -> velocity: what joints act on
    frame = staticmethod(lambda q, offset=(): director_frame(q, "r", offset))
    quadrature_degree = 4                     # integrands are at most P1 x P1 x P2 (degree 4): exact

    @staticmethod
    def default_initial():
        """A body placed without initial values: straight along x from the origin, r(s) = s e1, d_i = e_i,
        at rest (its stress-free reference)."""
        init = {"r": lambda x: np.vstack([x[0], np.zeros_like(x[0]), np.zeros_like(x[0])])}
        for i, d in enumerate(DIRECTORS):
            init[d] = lambda x, e=np.eye(3)[i]: np.outer(e, np.ones(x.shape[1]))
        return init
    # what the output writes (rodfem/io/snapshot.py): descriptions and component names
    labels = {**{d: (f"director {d} (d1 the axis, d2 and d3 span the section)", ("x", "y", "z")) for d in DIRECTORS},
              "v": ("velocity d_t r of the centreline", ("x", "y", "z")),
              **{w: (f"director rate {w} = d_t d{w[1]}", ("x", "y", "z")) for w in RATES},
              "lam": ("multipliers lambda_ij of the orthonormality constraints d_i . d_j = delta_ij "
                      "(reactions to them)", tuple(f"{i + 1}{j + 1}" for i, j in PAIRS)),
              "strain_from_N": ("strains C_N N from the stress-free reference: axial strain, shear strains "
                                "(= Pi(Gamma(q)) - Pi(Gamma(q_ref)), Gamma_i = d_i . d_s r - delta_i1)",
                                ("axial", "shear2", "shear3")),
              "strain_from_M": ("curvatures C_M M from the stress-free reference: torsion, bending about d2, d3 "
                                "(= Pi(K(q)) - Pi(K(q_ref)), K_i = 1/2 eps_ijk d_s d_j . d_k)",
                                ("torsion", "bend2", "bend3")),
              "N": ("stress resultants N on (d1, d2, d3): axial and shear forces (the state's field)",
                    ("axial", "shear2", "shear3")),
              "M": ("moments M on (d1, d2, d3): torsion and bending moments (the state's field)",
                    ("torsion", "bend2", "bend3")),
              "gamma": ("strains gamma = dW*/dN from the stress-free reference (the state's field; "
                        "non-quadratic materials only)", ("axial", "shear2", "shear3")),
              "kappa": ("curvatures kappa = dW*/dM from the stress-free reference (the state's field; "
                        "non-quadratic materials only)", ("torsion", "bend2", "bend3"))}

    # SI units of the written arrays (with the scene's parameters in SI); "1": dimensionless
    units = {"r": "m", **{d: "1" for d in DIRECTORS}, "v": "m/s", **{w: "1/s" for w in RATES},
             "lam": "N", "strain_from_N": "1", "strain_from_M": "1/m", "gamma": "1", "kappa": "1/m",
             "N": "N", "M": "N m"}

    def __init__(self, rhoA, rhoJ, C_N=None, C_M=None, branches=(), material=None, damping=None):
        self.rhoA = float(rhoA)
        if not self.rhoA >= 0:  # also NaN
            raise ValueError(f"CosseratRod: rhoA must be a number >= 0 (got {rhoA!r})")
        self.masses = director_masses(rhoJ)
        if material is None:
            if C_N is None or C_M is None:
                raise ValueError("CosseratRod: give the compliances C_N, C_M or a material (forms/rod_materials.py)")
        elif not isinstance(material, RodMaterial):
            raise TypeError(f"material must be a rod material (forms/rod_materials.py), got {material!r}")
        elif C_N is not None or C_M is not None:
            raise ValueError("CosseratRod: give either the compliances C_N, C_M or a material, not both")
        elif type(material).__name__ == "linear":   # the diagonal law: today's rows, bit for bit
            C_N, C_M = [material.params[k] for k in COMPLIANCES[:3]], [material.params[k] for k in COMPLIANCES[3:]]
            material = None
        # material None: the diagonal linear law with C_N, C_M (constants "C_N1", ...);
        # otherwise W*(N, M) of the material, C_N, C_M its small-strain (diagonal) compliances
        self.material = material
        if material is not None:
            C0 = np.diag(material.compliance())
            C_N, C_M = C0[:3], C0[3:]
        self.C_N, self.C_M = (np.asarray(c, dtype=float) for c in (C_N, C_M))
        if self.C_N.shape != (3,) or self.C_M.shape != (3,) or np.any(self.C_N < 0) or np.any(self.C_M < 0):
            raise ValueError("compliances C_N, C_M must be three numbers >= 0 each")
        # run-time constants of the forms (a new value recompiles nothing)
        self.parameters = ParameterSet(rhoA=self.rhoA, **{f"m{i + 1}": m for i, m in enumerate(self.masses)},
                                       **{f"C_N{i + 1}": c for i, c in enumerate(self.C_N)},
                                       **{f"C_M{i + 1}": c for i, c in enumerate(self.C_M)})
        v3 = (3,)
        self.fields = ([Field(n, "P", 2, v3) for n in ("r", *DIRECTORS, "v", *RATES)]
                       + [Field("N", "DG", 1, v3), Field("M", "DG", 1, v3), Field("lam", "P", 2, (6,))])
        if self.general:   # the strains conjugate to N, M (module docstring: non-quadratic materials)
            self.fields += [Field("gamma", "DG", 1, v3), Field("kappa", "DG", 1, v3)]
            self.dg_weights = ParameterSet(**{f"w{i}": w for i, w in enumerate(material.weights())})
        self.damping = kv.checked(damping, 6)   # None: no damping (nothing built)
        # Maxwell branches: their stress resultants are internal variables, their
        # compliances and 1/tau run-time constants
        self.branches = active(branches)
        self.branch_parameters = []
        for k, b in enumerate(self.branches, 1):
            self.fields += [Field(f"{name}_{k}", "DG", 1, v3) for name in ("N", "M") if name in b.spring]
            inv_tau = 0.0 if np.isinf(b.tau) else 1.0 / b.tau
            self.branch_parameters.append(ParameterSet(inv_tau=inv_tau, **{
                f"C_{name}{i + 1}": c for name, cs in b.spring.items() for i, c in enumerate(cs)}))

    @property
    def general(self):
        """True for a non-quadratic material W*(N, M): strain fields and the discrete gradient of W*."""
        return self.material is not None and not self.material.quadratic

    def _complementary(self, N, M):
        """W*(N, M) of the material (its parameters: constants on the mesh of N)."""
        return self.material(N, M)

    def _compliance_rows(self, Ndot, Mdot, domain):
        """(C_N Ndot, C_M Mdot) of a quadratic law: the diagonal constants, or dW*/d(N, M) at the rates."""
        if self.material is None:
            _, _, C_N, C_M = self._constants(domain)
            return C_N * Ndot, C_M * Mdot
        X = ufl.variable(ufl.as_vector([Ndot[i] for i in range(3)] + [Mdot[i] for i in range(3)]))
        g = ufl.diff(self._complementary(ufl.as_vector([X[i] for i in range(3)]),
                                         ufl.as_vector([X[i] for i in range(3, 6)])), X)
        return ufl.as_vector([g[i] for i in range(3)]), ufl.as_vector([g[i] for i in range(3, 6)])

    def _constants(self, domain):
        """(rhoA, director masses m_1..3, C_N, C_M) as UFL constants on `domain`."""
        c = self.parameters.on(domain)
        diag = lambda name: ufl.as_matrix([[c[f"{name}{i + 1}"] if i == j else 0.0 for j in range(3)]  # noqa: E731
                                           for i in range(3)])
        return c["rhoA"], [c[f"m{i + 1}"] for i in range(3)], diag("C_N"), diag("C_M")

    def hamiltonian(self, x, dx, ds):
        """H = int 1/2 rhoA |v|^2 + 1/2 sum m_i |w_i|^2 + U ds,  U = 1/2 N.C_N N + 1/2 M.C_M M (linear),
        W*(N, M) (quadratic material), N.gamma + M.kappa - W*(N, M) (any other material)."""
        rhoA, masses, C_N, C_M = self._constants(dx.ufl_domain())
        kin = 0.5 * rhoA * ufl.inner(x["v"], x["v"])
        kin += sum(0.5 * m * ufl.inner(x[n], x[n]) for m, n in zip(masses, RATES))
        if self.material is None:
            pot = 0.5 * ufl.inner(x["N"], C_N * x["N"]) + 0.5 * ufl.inner(x["M"], C_M * x["M"])
        elif self.material.quadratic:
            pot = self._complementary(x["N"], x["M"])
        else:
            pot = (ufl.inner(x["N"], x["gamma"]) + ufl.inner(x["M"], x["kappa"])
                   - self._complementary(x["N"], x["M"]))
        for field, C, _ in self._branch_terms(dx.ufl_domain()):
            pot = pot + 0.5 * ufl.inner(x[field], C * x[field])
        return (kin + pot) * dx

    def _branch_terms(self, domain):
        """[(field 'N_k' or 'M_k', its compliance matrix, 1/tau_k)] of the Maxwell branches."""
        out = []
        for k, (b, params) in enumerate(zip(self.branches, self.branch_parameters), 1):
            c = params.on(domain)
            for name in ("N", "M"):
                if name in b.spring:
                    C = ufl.as_matrix([[c[f"C_{name}{i + 1}"] if i == j else 0.0 for j in range(3)] for i in range(3)])
                    out.append((f"{name}_{k}", C, c["inv_tau"]))
        return out

    def residual(self, step, test, dx, ds):
        """E (x_{n+1} - x_n)/h - J(x_m) z, tested; z = (v_m, w_m, N_m, M_m, lambda_{n+1})."""
        dxG = gll(dx)
        rhoA, masses, C_N, C_M = self._constants(dx.ufl_domain())
        r, v = step.mid("r"), step.mid("v")
        d = [step.mid(n) for n in DIRECTORS]
        w = [step.mid(n) for n in RATES]
        N, M, lam = step.mid("N"), step.mid("M"), step.x1["lam"]
        branches = self._branch_terms(dx.ufl_domain())
        for field, _, _ in branches:   # parallel branches: the resultants add
            if field.startswith("N"):
                N = N + step.mid(field)
            else:
                M = M + step.mid(field)
        dv, dN, dM, dlam = test["v"], test["N"], test["M"], test["lam"]
        dw = [test[n] for n in RATES]
        mass_damping = None
        if self.damping is not None:   # Kelvin-Voigt: viscous resultants in the momentum rows only
            Nv, Mv, _, alpha = self._viscous(step, dx.ufl_domain())
            N, M = N + Nv, M + Mv
            if alpha is not None:
                mass_damping = alpha * (rhoA * ufl.inner(v, dv)
                                        + sum(m * ufl.inner(wi, dwi) for m, wi, dwi in zip(masses, w, dw))) * dx
        # kinematics d_t q = v (nodal: lumped on the GLL rule)
        F = sum(ufl.inner(step.rate(q) - step.mid(p), test[q])
                for q, p in zip(("r", *DIRECTORS), ("v", *RATES))) * dxG
        # balance of linear momentum: rhoA d_t v = d_s(R N)
        F += (rhoA * ufl.inner(step.rate("v"), dv) + ufl.inner(frame(d) * N, dv.dx(0))) * dx
        # director momentum: M_rho d_t v_d = -J_N N - J_M M - G_d^T lambda
        F += sum(m * ufl.inner(step.rate(n), dwi) + N[i] * ufl.inner(r.dx(0), dwi)
                 for i, (m, n, dwi) in enumerate(zip(masses, RATES, dw))) * dx
        F += ufl.inner(M, curvature_rate(d, dw)) * dx
        F += ufl.inner(lam, constraint_rate(d, dw)) * dxG
        # orthonormality on velocity level, collocated at the nodes
        F += ufl.inner(constraint_rate(d, w), dlam) * dxG
        # compliance equations in rate form
        gamma_rate = frame(d).T * v.dx(0) + ufl.as_vector([ufl.inner(r.dx(0), w[i]) for i in range(3)])
        if not self.general:   # quadratic: C d_t (N, M) = strain rate
            CN_rate, CM_rate = self._compliance_rows(step.rate("N"), step.rate("M"), dx.ufl_domain())
            F += (ufl.inner(CN_rate - gamma_rate, dN) + ufl.inner(CM_rate - curvature_rate(d, w), dM)) * dx
        else:   # d_t (gamma, kappa) = strain rate, (gamma, kappa)_m = the step's effort of W*(N, M)
            c = self.dg_weights.on(dx.ufl_domain())
            zN, zM = step.effort(self._complementary, ["N", "M"], weights=[c[f"w{i}"] for i in range(6)])
            # (tested with dgamma, resp. dN: the same equations as the other way round, but every
            # row then has its own dof on the diagonal -- mass/h, resp. -d^2 W*/dN^2/2 -- and the
            # LU needs no multiplier ordering for N, M: 8x cheaper per iteration at 16 elements)
            F += (ufl.inner(step.rate("gamma") - gamma_rate, test["gamma"])
                  + ufl.inner(step.rate("kappa") - curvature_rate(d, w), test["kappa"])
                  + ufl.inner(step.mid("gamma") - zN, dN) + ufl.inner(step.mid("kappa") - zM, dM)) * dx
        for field, C, inv_tau in branches:   # C_k (d_t N_k + N_k/tau_k) = strain rate, times tau_k/(tau_k + h)
            rate = gamma_rate if field.startswith("N") else curvature_rate(d, w)
            F += row_scale(step, inv_tau) * ufl.inner(C * (step.rate(field) + inv_tau * step.mid(field)) - rate,
                                                      test[field]) * dx
        if mass_damping is not None:
            F += mass_damping
        return F

    def _strain_rates(self, step, domain):
        """(e_N, e_M) = Pi (R^T v' + J_N^T v_d, J_K v_d)_m, the strain rates of the compliance rows."""
        if self.general:
            return step.rate("gamma"), step.rate("kappa")
        return self._compliance_rows(step.rate("N"), step.rate("M"), domain)

    def _viscous(self, step, domain):
        """(N_v, M_v, (e_N, e_M), alpha): the Kelvin-Voigt resultants D (e_N, e_M), the strain rates,
        the mass rate (None if 0)."""
        eN, eM = self._strain_rates(step, domain)
        s = kv.viscous(self.damping.eta(domain), [eN[i] for i in range(3)] + [eM[i] for i in range(3)])
        return ufl.as_vector(s[:3]), ufl.as_vector(s[3:]), (eN, eM), self.damping.mass_rate(domain)

    def dissipation(self, step, dx, ds):
        """h d_n = h int sum_k (N_k.C_Nk N_k + M_k.C_Mk M_k)_m / tau_k + N_v.Gamma_dot + M_v.K_dot
        + alpha (rhoA |v|^2 + sum m_i |w_i|^2)_m ds (None without branches and damping)."""
        if not self.branches and self.damping is None:
            return None
        terms = [inv_tau * ufl.inner(step.mid(f), C * step.mid(f))
                 for f, C, inv_tau in self._branch_terms(dx.ufl_domain())]
        if self.damping is not None:
            Nv, Mv, (eN, eM), alpha = self._viscous(step, dx.ufl_domain())
            terms.append(ufl.inner(Nv, eN) + ufl.inner(Mv, eM))
            if alpha is not None:
                rhoA, masses, _, _ = self._constants(dx.ufl_domain())
                v, w = step.mid("v"), [step.mid(n) for n in RATES]
                terms.append(alpha * (rhoA * ufl.inner(v, v) + sum(m * ufl.inner(wi, wi) for m, wi in zip(masses, w))))
        return step.h * sum(terms[1:], terms[0]) * dx

    @property
    def massless(self):
        """No inertia (rhoA = 0 and rhoJ = 0): statics through the integrator, the velocities mean nothing."""
        return self.rhoA == 0 and not np.any(self.masses)

    @staticmethod
    def directors(q):
        """The section frame (n, 3, 3), columns d1, d2, d3, at nodal values q (numbers, for pictures)."""
        return np.stack([np.asarray(q[n], dtype=float).reshape(-1, 3) for n in DIRECTORS], axis=-1)

    def outputs(self, x):
        """The model's strains and the stress resultants N, M (UFL).

        The strains are those the stress resultants carry: strain_from_N = C_N N and strain_from_M =
        C_M M (dW*/d(N, M) at the state of a quadratic material), the strains from the stress-free
        reference; for any other material the state's strain fields gamma, kappa (module docstring).
        They are DG1 like N and M (the configuration's Gamma(q), K(q), cubic and quadratic on a cell,
        meet them only in the L2 projection Pi, so their nodal values oscillate from node to node).
        N, M: the equilibrium branch's plus every Maxwell branch's (parallel branches: the stresses
        add); the strains are the equilibrium branch's (every branch sees the rod's strain)."""
        if self.general:
            strains = {"gamma": x["gamma"], "kappa": x["kappa"]}
        else:
            CN, CM = self._compliance_rows(x["N"], x["M"], ufl.domain.extract_unique_domain(x["N"]))
            strains = {"strain_from_N": CN, "strain_from_M": CM}
        N, M = x["N"], x["M"]
        for field in (f.name for f in self.fields):
            if field.startswith("N_"):
                N = N + x[field]
            elif field.startswith("M_"):
                M = M + x[field]
        return {**strains, "N": N, "M": M}

    def compatible_strains(self, x):
        """None: N = M = 0 is the stress-free reference state (straight or curved); the rate form needs no Gamma^0, K^0."""
        return {}

    # -- statics and modes (rodfem/analysis/statics.py, rodfem/analysis/linearize.py) -------------------
    # At rest the compliance rows and the velocity-level constraint rows are empty; these
    # total-form rows replace them (the rows tested with `static_fields`):
    #     C_N (N - N_ref) = Pi(Gamma(q) - Gamma(q_ref)),   C_M (M - M_ref) = Pi(K(q) - K(q_ref)),
    #     d_i . d_j - delta_ij = 0 at the nodes (GLL),
    # with q_ref the reference state (the body's initial state).  They are exactly the
    # invariants the rate form keeps (module docstring): a static solution is a rest
    # state of the time stepping.
    @property
    def static_fields(self):
        """The test fields of the rate rows: (N, M, lam), or (gamma, kappa, lam) for a non-quadratic material."""
        return ("gamma", "kappa", "lam") if self.general else ("N", "M", "lam")

    def static_rows(self, x, ref, test, dx, ds):
        d, d0 = [x[n] for n in DIRECTORS], [ref[n] for n in DIRECTORS]
        gamma = shear_strain(x["r"], d) - shear_strain(ref["r"], d0)
        kappa = curvature(d) - curvature(d0)
        if self.general:   # (gamma, kappa) - their reference = the strains; dW*/d(N, M) = (gamma, kappa) is a residual row
            eN, eM = x["gamma"] - ref["gamma"], x["kappa"] - ref["kappa"]
            tN, tM = test["gamma"], test["kappa"]
        else:
            eN, eM = self._compliance_rows(x["N"] - ref["N"], x["M"] - ref["M"], dx.ufl_domain())
            tN, tM = test["N"], test["M"]
        F = (ufl.inner(eN - gamma, tN) + ufl.inner(eM - kappa, tM)) * dx
        return F + ufl.inner(orthonormality(d), test["lam"]) * gll(dx)

    def momentum(self, x):
        """p = rhoA v and L = rhoA phi x v + sum_i m_i d_i x w_i (densities; L about the origin)."""
        rhoA, masses, _, _ = self._constants(ufl.domain.extract_unique_domain(x["v"]))
        p = rhoA * x["v"]
        L = ufl.cross(x["r"], p) + sum((m * ufl.cross(x[dn], x[wn])
                                       for m, dn, wn in zip(masses, DIRECTORS, RATES)), ufl.zero(3))
        return {**{f"p_{c}": p[i] for i, c in enumerate("xyz")}, **{f"L_{c}": L[i] for i, c in enumerate("xyz")}}
