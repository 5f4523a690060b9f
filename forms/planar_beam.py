"""Planar geometrically exact (Simo-Reissner) beam as a port-Hamiltonian system.

Kinon, Betsch & Eugster, Multibody Syst. Dyn. (2025), doi 10.1007/s11044-025-10087-9.

State x = (r, phi, v, omega, Gamma, kappa) on s in [0, L]:
centreline r in R^2, angle phi, velocities v = r', omega = phi' (in time),
strains Gamma = A^T d_s r - e1 (axial, shear) and kappa = d_s phi as
independent fields, with A(phi) = [[cos, -sin], [sin, cos]] = [d1 d2].

    H(x) = int 1/2 rhoA v.v + 1/2 rhoI omega^2 + W(Gamma, kappa) ds

Local PH equations (N = dW/dGamma, M = dW/dkappa, n = A N, S = [[0, -1], [1, 0]]):

    d_t r = v,                    d_t phi = omega
    rhoA d_t v = d_s(A N) + f,    rhoI d_t omega = d_s M + (S d_s r).(A N) + m
    d_t Gamma = A^T (d_s v - omega S d_s r),          d_t kappa = d_s omega

Sign of S: with S = [[0, -1], [1, 0]] in *this* arrangement the model is
objective; the authors' slides write omega A^T S d_s r with S = [[0, 1], [-1, 0]],
which is the same.  (Flipping it still conserves energy but lets a rigidly
spinning beam build up strain; tests/models/test_planar_beam.py catches that.)

Weak form: (r, phi, v, omega) in P_k, (Gamma, kappa) in DG_{k-1}; the balance
rows are integrated by parts (the end terms are the ports), the strain rows
are tested with DG_{k-1}.  Testing with (v_m, omega_m, N, M) gives
H_{n+1} - H_n = h y.u exactly -- provided (N, M) lie in the test space
DG_{k-1}.  For k = 1 they do: the pointwise discrete gradient of cellwise
constant strains is cellwise constant.  For k >= 2 the discrete gradient of a
non-quadratic W is not a polynomial (the balance error of log_axial at k = 2
was 8e-8 of max|H|), so there N, M are extra DG_{k-1} fields, the L2
projection of the effort with the quadrature rule of H: the strain increment
is in DG_{k-1}, so int N.(Gamma_{n+1} - Gamma_n) = int grad_bar W.(Gamma_{n+1}
- Gamma_n) = int W_{n+1} - W_n (Gonzalez, point by point), and the balance is exact again.
(The efforts of Maxwell branches are not projected: at k >= 2 a non-quadratic
branch law keeps an O(h^3) balance error per step.)

Viscoelasticity (generalized Maxwell, forms/viscoelastic.py): `branches` =
[maxwell(tau_j, EA_j, GA_j, EI_j), ...] adds per branch j its elastic strains
(Gamma_j, kappa_j) (fields "Gamma_j", "kappa_j", DG_{k-1}, starting relaxed
at 0) with energy W_j(Gamma_j, kappa_j); the resultants become N + sum N_j,
M + sum M_j, and

    d_t Gamma_j = A^T (d_s v - omega S d_s r) - R_j N_j,    d_t kappa_j = d_s omega - R_j M_j,

R_j = diag(1/(tau_j EA_j), 1/(tau_j GA_j), 1/(tau_j EI_j)).  Testing the
branch rows with (N_j, M_j) (the step's efforts of W_j) gives
H_{n+1} - H_n = -h d_n + h y.u with h d_n = h int sum_j (N_j, M_j).R_j (N_j, M_j) ds
(`dissipation`).  Without branches nothing of this is built.

Kelvin-Voigt and Rayleigh damping (forms/damping.py): `damping` = kelvin_voigt(tau_d, EA, GA, EI)
or rayleigh(alpha, beta, EA, GA, EI) (or damping.KelvinVoigt([eta_EA, eta_GA, eta_EI], alpha)) adds
to the resultants of the momentum rows (not of the strain rows) the viscous stresses D e of the
step's strain rates, the rates of the strain fields,

    e = ((Gamma_{n+1} - Gamma_n)/h, (kappa_{n+1} - kappa_n)/h) = Pi (A^T (d_s v - omega S d_s r), d_s omega)_m,
    D = diag(eta_EA, eta_GA, eta_EI) = tau_d diag(EA, GA, EI),

i.e. the midpoint strain rates projected on DG_{k-1} by the strain rows (Pi), like the elastic
stresses (the pointwise rate would lock: with P1 its shear part damps bending 1 + GA h^2/(12 EI)
times too much, zeta_1 = 0.69 instead of 0.021 on the steel strip of cantilever-2d), and the
forces alpha (rhoA v_m, rhoI omega_m) (Rayleigh's mass part).  As a PH structure it is
R = B^* Pi^* D Pi B >= 0 on the velocity efforts (B: the strain-rate operator).  Testing the
momentum rows with (v_m, omega_m) and the strain rows with D e (a DG_{k-1} field: exact with any
quadrature) gives, for both rules,

    H_{n+1} - H_n = -h d_n + h y.u,   h d_n = h int e.D e + alpha (rhoA |v_m|^2 + rhoI omega_m^2) ds >= 0

(`dissipation`).  Zero damping builds nothing.
"""
import math
import numbers

