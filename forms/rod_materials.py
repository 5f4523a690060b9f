"""Materials of the 3D Cosserat rod: a complementary energy W*(N, M) written as one UFL function.

The rod (forms/cosserat_rod.py) is in compliance form: its states are the
stress resultants N (axial, shear2, shear3) and M (torsion, bend2, bend3) in
the section frame, and a material gives the strains measured from the
stress-free reference as the gradients of its complementary energy,

    gamma = dW*/dN  (= Gamma - Gamma^0),     kappa = dW*/dM  (= K - K^0).

The stored (strain) energy is the Legendre transform, in the stresses:

    U(N, M) = N . gamma + M . kappa - W*(N, M)        (= 1/2 W* ... = W* for a quadratic W*)

Adding a material is writing ONE function of (N, M) (UFL 3-vectors) and its
parameters, decorated with `@rod_material` -- `stiffening` below is an example:

    @rod_material(nonnegative=COMPLIANCES)
    def my_law(N, M, C_N1, ..., beta):
        # docstring: W*, the strains, the small-strain compliances
        return ...

`my_law(C_N1=..., ...)` is then a `RodMaterial`; its parameters enter the
compiled forms as run-time constants (rodfem/core/materials.py).  Parameters
are positive numbers, except those named in `nonnegative` (compliances:
0 makes the strain a constraint, its stress a multiplier) or `signed`
(coupling terms); `check(params)` may add a condition across parameters
(e.g. positive definiteness).  Every check fails with a one-line ValueError
naming the parameter and the allowed range.  Add the name to MATERIALS to
make it selectable in the 3D scenes (``--set material=...``) and covered by
the per-material tests (tests/models/test_rod_materials.py).

Conditions on W*: convex (a compliance matrix >= 0), W*(0) = 0 and dW*/d(N, M)
(0) = 0 (the reference is stress-free and strain-free: checked), and a
component with zero small-strain compliance must not enter W* at all (it is
a constraint).  Declare ``quadratic=True`` when W* is a quadratic form: the
rod then keeps the rate form C d_t(N, M) = strain rate, with no extra
fields, exact under both time integrators.  Any other W* gets the strain
fields (gamma, kappa) and Gonzalez' discrete gradient of W* (see the rod's
docstring); its balance is exact under the discrete-gradient rule only.

A law known only as a strain energy W(Gamma, K) is not offered in the time
stepping: its compliance form needs W* = sup (N.gamma - W), whose
evaluation point by point is a local Newton solve at every quadrature point
of every residual (no UFL expression).  `RodMaterial.stresses` does that
Legendre transform numerically for numbers (scenes use it, e.g. for the end
moment that rolls a stiffening rod into a circle); a law given as W can
also be written in closed form as W* when it is one-dimensional per
component, as `stiffening` shows (W = EI kappa_l^2 (1 - sqrt(1 - kappa^2/kappa_l^2))).
"""
import math

import numpy as np
import ufl
from ufl.algorithms import expand_derivatives

from rodfem.core import materials

COMPLIANCES = ("C_N1", "C_N2", "C_N3", "C_M1", "C_M2", "C_M3")
PROBE = (0.31, -0.27, 0.23, 0.41, -0.37, 0.29)   # a generic stress point (see RodMaterial.weights)


