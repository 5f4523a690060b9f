"""Hyperelastic string (cable) in 3D as a port-Hamiltonian system
(Kinon, Thoma, Betsch & Kotyczka, PAMM 23 (2023), doi 10.1002/pamm.202300144;
Kinon, Thoma, Betsch & Kotyczka, IFAC-PapersOnLine 58(6) (2024) 101-106, doi 10.1016/j.ifacol.2024.08.264).

State x = (r, v, C) on the reference interval s in [0, L]: position r in R^3,
velocity v = d_t r (the momentum density is p = rhoA v), and the strain-type
quantity C = d_s r . d_s r as an independent field.  Hyperelastic stored
energy W(C) (forms/string_materials.py), stress quantity S = 2 W'(C), contact
force n = S d_s r, tension N = |n| = S sqrt(C).

    H(x) = int_0^L  1/(2 rhoA) p.p + W(C) ds  (+ 1/2 m_0 |v(0)|^2 + 1/2 m_L |v(L)|^2)

(lumped end masses m_0, m_L >= 0, e.g. the load of a crane).  Kinon et al. (PAMM 2023),
eq. (4), with p = rhoA v:

    d_t r = v,    rhoA d_t v = d_s (S d_s r) + b,    d_t C = 2 d_s r . d_s v,

inputs u = (-n(0, t), n(L, t)) and outputs y = (v(0, t), v(L, t)) (eq. (5)).
Distributed loads b (gravity rhoA g) are inputs too: a 'domain' `Load` on v,
with output v and supplied power int b.v ds.  So H here EXCLUDES the
potential -r.b of Kinon et al. (PAMM 2023), eq. (3): the work of gravity is booked in the
supplied work sum h y.u (history column `supplied`), and H - supplied is the
conserved total energy of a free swing.

Weak form (trial = test spaces: r, v in P1^3, C in DG0), one step
t_n -> t_{n+1} = t_n + h, x_m = (x_n + x_{n+1})/2, S_bar = 2 grad_bar W(C_n, C_{n+1}):

    int (r_{n+1} - r_n)/h . dr - v_m . dr                                    = 0
    int rhoA (v_{n+1} - v_n)/h . dv + S_bar d_s r_m . d_s dv  (+ end masses) = ports
    int [(C_{n+1} - C_n)/h - 2 d_s r_m . d_s v_m] dC                        = 0

The coupling blocks  int S_bar d_s r_m . d_s dv  and  -int 2 d_s r_m . d_s v_m dC
are the -K(r) and K(r)^T of Kinon et al. (PAMM 2023), eq. (7): skew-symmetric, with the
co-energy S/2 of C (the row of v is the row of p divided by rhoA).

Energy balance.  Test the v-row with dv = v_m and the C-row with dC = S_bar/2.
S_bar/2 is a legal test function: C_n, C_{n+1} are cellwise constant (DG0),
so the pointwise discrete gradient grad_bar W is cellwise constant as well.
The coupling terms cancel and

    H(x_{n+1}) - H(x_n) = int rhoA (v_{n+1}-v_n).v_m + [W(C_{n+1}) - W(C_n)] ds + ... = h y.u

exactly (to solver tolerance) for ANY W: grad_bar W (C_{n+1} - C_n) =
W(C_{n+1}) - W(C_n) is Gonzalez' property (`step.effort` of the engine,
rodfem/core/integrators.py: for a scalar C the difference quotient, with a
third-order Taylor fall-back where |C_{n+1} - C_n| <= 1e-3).  With the midpoint rule
S = 2 W'(C_m) (`step.effort`) the balance is exact only for W quadratic in
C (kirchhoff); its error per unit length is W'''(C_m) dC^3 / 24.

Compatibility.  The r-row gives r_{n+1} - r_n = h v_m nodewise (P1 mass
matrix), hence C_{n+1} - C_n = 2 d_s r_m . d_s (r_{n+1} - r_n) =
|d_s r_{n+1}|^2 - |d_s r_n|^2 cellwise: C = |d_s r|^2 stays exact if it holds
at t = 0 (compatible_strains).

Viscoelasticity (generalized Maxwell, Kinon et al., IFAC 2024; forms/viscoelastic.py):
`branches` = [maxwell(tau_k, EA_k), ...] adds per branch k the branch's
elastic strain C_k (field "C_k", DG0; C_k = 1 is the relaxed branch, the
start unless `initial` says otherwise) with the stored energy W_k(C_k)
(a string material with small-strain stiffness EA_k, W_k''(1) = EA_k/4).
With S_bar_k = 2 grad_bar W_k(C_k,n, C_k,n+1) the v-row carries the total
stress S_bar + sum_k S_bar_k, and each branch has the row

    int [(C_k,n+1 - C_k,n)/h - 2 d_s r_m . d_s v_m + R_k grad_bar W_k] dC_k = 0   (times tau_k/(tau_k + h)),
    R_k = 4/(tau_k EA_k)  (so that C_k - 1 relaxes as exp(-t/tau_k) near C_k = 1)

(the IFAC 2024 paper's dashpot  d_t C_el = 2 d_s r . d_s v - (2/etaA) W'(C_el)  with
2/etaA = R_k).  Testing it with dC_k = grad_bar W_k (cellwise constant,
as above) gives

    H(x_{n+1}) - H(x_n) = -h d_n + h y.u,   h d_n = h int sum_k R_k (grad_bar W_k)^2 ds >= 0

exactly for any W_k with the discrete gradient (`dissipation`).

Kelvin-Voigt and Rayleigh damping (forms/damping.py): `damping` = kelvin_voigt(tau_d, EA) or
rayleigh(alpha, beta, EA) adds to the stress of the v-row the viscous stress of the rate of the
Green-Lagrange strain E = (C - 1)/2, d_t E = d_s r . d_s v (not to the C-row):

    S_v = eta (d_s r . d_s v)_m,       eta = tau_d EA   (tension eta d_t eps at small strain),

and the forces alpha rhoA v_m (and alpha m v_m at the end masses: Rayleigh's mass part).  Testing
with v_m: H_{n+1} - H_n = -h d_n + h y.u, h d_n = h int eta (d_s r . d_s v)_m^2 + alpha rhoA |v_m|^2 ds
(+ the ends).  Zero damping builds nothing.

Supports: 'pinned' fixes r and v at an end; 'fix-x', 'fix-y', 'fix-z' fix one
component (e.g. a crane trolley on a horizontal rail: 'fix-z' with z up).
"""
import numpy as np
import ufl