import numpy as np
import ufl

from rodfem.core.joints import Frame
from rodfem.core.materials import ParameterSet, material
from rodfem.core.model import Field
from rodfem.forms import damping as kv
from rodfem.forms.viscoelastic import Maxwell, active

S_HAT = ufl.as_matrix([[0.0, -1.0], [1.0, 0.0]])
E1 = ufl.as_vector([1.0, 0.0])


def rotation(phi):
    """A(phi) = [d1 d2]."""
    c, s = ufl.cos(phi), ufl.sin(phi)
    return ufl.as_matrix([[c, -s], [s, c]])


def planar_frame(q, position, offset=()):
    """The point at `offset` X in the section frame: x = r + A(phi) X, and the angle phi (numbers;
    for joints, rodfem/core/joints.py).  With an offset, x is trigonometric in phi."""
    phi = q["phi"][0]
    x = np.asarray(q[position], dtype=float)
    if len(offset) and any(offset):
        c, s = np.cos(phi), np.sin(phi)
        x = x + np.array([c * offset[0] - s * offset[1], s * offset[0] + c * offset[1]])
    return Frame(x=x, phi=phi)


def planar_directors(phi):
    """The section frame [d1 d2 d3] (n, 3, 3) of angles phi (n,) in 3D: the plane is z = 0, d3 = e_z
    (numbers; for pictures, rodfem/io/snapshot.py)."""
    c, s = np.cos(phi), np.sin(phi)
    R = np.zeros((len(phi), 3, 3))
    R[:, 0, 0], R[:, 1, 0], R[:, 0, 1], R[:, 1, 1], R[:, 2, 2] = c, s, -s, c, 1.0
    return R


def cross(a, b):
    """Planar cross product a x b = a^T S^T b = a_0 b_1 - a_1 b_0."""
    return a[0] * b[1] - a[1] * b[0]


# -- materials: W(Gamma, kappa; parameters) ----------------------------------------
# One function each; `quadratic(EA=..., GA=..., EI=...)` makes the Material
# (rodfem/core/materials.py: the parameters become run-time constants, positive
# except the reference curvature kappa0, which may also be a UFL expression).

@material(strains=2, signed=("kappa0",))
def quadratic(Gamma, kappa, EA, GA, EI, kappa0=0.0):
    """W = 1/2 EA Gamma_1^2 + 1/2 GA Gamma_2^2 + 1/2 EI (kappa - kappa0)^2 (Hooke)."""
    return 0.5 * EA * Gamma[0] ** 2 + 0.5 * GA * Gamma[1] ** 2 + 0.5 * EI * (kappa - kappa0) ** 2