class RodMaterial(materials.Material):
    """A complementary energy W*(N, M; params), with its response for numbers."""
    quadratic = False
    nonnegative = ()
    check = None
    stress_scales = None

    def __init__(self, name, function, params, signed=()):
        super().__init__(name, function, params, signed=tuple(signed) + tuple(self.nonnegative))
        for key in self.nonnegative:
            value = self.params[key]
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"material {name}: parameter {key} must be a number >= 0 (got {value!r})")
        if self.check is not None:
            message = type(self).check(self.params)
            if message:
                raise ValueError(f"material {name}: {message}")
        g = self.strains(np.zeros(6))
        if np.any(g != 0) or self.energy(np.zeros(6)) != 0:
            raise ValueError(f"material {name}: W*(0) and dW*/d(N, M)(0) must be 0 (a stress-free, strain-free "
                             f"reference); got strains {tuple(g)}")

    # -- numbers ---------------------------------------------------------------------------
    def _at(self, X):
        X = ufl.variable(ufl.as_vector([float(x) for x in np.asarray(X, dtype=float).ravel()]))
        return X, self(ufl.as_vector([X[i] for i in range(3)]), ufl.as_vector([X[i] for i in range(3, 6)]))

    def energy(self, X):
        """W*(N, M) for numbers X = (N1, N2, N3, M1, M2, M3)."""
        return float(self._at(X)[1])

    def strains(self, X):
        """(gamma, kappa) = dW*/d(N, M) at X = (N, M) (numbers, 6)."""
        X, W = self._at(X)
        g = expand_derivatives(ufl.diff(W, X))
        return np.array([float(g[i]) for i in range(6)])

    def compliance(self, X=np.zeros(6)):
        """The tangent compliance d^2 W*/d(N, M)^2 at X (6 x 6; at 0: the small-strain compliances)."""
        X, W = self._at(X)
        H = expand_derivatives(ufl.diff(ufl.diff(W, X), X))
        return np.array([[float(H[i, j]) for j in range(6)] for i in range(6)])

    def stresses(self, e, X0=None, tol=1e-13, maxit=50):
        """The Legendre transform numerically: (N, M) with dW*/d(N, M) = e (6 strains), by Newton
        from X0 (default: the small-strain answer).  Components of zero compliance stay 0."""
        e = np.asarray(e, dtype=float)
        active = np.diag(self.compliance()) > 0
        C0 = self.compliance()[np.ix_(active, active)]
        X = np.zeros(6)
        X[active] = np.linalg.solve(C0, e[active]) if X0 is None else np.asarray(X0, float)[active]
        for _ in range(maxit):
            r = (self.strains(X) - e)[active]
            if np.max(np.abs(r)) <= tol * max(1.0, np.max(np.abs(e))):
                return X
            X[active] -= np.linalg.solve(self.compliance(X)[np.ix_(active, active)], r)
        raise ValueError(f"material {self.name}: no stresses for the strains {tuple(e)} (Newton: {maxit} iterations)")

    def scales(self):
        """Stress scales S_i of the six components: where W* departs from its Taylor polynomial.
        Default 1/C0_ii (C0: the small-strain compliances; the stress of a unit strain) or 1;
        a material with a narrower nonlinearity declares it (`rod_material(scales=...)`)."""
        C0 = np.diag(self.compliance())
        S = [1.0 / c if c > 0 else 1.0 for c in C0]
        if self.stress_scales is not None:
            for i, value in type(self).stress_scales(self.params).items():
                S[i] = float(value)
        return S

    def weights(self):
        """The metric of the discrete gradient's correction (rodfem/core/integrators.py): 1/S_i^2 per
        component (`scales`), i.e. Gonzalez' rule in the dimensionless y_i = X_i/S_i, as the rule's
        Taylor threshold |dy| <= 1e-3 assumes.  In the stresses themselves, a moment of 800 N m
        would take the cancelling quotient at every step (a residual floor of 4e-12 in the
        roll-up), and a law with a narrow transition (asymmetric, delta = 1 N) the Taylor branch
        over steps much wider than delta (a balance error of 3e-8).  0 for a component W* does not
        depend on (a zero compliance: a constraint, whose strain stays exactly 0)."""
        g = self.strains(PROBE)
        return [0.0 if gi == 0.0 else 1.0 / S ** 2 for S, gi in zip(self.scales(), g)]


def rod_material(function=None, *, quadratic=False, nonnegative=(), signed=(), check=None, scales=None):
    """Decorator: W*(N, M, **params) -> a factory params -> RodMaterial.  `check(params)`: a message
    if the parameters do not fit together; `scales(params)`: {component: stress scale} where the
    default 1/C0_ii is too wide (RodMaterial.scales)."""
    def wrap(f):
        cls = type(f.__name__, (RodMaterial,), {"quadratic": quadratic, "nonnegative": tuple(nonnegative),
                                               "check": None if check is None else staticmethod(check),
                                               "stress_scales": None if scales is None else staticmethod(scales)})
        return materials.material(f, strains=2, signed=signed, cls=cls)
    return wrap(function) if function is not None else wrap