from rodfem.core.joints import Frame
from rodfem.core.materials import ParameterSet
from rodfem.core.model import Field
from rodfem.core.ports import ENDS
from rodfem.forms import damping as kv
from rodfem.forms.string_materials import MATERIALS, Material, logarithmic  # noqa: F401  (re-exported)
from rodfem.forms.viscoelastic import Maxwell, active


def maxwell(tau, EA, law=logarithmic):
    """A Maxwell branch of a string: a spring `law(EA=EA)` (a string material, small-strain
    stiffness EA >= 0; EA = 0: no branch) in series with a dashpot of relaxation time tau."""
    spring = law(EA=EA) if EA > 0 else None
    return Maxwell(tau, spring, [EA / 4.0], name="maxwell")   # W''(1) = EA/4: the stiffness in C


def kelvin_voigt(tau, EA):
    """Kelvin-Voigt damping with retardation time tau = eta/E >= 0: viscosity tau EA."""
    return kv.retardation(tau, [EA])


def rayleigh(alpha, beta, EA):
    """Rayleigh damping alpha M + beta K: mass-proportional rate alpha, viscosity beta EA."""
    return kv.retardation(beta, [EA], alpha=alpha)


class String:
    """Hyperelastic PH string: `material` W(C) (a Material), mass per reference length rhoA,
    lumped end masses {'left': m_0, 'right': m_L} (>= 0)."""
    supports = {"pinned": ["r", "v"], "fix-x": ["r.0", "v.0"], "fix-y": ["r.1", "v.1"], "fix-z": ["r.2", "v.2"]}
    position = "r"
    kinematics = {"r": "v"}   # configuration -> velocity: what joints act on

    @staticmethod
    def default_initial():
        """A body placed without initial values: straight along x from the origin, r(s) = s e1, at rest
        (its reference: C = 1)."""
        return {"r": lambda x: np.vstack([x[0], np.zeros_like(x[0]), np.zeros_like(x[0])])}

    @staticmethod
    def frame(q, offset=()):
        """A string point has a position only (no offset)."""
        if len(offset) and any(offset):
            raise ValueError("a string end has no cross-section: a joint on it takes no offset")
        return Frame(x=np.asarray(q["r"], dtype=float))
    fields = [Field("r", "P", 1, (3,)), Field("v", "P", 1, (3,)), Field("C", "DG", 0)]
    quadrature_degree = 2   # exact for every term: rhoA v.dv is quadratic, the rest cellwise constant
    # what the output writes (rodfem/io/snapshot.py): descriptions and component names
    labels = {"v": ("velocity d_t r", ("x", "y", "z")),
              "C": ("strain C = d_s r . d_s r (the state's field)", ()),
              "stretch": ("stretch sqrt(C) = |d_s r|", ()),
              "tension": ("tension N = 2 W'(C) sqrt(C) = |contact force|", ())}

    units = {"r": "m", "v": "m/s", "C": "1", "stretch": "1", "tension": "N"}   # SI; "1": dimensionless

    def __init__(self, material, rhoA, end_masses=None, branches=(), damping=None):
        if not isinstance(material, Material):
            raise TypeError("material must be a Material, e.g. string_materials.logarithmic(EA=20)")
        if not (np.isfinite(rhoA) and rhoA > 0):
            raise ValueError(f"rhoA must be a positive number (got {rhoA!r})")
        self.material, self.rhoA = material, float(rhoA)
        self.end_masses = {k: float(v) for k, v in (end_masses or {}).items()}
        for end, m in self.end_masses.items():
            if end not in ENDS or not (np.isfinite(m) and m >= 0):
                raise ValueError(f"end_masses: need 'left'/'right' -> mass >= 0 (got {end!r}: {m!r})")
        # The numbers enter the forms as fem.Constants (one set per mesh, like the
        # material's parameters), so a new EA, rhoA or end mass does not recompile.
        self.parameters = ParameterSet(rhoA=self.rhoA, **{"m_" + e: m for e, m in self.end_masses.items()})
        self.damping = kv.checked(damping, 1)   # None: no damping (nothing built)
        # Maxwell branches with stiffness: their strains C_k are internal variables
        self.branches = active(branches)
        if self.branches:
            self.fields = String.fields + [Field(f"C_{k}", "DG", 0) for k in range(1, len(self.branches) + 1)]

    def constants(self, domain):
        return self.parameters.on(domain)

    def W(self, C, domain=None):
        """W(C), the material's stored energy (its parameters are constants on C's mesh)."""
        return self.material(C)

    def _lumped(self, ds, density):
        """sum_ends m_end * density at s = 0, L (only ends with a mass)."""
        c = self.constants(ds.ufl_domain())
        terms = [c["m_" + end] * density * ds(ENDS[end]) for end, m in self.end_masses.items() if m > 0]
        return sum(terms[1:], terms[0]) if terms else None

    def stored(self, x, dom):
        """The stored energy per length: W(C) and the Maxwell branches' springs W_k(C_k)."""
        W = self.W(x["C"], dom)
        for k, b in enumerate(self.branches, 1):
            W = W + b.spring(x[f"C_{k}"])
        return W

    def hamiltonian(self, x, dx, ds):
        """H = int 1/2 rhoA v.v + W(C) ds + 1/2 m |v|^2 at the ends (W: `stored`)."""
        dom = dx.ufl_domain()
        H = (0.5 * self.constants(dom)["rhoA"] * ufl.inner(x["v"], x["v"]) + self.stored(x, dom)) * dx
        ends = self._lumped(ds, 0.5 * ufl.inner(x["v"], x["v"]))
        return H + ends if ends is not None else H

    def residual(self, step, test, dx, ds):
        """The three rows of the module docstring, S_bar = 2 step.effort(W, C)."""
        dom = dx.ufl_domain()
        dr, dv, dC = test["r"], test["v"], test["C"]
        rs, v = step.mid("r").dx(0), step.mid("v")
        (Wbar,) = step.effort(lambda C: self.W(C, dom), ["C"])
        S = 2 * Wbar
        branches = self._branch_efforts(step, dom)
        for Wk, _ in branches:   # parallel branches: the stresses add
            S = S + 2 * Wk
        if self.damping is not None:   # Kelvin-Voigt: the viscous stress in the v-row only
            Sv, _ = self._viscous(step, dom)
            S = S + Sv
        F = (ufl.inner(step.rate("r") - v, dr)
             + self.constants(dom)["rhoA"] * ufl.inner(step.rate("v"), dv) + S * ufl.inner(rs, dv.dx(0))
             + (step.rate("C") - 2 * ufl.inner(rs, v.dx(0))) * dC) * dx
        for k, ((Wk, R), b) in enumerate(zip(branches, self.branches), 1):
            # d_t C_k = 2 d_s r . d_s v - R_k grad_bar W_k, scaled by tau_k/(tau_k + h)
            row = step.rate(f"C_{k}") - 2 * ufl.inner(rs, v.dx(0)) + R * Wk
            F += b.row_scale(step, dom) * row * test[f"C_{k}"] * dx
        if self.damping is not None and self.damping.alpha > 0:   # Rayleigh's mass part
            alpha = self.damping.mass_rate(dom)
            F += alpha * self.constants(dom)["rhoA"] * ufl.inner(v, dv) * dx
            ends_v = self._lumped(ds, alpha * ufl.inner(v, dv))
            F = F + ends_v if ends_v is not None else F
        ends = self._lumped(ds, ufl.inner(step.rate("v"), dv))
        return F + ends if ends is not None else F

    def _viscous(self, step, domain):
        """(S_v, d_t E): the Kelvin-Voigt stress eta d_t E of d_t E = (d_s r . d_s v)_m (S_v = 0 if eta = 0)."""
        Edot = ufl.inner(step.mid("r").dx(0), step.mid("v").dx(0))
        (Sv,) = kv.viscous(self.damping.eta(domain), [Edot])
        return Sv, Edot

    def _branch_efforts(self, step, domain):
        """[(grad_bar W_k, R_k)] of the Maxwell branches."""
        out = []
        for k, b in enumerate(self.branches, 1):
            (Wk,) = step.effort(b.spring, [f"C_{k}"])
            out.append((Wk, b.mobility(domain)[0]))
        return out

    def dissipation(self, step, dx, ds):
        """h d_n = h int sum_k R_k (grad_bar W_k)^2 + S_v d_t E + alpha rhoA |v_m|^2 ds + alpha m |v_m|^2 at
        the ends (None without branches and damping)."""
        if not self.branches and self.damping is None:
            return None
        dom = dx.ufl_domain()
        d = sum(R * Wk ** 2 for Wk, R in self._branch_efforts(step, dom))
        if self.damping is None:
            return step.h * d * dx
        Sv, Edot = self._viscous(step, dom)
        d = d + Sv * Edot
        v = step.mid("v")
        if self.damping.alpha > 0:
            alpha = self.damping.mass_rate(dom)
            d = d + alpha * self.constants(dom)["rhoA"] * ufl.inner(v, v)
            ends = self._lumped(ds, alpha * ufl.inner(v, v))
            if ends is not None:
                return step.h * d * dx + step.h * ends
        return step.h * d * dx

    def compatible_strains(self, x):
        """C = d_s r . d_s r; Maxwell branches relaxed, C_k = 1."""
        branches = {f"C_{k}": relaxed for k in range(1, len(self.branches) + 1)}
        return {"C": ufl.inner(x["r"].dx(0), x["r"].dx(0)), **branches}

    # statics and modes (rodfem/analysis/statics.py): the total-form row C = |d_s r|^2 replaces the rate row of C
    static_fields = ("C",)

    def static_rows(self, x, ref, test, dx, ds):
        """(C - d_s r . d_s r) dC  (`ref` unused: C is absolute)."""
        return (x["C"] - ufl.inner(x["r"].dx(0), x["r"].dx(0))) * test["C"] * dx

    def momentum(self, x):
        """p = rhoA v and L = r x rhoA v (densities); empty with end masses (they are point masses)."""
        if any(m > 0 for m in self.end_masses.values()):
            return {}
        p = self.rhoA * x["v"]
        Lm = ufl.cross(x["r"], p)
        return {"p_x": p[0], "p_y": p[1], "p_z": p[2], "L_x": Lm[0], "L_y": Lm[1], "L_z": Lm[2]}

    def outputs(self, x):
        """The strain C (the state's), the stretch and the tension (UFL)."""
        return {"C": x["C"], "stretch": ufl.sqrt(x["C"]), "tension": self.tension(x["C"])}

    def tension(self, C):
        """N = 2 W'(C) sqrt(C) (UFL)."""
        Cv = ufl.variable(C)
        return 2 * ufl.diff(self.material(Cv), Cv) * ufl.sqrt(C)


def relaxed(x):
    """C_k = 1 at the points x: a Maxwell branch at rest (unstretched)."""
    return np.ones(x.shape[1])


# -- initial states -------------------------------------------------------------------

def set_state(problem):
    """After editing problem.x0: start x_{n+1} and the support values from it."""
    problem.x0.x.scatter_forward()
    problem.x1.x.array[:] = problem.x0.x.array
    problem.state0.x.array[:] = problem.x0.x.array


def map_positions(problem, f):
    """r <- f(r) at every node (f maps an (n, 3) array to an (n, 3) array); C follows, v unchanged."""
    S = problem.space
    Vr, rdofs = S.collapse("r")
    pos = problem.x0.x.array[rdofs].reshape(-1, 3)
    problem.x0.x.array[rdofs] = np.asarray(f(pos), dtype=float).reshape(-1)
    r = S.split(problem.x0)["r"]
    S.assign(problem.x0, "C", ufl.inner(r.dx(0), r.dx(0)))
    set_state(problem)