@material(strains=2, signed=("kappa0",))
def log_axial(Gamma, kappa, EA, GA, EI, kappa0=0.0):
    """Hyperelastic in stretch lambda = 1 + Gamma_1:  W = EA (lambda - 1 - ln lambda) + ...

    Same small-strain stiffness as `quadratic`, but W -> infinity as lambda -> 0
    (no compression through zero length).  Non-quadratic: use the
    discrete-gradient integrator for an exact energy balance.
    """
    return EA * stretch_energy(Gamma[0]) + 0.5 * GA * Gamma[1] ** 2 + 0.5 * EI * (kappa - kappa0) ** 2


def stretch_energy(G):
    """lambda - 1 - ln(lambda) with lambda = 1 + G, accurate near G = 0.

    Written directly, its derivative 1 - 1/lambda loses all digits of G below
    eps: a stiff beam (EA = 2e7) then carries a residual noise EA eps = 2e-9,
    above Newton's tolerance.  For |G| < 1e-2 the series
    G^2/2 - G^3/3 + ... - G^9/9 (remainder <= |G|^10/10, 2e-17 of the value)
    has no cancellation.
    """
    series = sum((-1) ** k * G ** k / k for k in range(2, 10))
    return ufl.conditional(ufl.lt(abs(G), 1e-2), series, G - ufl.ln(1.0 + G))


@material(strains=2, signed=("EA", "GA", "EI"))
def hooke_branch(Gamma, kappa, EA, GA, EI):
    """The spring of a Maxwell branch: W = 1/2 EA Gamma_1^2 + 1/2 GA Gamma_2^2 + 1/2 EI kappa^2 (stiffnesses >= 0)."""
    return 0.5 * EA * Gamma[0] ** 2 + 0.5 * GA * Gamma[1] ** 2 + 0.5 * EI * kappa ** 2


def maxwell(tau, EA=0.0, GA=0.0, EI=0.0, law=None):
    """A Maxwell branch on (Gamma, kappa): a spring with small-strain stiffnesses (EA, GA, EI) (>= 0)
    in series with a dashpot of relaxation time tau.  The spring is Hooke's law (`hooke_branch`)
    or `law(EA, GA, EI)`, a material of this module with those small-strain stiffnesses (e.g. log_axial)."""
    spring = (law or hooke_branch)(EA, GA, EI)
    return Maxwell(tau, spring, (EA, GA, EI), name="maxwell")


def kelvin_voigt(tau, EA, GA, EI):
    """Kelvin-Voigt damping with retardation time tau = eta/E >= 0: viscosities tau (EA, GA, EI)."""
    return kv.retardation(tau, (EA, GA, EI))


def rayleigh(alpha, beta, EA, GA, EI):
    """Rayleigh damping alpha M + beta K: mass-proportional rate alpha, viscosities beta (EA, GA, EI)."""
    return kv.retardation(beta, (EA, GA, EI), alpha=alpha)


# -- the model -------------------------------------------------------------------