def _diagonal(N, M, C):
    """1/2 sum_i C_Ni N_i^2 + 1/2 sum_i C_Mi M_i^2 for C = (C_N1, ..., C_M3)."""
    return 0.5 * (C[0] * N[0] ** 2 + C[1] * N[1] ** 2 + C[2] * N[2] ** 2
                  + C[3] * M[0] ** 2 + C[4] * M[1] ** 2 + C[5] * M[2] ** 2)


# -- the materials ---------------------------------------------------------------------------

@rod_material(quadratic=True, nonnegative=COMPLIANCES)
def linear(N, M, C_N1, C_N2, C_N3, C_M1, C_M2, C_M3):
    """Hooke, diagonal:  W* = 1/2 N.C_N N + 1/2 M.C_M M,  C_N = diag(C_N1, C_N2, C_N3) = diag(1/EA, 1/GA2,
    1/GA3),  C_M = diag(C_M1, C_M2, C_M3) = diag(1/GJ, 1/EI2, 1/EI3).

    gamma = C_N N, kappa = C_M M.  A zero compliance (inextensible, shear-rigid) makes that
    strain a constraint with its stress as multiplier.  The rod builds today's forms for it
    (bit for bit the same as CosseratRod(rhoA, rhoJ, C_N, C_M)).
    """
    return _diagonal(N, M, (C_N1, C_N2, C_N3, C_M1, C_M2, C_M3))


def _positive_definite_coupling(p):
    if p["C_NM"] ** 2 >= p["C_N1"] * p["C_M1"] and p["C_NM"] != 0:
        return (f"parameter C_NM must satisfy C_NM^2 < C_N1 C_M1 = {p['C_N1'] * p['C_M1']:g} "
                f"(a positive definite compliance; got {p['C_NM']!r})")
    return None


@rod_material(quadratic=True, nonnegative=COMPLIANCES, signed=("C_NM",), check=_positive_definite_coupling)
def stretch_twist(N, M, C_N1, C_N2, C_N3, C_M1, C_M2, C_M3, C_NM):
    """Coupled stretch-twist (helically wound cables, fibre-reinforced soft actuators):

        W* = linear + C_NM N_1 M_1,     gamma_1 = C_N1 N_1 + C_NM M_1,    kappa_1 = C_NM N_1 + C_M1 M_1

    (the other strains as `linear`).  Small-strain compliances: the 2 x 2 block
    [[C_N1, C_NM], [C_NM, C_M1]] of (N_1, M_1), positive definite: C_NM^2 < C_N1 C_M1 (checked;
    C_NM = 0 is `linear`).  A tension twists the rod, a torque stretches it.  Quadratic.
    """
    return _diagonal(N, M, (C_N1, C_N2, C_N3, C_M1, C_M2, C_M3)) + C_NM * N[0] * M[0]


def _bending_compliances(p):
    for key in ("C_M2", "C_M3"):
        if not p[key] > 0:
            return f"parameter {key} must be > 0 (a stiffening bending law needs bending; got {p[key]!r})"
    return None


@rod_material(nonnegative=COMPLIANCES, check=_bending_compliances,
              scales=lambda p: {4: p["kappa_lock"] / p["C_M2"], 5: p["kappa_lock"] / p["C_M3"]})