class PlanarBeam:
    """Planar beam with line densities rhoA, rhoI and stored energy W(Gamma, kappa).

    degree k: P_k kinematics and DG_{k-1} strains (k = 1 is the paper's element).
    gauss_points: Gauss points per element of every cell integral (default k + 2, which
    integrates the polynomial terms exactly; the authors' code uses 2 for k = 1).
    """
    supports = {"clamped": ["r", "phi", "v", "omega"], "pinned": ["r", "v"]}
    position = "r"
    kinematics = {"r": "v", "phi": "omega"}   # configuration -> velocity: what joints act on
    # what the output writes (rodfem/io/snapshot.py): descriptions and component names
    labels = {"phi": ("section angle phi (rad, unwrapped): d1 = (cos phi, sin phi)", ()),
              "v": ("velocity d_t r of the centreline", ("x", "y")),
              "omega": ("angular velocity d_t phi of the section", ()),
              "Gamma": ("strains Gamma = A(phi)^T d_s r - e1 in the section frame (the state's field)",
                        ("axial", "shear")),
              "kappa": ("curvature kappa = d_s phi (the state's field)", ()),
              "N": ("stress resultants N = dW/dGamma in the section frame: axial and shear force", ("axial", "shear")),
              "M": ("bending moment M = dW/dkappa", ())}

    # SI units of the written arrays (with the scene's parameters in SI); "1": dimensionless
    units = {"r": "m", "phi": "rad", "v": "m/s", "omega": "rad/s", "Gamma": "1", "kappa": "1/m", "N": "N", "M": "N m"}
    frame = staticmethod(lambda q, offset=(): planar_frame(q, "r", offset))

    @staticmethod
    def default_initial():
        """A body placed without initial values: straight along x from the origin, r(s) = (s, 0),
        phi = 0, at rest (its stress-free reference)."""
        return straight((0.0, 0.0), (1.0, 0.0))[1]
    projects = False   # True: the efforts N, M are projected fields at every degree (a subclass whose N is not DG_{k-1})

    def __init__(self, rhoA, rhoI, energy, degree=1, gauss_points=None, branches=(), damping=None):
        if degree < 1:
            raise ValueError(f"degree must be >= 1 (got {degree})")
        for name, value in (("rhoA", rhoA), ("rhoI", rhoI)):
            number = isinstance(value, numbers.Real) and math.isfinite(value) and value >= 0
            if not (number or isinstance(value, ufl.core.expr.Expr)):
                raise ValueError(f"PlanarBeam: {name} must be a number >= 0 (got {value!r})")
        if gauss_points is not None and not (isinstance(gauss_points, int) and 1 <= gauss_points <= 10):
            raise ValueError(f"gauss_points must be an integer in [1, 10] (got {gauss_points!r})")
        self.energy, self.degree = energy, degree
        self.densities = ParameterSet(rhoA=rhoA, rhoI=rhoI)  # run-time constants: no recompiling
        k = degree
        self.fields = [Field("r", "P", k, (2,)), Field("phi", "P", k), Field("v", "P", k, (2,)),
                       Field("omega", "P", k), Field("Gamma", "DG", k - 1, (2,)), Field("kappa", "DG", k - 1)]
        self.projected = k >= 2 or self.projects
        if self.projected:  # the efforts, projected on DG_{k-1} (module docstring); algebraic: only x_{n+1} is used
            self.fields += [Field("N", "DG", k - 1, (2,)), Field("M", "DG", k - 1)]
            self.efforts = {"Gamma": "N", "kappa": "M"}   # energy variable -> its effort field (same element)
        # Maxwell branches with stiffness: their elastic strains are internal variables
        self.branches = active(branches)
        for j in range(1, len(self.branches) + 1):
            self.fields += [Field(f"Gamma_{j}", "DG", k - 1, (2,)), Field(f"kappa_{j}", "DG", k - 1)]
        self.damping = kv.checked(damping, 3)   # None: no damping (nothing built)
        # an n-point Gauss rule is exact to degree 2n - 1 (DOLFINx picks n from the degree)
        self.quadrature_degree = 2 * k + 2 if gauss_points is None else 2 * gauss_points - 1

    def hamiltonian(self, x, dx, ds):
        """H = int 1/2 rhoA v.v + 1/2 rhoI omega^2 + W(Gamma, kappa) ds."""
        c = self.densities.on(dx.ufl_domain())
        W = self.energy(x["Gamma"], x["kappa"])
        for j, b in enumerate(self.branches, 1):
            W = W + b.spring(x[f"Gamma_{j}"], x[f"kappa_{j}"])
        return (0.5 * c["rhoA"] * ufl.inner(x["v"], x["v"]) + 0.5 * c["rhoI"] * x["omega"] ** 2 + W) * dx

    def energy_efforts(self, step, domain):
        """(N, M): the discrete gradient (or midpoint derivative) of W(Gamma, kappa) (UFL)."""
        return step.effort(self.energy, ["Gamma", "kappa"])

    def _branch_efforts(self, step, domain):
        """[(N_j, M_j, mobilities [R_EA, R_GA, R_EI])] of the Maxwell branches."""
        out = []
        for j, b in enumerate(self.branches, 1):
            Nj, Mj = step.effort(b.spring, [f"Gamma_{j}", f"kappa_{j}"])
            out.append((Nj, Mj, b.mobility(domain)))
        return out

    def residual(self, step, test, dx, ds):
        """E (x_{n+1} - x_n)/h - J(x_m) z, tested; z = (v_m, omega_m, N, M)."""
        dr, dphi, dv, dw, dG, dk = (test[n] for n in ("r", "phi", "v", "omega", "Gamma", "kappa"))
        r_s, v, w = step.mid("r").dx(0), step.mid("v"), step.mid("omega")
        A = rotation(step.mid("phi"))
        N, M = self.energy_efforts(step, dx.ufl_domain())
        projection = 0
        if self.projected:
            Nh, Mh = step.x1["N"], step.x1["M"]
            projection = (ufl.inner(Nh - N, test["N"]) + (Mh - M) * test["M"]) * dx
            N, M = Nh, Mh
        branches = self._branch_efforts(step, dx.ufl_domain())
        for Nj, Mj, _ in branches:   # parallel branches: the stresses add
            N, M = N + Nj, M + Mj
        c = self.densities.on(dx.ufl_domain())
        mass_damping = None
        if self.damping is not None:   # Kelvin-Voigt: viscous resultants in the momentum rows only
            Nv, Mv, _, alpha = self._viscous(step, dx.ufl_domain())
            N, M = N + Nv, M + Mv
            if alpha is not None:
                mass_damping = alpha * (c["rhoA"] * ufl.inner(v, dv) + c["rhoI"] * w * dw) * dx
        n = A * N
        F = projection + (ufl.inner(step.rate("r") - v, dr) + (step.rate("phi") - w) * dphi
                          + c["rhoA"] * ufl.inner(step.rate("v"), dv) + ufl.inner(n, dv.dx(0))
                          + c["rhoI"] * step.rate("omega") * dw + M * dw.dx(0) - ufl.inner(S_HAT * r_s, n) * dw
                          + ufl.inner(step.rate("Gamma") - A.T * (v.dx(0) - w * S_HAT * r_s), dG)
                          + (step.rate("kappa") - w.dx(0)) * dk) * dx
        for j, ((Nj, Mj, R), b) in enumerate(zip(branches, self.branches), 1):
            # d_t e_j = (kinematic strain rate) - R_j sigma_j, scaled by tau_j/(tau_j + h)
            G, kap = f"Gamma_{j}", f"kappa_{j}"
            flow = ufl.as_vector([R[0] * Nj[0], R[1] * Nj[1]])
            F += b.row_scale(step, dx.ufl_domain()) * (
                ufl.inner(step.rate(G) - A.T * (v.dx(0) - w * S_HAT * r_s) + flow, test[G])
                + (step.rate(kap) - w.dx(0) + R[2] * Mj) * test[kap]) * dx
        if mass_damping is not None:
            F += mass_damping
        return F

    def _viscous(self, step, domain):
        """(N_v, M_v, e, alpha): the Kelvin-Voigt resultants D e of the strain fields' rates
        e = (d_t Gamma, d_t kappa) (= Pi (A^T (v' - omega S r'), omega')_m by the strain rows), e, and
        the mass-proportional rate (None if zero)."""
        Gdot, kdot = step.rate("Gamma"), step.rate("kappa")
        sN0, sN1, sM = kv.viscous(self.damping.eta(domain), (Gdot[0], Gdot[1], kdot))
        return ufl.as_vector([sN0, sN1]), sM, (Gdot, kdot), self.damping.mass_rate(domain)

    def dissipation(self, step, dx, ds):
        """h d_n = h int sum_j N_j.R_j N_j + R_j M_j^2 + e.D e + alpha (rhoA v.v + rhoI omega^2) ds
        (None without branches and damping)."""
        d = self.dissipation_density(step, dx.ufl_domain())
        return None if d is None else step.h * d * dx

    def dissipation_density(self, step, domain):
        """d_n = sum_j N_j.R_j N_j + R_j M_j^2 + e.D e + alpha (rhoA v.v + rhoI omega^2) (UFL; None without
        branches and damping)."""
        if not self.branches and self.damping is None:
            return None
        d = sum(R[0] * Nj[0] ** 2 + R[1] * Nj[1] ** 2 + R[2] * Mj ** 2
                for Nj, Mj, R in self._branch_efforts(step, domain))
        if self.damping is not None:
            Nv, Mv, (Gdot, kdot), alpha = self._viscous(step, domain)
            d = d + ufl.inner(Nv, Gdot) + Mv * kdot
            if alpha is not None:
                c, v, w = self.densities.on(domain), step.mid("v"), step.mid("omega")
                d = d + alpha * (c["rhoA"] * ufl.inner(v, v) + c["rhoI"] * w ** 2)
        return d

    @property
    def massless(self):
        """No inertia (rhoA = rhoI = 0): statics through the integrator, the velocities mean nothing."""
        return all(isinstance(v, numbers.Real) and v == 0 for v in self.densities.values.values())

    @staticmethod
    def directors(q):
        """The section frame (n, 3, 3) at nodal values q (numbers, for pictures)."""
        return planar_directors(np.asarray(q["phi"], dtype=float).reshape(-1))

    def outputs(self, x):
        """The strains (the state's) and the stress resultants N = dW/dGamma + sum_j dW_j/dGamma_j,
        M = dW/dkappa + sum_j dW_j/dkappa_j (UFL): the equilibrium branch's plus every Maxwell
        branch's (parallel branches: the stresses add)."""
        N, M = self._stress(self.energy, x["Gamma"], x["kappa"])
        for j, b in enumerate(self.branches, 1):
            Nj, Mj = self._stress(b.spring, x[f"Gamma_{j}"], x[f"kappa_{j}"])
            N, M = N + Nj, M + Mj
        return {"Gamma": x["Gamma"], "kappa": x["kappa"], "N": N, "M": M}

    @staticmethod
    def _stress(energy, Gamma, kappa):
        """(dW/dGamma, dW/dkappa) of the energy density W(Gamma, kappa)."""
        G, k = ufl.variable(Gamma), ufl.variable(kappa)
        W = energy(G, k)
        return ufl.diff(W, G), ufl.diff(W, k)

    def compatible_strains(self, x):
        """Gamma = A^T d_s r - e1, kappa = d_s phi."""
        return {"Gamma": rotation(x["phi"]).T * x["r"].dx(0) - E1, "kappa": x["phi"].dx(0)}

    # -- statics and modes (rodfem/analysis/statics.py, rodfem/analysis/linearize.py) -------------------
    # At rest the strain rows above are empty (their rates and the velocities vanish):
    # the strains are then fixed by these total-form rows, which replace the rows
    # tested with `static_fields`.  Gamma = Pi(A^T r' - e1), kappa = Pi(phi') (Pi: the
    # L2 projection on DG_{k-1}); the reference curvature kappa0 is in the material.
    static_fields = ("Gamma", "kappa")

    def static_rows(self, x, ref, test, dx, ds):
        """(Gamma - (A^T r' - e1)) . dGamma + (kappa - phi') dkappa  (`ref` unused: absolute strains)."""
        c = self.compatible_strains(x)
        return (ufl.inner(x["Gamma"] - c["Gamma"], test["Gamma"]) + (x["kappa"] - c["kappa"]) * test["kappa"]) * dx

    def momentum(self, x):
        """Linear momentum p = rhoA v and angular momentum L_z = rhoA r x v + rhoI omega (densities)."""
        c = self.densities.on(ufl.domain.extract_unique_domain(x["v"]))
        return {"p_x": c["rhoA"] * x["v"][0], "p_y": c["rhoA"] * x["v"][1],
                "L_z": c["rhoA"] * cross(x["r"], x["v"]) + c["rhoI"] * x["omega"]}


def straight(start, end):
    """A straight beam from `start` to `end`: (length, initial values of r and phi)."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    length = float(np.linalg.norm(end - start))
    t = (end - start) / length
    phi = float(np.arctan2(t[1], t[0]))
    return length, {"r": lambda x: start[:, None] + np.outer(t, x[0]), "phi": lambda x: np.full(x.shape[1], phi)}