def stiffening(N, M, C_N1, C_N2, C_N3, C_M1, C_M2, C_M3, kappa_lock):
    """Bending that stiffens with curvature up to a locking curvature kappa_lock (> 0):

        W* = 1/2 N.C_N N + 1/2 C_M1 M_1^2 + q / (1 + sqrt(1 + c q / kappa_lock^2)),
        q = C_M2 M_2^2 + C_M3 M_3^2,   c = max(C_M2, C_M3)

    (= (kappa_lock^2/c)(sqrt(1 + c q/kappa_lock^2) - 1), written without cancellation).  For a
    round section (C_M2 = C_M3 = 1/EI) the bending strain is isotropic:

        kappa_b = M_b / (EI sqrt(1 + |M_b|^2 / (EI kappa_lock)^2)),   i.e.
        M_b = EI kappa_b / sqrt(1 - |kappa_b|^2 / kappa_lock^2)      (the strain energy
        W = EI kappa_lock^2 (1 - sqrt(1 - |kappa_b|^2/kappa_lock^2)) is its Legendre transform):

    the bending stiffness dM/dkappa = EI (1 - kappa^2/kappa_lock^2)^(-3/2) grows from EI
    without bound as |kappa_b| -> kappa_lock.  Small-strain compliances: those of `linear`.
    Not quadratic: use the discrete-gradient integrator for an exact energy balance.
    """
    q = C_M2 * M[1] ** 2 + C_M3 * M[2] ** 2
    c = ufl.max_value(C_M2, C_M3)
    return (_diagonal(N, M, (C_N1, C_N2, C_N3, C_M1, 0.0, 0.0))
            + q / (1.0 + ufl.sqrt(1.0 + c * q / kappa_lock ** 2)))


def _asinh_minus_identity(y):
    """asinh(y) - y, free of cancellation: a series for |y| < 1e-2 (remainder < y^11/10 ~ 1e-16 y^3)."""
    a = abs(y)
    direct = ufl.sign(y) * ufl.ln(a + ufl.sqrt(a * a + 1)) - y
    series = -y ** 3 / 6 + 3 * y ** 5 / 40 - 15 * y ** 7 / 336 + 105 * y ** 9 / 3456
    return ufl.conditional(ufl.lt(a, 1e-2), series, direct)


def ramp_energy(x, delta):
    """Phi(x) = int_0^x rho,  rho(x) = (x + sqrt(x^2 + delta^2))/2 - delta/2 (a smooth max(x, 0), rho(0) = 0):

        Phi = [x^2 + x^3/(sqrt(x^2 + delta^2) + delta) + delta^2 (asinh(x/delta) - x/delta)] / 4

    (= [x^2 + x sqrt(x^2 + delta^2) + delta^2 asinh(x/delta)]/4 - delta x/2, without its cancellation)."""
    root = ufl.sqrt(x * x + delta * delta)
    return (x * x + x ** 3 / (root + delta) + delta ** 2 * _asinh_minus_identity(x / delta)) / 4


@rod_material(nonnegative=("C_N2", "C_N3", "C_M1", "C_M2", "C_M3"), scales=lambda p: {0: p["delta"]})
def asymmetric(N, M, C_N1, C_N2, C_N3, C_M1, C_M2, C_M3, C_N1c, delta):
    """Axial law stiffer in tension than in compression (or the reverse), e.g. a braided soft robot:
    axial compliance C_N1 in tension, C_N1c in compression, a smooth transition of width delta
    (a force, > 0) around N_1 = 0:

        W* = 1/2 C_N1c N_1^2 + (C_N1 - C_N1c) Phi(N_1) + (the rest as `linear`),
        gamma_1 = C_N1c N_1 + (C_N1 - C_N1c) rho(N_1),   rho(x) = (x + sqrt(x^2 + delta^2) - delta)/2

    (Phi, rho: `ramp_energy`).  For N_1 >> delta: gamma_1 -> C_N1 N_1 - (C_N1 - C_N1c) delta/2;
    for N_1 << -delta: gamma_1 -> C_N1c N_1.  Small-strain axial compliance (C_N1 + C_N1c)/2;
    convex for C_N1, C_N1c > 0 (the tangent lies between them).  Not quadratic: use the
    discrete-gradient integrator for an exact energy balance.
    """
    return (0.5 * C_N1c * N[0] ** 2 + (C_N1 - C_N1c) * ramp_energy(N[0], delta)
            + _diagonal(N, M, (0.0, C_N2, C_N3, C_M1, C_M2, C_M3)))


MATERIALS = {"linear": linear, "stretch-twist": stretch_twist, "stiffening": stiffening, "asymmetric": asymmetric}
