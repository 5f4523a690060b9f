"""Actuators of soft and continuum arms as power ports: pneumatic chambers and tendons.

Both act on a rod (forms/cosserat_rod.py) or a planar beam (forms/planar_beam.py)
through a *fibre* of the arm: the curve

    p(s) = phi(s) + y_a(s) d_2(s) + y_b(s) d_3(s)            (3D rod; d_1 = axis)
    p(s) = r(s) + y(s) d_2(s)                                 (planar beam)

at the offset y(s) in the cross-section frame (a `Routing`).  Its tangent in
the section frame is affine in the rod's strains (' = d/ds):

    e = R^T p' = e_1 + Gamma + K x y + y'      (y = (0, y_a, y_b), Gamma_i = d_i.phi' - delta_i1,
                                                K_i = 1/2 eps_ijk d_j'.d_k: the rod's own strains)
    e = (1 + Gamma_1 - y kappa, Gamma_2 + y')   (planar: y along d_2, kappa = phi')

Pneumatic chamber (Eugster, Weeger, Capobianco, ... RA-L 7(2) 2022: the pressure
is part of the resultant contact forces).  A chamber of cross-section area A
whose centroid follows y(s) sweeps the volume

    V = A int_{s0}^{s1} e_1 . e ds = A int (1 + Gamma_1 + y_b K_2 - y_a K_3) ds       (3D)
    V = A int (1 + Gamma_1 - y kappa) ds                                            (planar)

(the Jacobian of (s, xi) -> phi + xi_a d_a is d_1.(phi' + xi_a d_a'), and
d_1.d_2' = -K_3, d_1.d_3' = K_2 for orthonormal directors).  V is LINEAR in
the strains.  Port: input the gauge pressure p(t), output Vdot; the power
p Vdot enters the balance rows through the strain rates of the rod's own rows,

    - < p, B(x_m)^T delta > = - p A int e_1 . (gamma_dot(delta) + kappa_dot(delta) x y) ds

(gamma_dot, kappa_dot: the strain rates of the test velocities at the
midpoint configuration, exactly the terms the rod's balance rows pair with N
and M).  Equivalently the pressure adds -pA e_1 to N and -pA (y x e_1) to M:
a positive pressure elongates (N_1 = pA in equilibrium) and bends the arm
AWAY from the chamber (M = pA y x e_1, kappa = pA |y| / EI).

Tendon (Rucker & Webster, IEEE T-RO 27(6) 2011, in the virtual-work form of
cardillo's tendon force and jsrm's length gradient).  A tendon of tension
tau >= 0 along y(s), s in [0, s_end] (it is fixed at s_end and pulled at
s = 0, where the actuator sits), has the length

    l = int_0^{s_end} |e| ds

and acts through the virtual work of tau l: power -tau ldot (input tau,
output -ldot).  The distributed wall forces of the routing and the
termination force at s_end both come out of the variation of l; nothing is
applied as a point load.  In equilibrium (free tip, no gravity) the rod's
resultants are N = -tau e/|e|, M = -tau y x e/|e|: a straight tendon at
offset d bends the rod TOWARD the tendon with kappa = tau d/EI and shortens
it by tau/EA.

Exactness.  Gamma(q), K(q) are quadratic in the configuration q, and
q_{n+1} - q_n = h v_m at the P2 nodes (the rod's kinematic rows, collocated), so

    e(q_{n+1}) - e(q_n) = h edot(x_m; z_m),    edot(x; w) = gamma_dot(x; w) + kappa_dot(x; w) x y

holds pointwise (a quadratic form has an exact midpoint derivative).  The
chamber's V is linear in e: its midpoint pairing gives p (V_{n+1} - V_n) =
h y u exactly.  For the tendon |e| is not quadratic; the pairing uses the
discrete gradient of the norm,

    g(e_n, e_{n+1}) = (e_n + e_{n+1}) / (|e_n| + |e_{n+1}|),
    g . (e_{n+1} - e_n) = (|e_{n+1}|^2 - |e_n|^2) / (|e_n| + |e_{n+1}|) = |e_{n+1}| - |e_n|

(no cancellation, no threshold), so at every quadrature point, hence for the
discrete length l_h (same rule):  h (-ldot) tau = -tau (l_{n+1} - l_n) exactly.
Both ports therefore satisfy H_{n+1} - H_n = h y.u (the port layer's
balance, for any pairing) AND, for constant inputs, H + tau l - p V is
conserved to round-off: the work a port reports is the exact change of its
own potential.  (Planar beam: Gamma, kappa are DG_{k-1} states with
Delta Gamma = h Pi gamma_dot; the identity is exact when g and y are
cellwise in DG_{k-1}, e.g. k = 1 and a constant offset; otherwise it holds
to O(h^3) per step -- the energy balance itself stays exact.)

A segment end (a tendon's s_end, a chamber's s0, s1) must be a mesh node:
the indicator of the segment is then integrated exactly.  Inputs are
run-time constants and so are the routing's numbers (a new value recompiles
nothing).  Only the actuators a scene lists are assembled.

Bad input raises one line: negative tension (also at run time, from a
tension history), an offset outside the cross-section (|y(s)| > radius), a
chamber area <= 0 or >= the section's area.

The closed forms of a free arm with uniform actuation (a circular arc for
straight tendons and chambers, a helix for a helical tendon) are at the end
of this file (`uniform_equilibrium`, `uniform_centreline`).
"""
from dataclasses import dataclass, field

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from rodfem.errors import ParameterError
from rodfem.forms import cosserat_rod
from rodfem.forms.cosserat_rod import DIRECTORS, RATES

# --------------------------------------------------------------------------------------------
# Routings y(s): one function for UFL and numpy (lib = ufl or numpy), with run-time numbers.


@dataclass
class Routing:
    """A path y(s) in the cross-section frame: `path(s, c, lib) -> (y, y')` (lists of components),
    with the numbers c (dict name -> value) that become run-time constants."""
    kind: str
    params: dict
    path: object
    dim: int = 2          # 2: (y_a, y_b) on (d_2, d_3) of the 3D rod; 1: y on d_2 of the planar beam

    def numeric(self, s):
        """(y, y') at the numbers s (arrays of shape (dim, len(s)))."""
        s = np.asarray(s, dtype=float)
        y, dy = self.path(s, {k: np.asarray(v, dtype=float) for k, v in self.params.items()}, np)
        return (np.array([np.broadcast_to(c, s.shape) for c in y]),
                np.array([np.broadcast_to(c, s.shape) for c in dy]))


def straight(offset):
    """A constant offset: (y_a, y_b) for the 3D rod, or a number y (planar beam)."""
    off = np.atleast_1d(np.asarray(offset, dtype=float))
    if off.shape not in ((1,), (2,)):
        raise ParameterError(f"offset must be a number (planar) or (y_a, y_b) (got {offset!r})")
    return Routing("straight", {"offset": off}, lambda s, c, lib: ([c["offset"][i] for i in range(len(off))],
                                                                    [0.0 * s] * len(off)), dim=len(off))


def helical(radius, rate, phase=0.0):
    """y = radius (cos(rate s + phase), sin(rate s + phase)): rate 2 pi/L is one turn over the rod."""
    def path(s, c, lib):
        a = c["rate"] * s + c["phase"]
        R, k = c["radius"], c["rate"]
        return [R * lib.cos(a), R * lib.sin(a)], [-R * k * lib.sin(a), R * k * lib.cos(a)]
    return Routing("helical", {"radius": float(radius), "rate": float(rate), "phase": float(phase)}, path)


def converging(offset, length):
    """y = (1 - s/length) offset: the routing converges onto the axis at s = length."""
    off = np.atleast_1d(np.asarray(offset, dtype=float))

    def path(s, c, lib):
        return ([(1.0 - s / c["length"]) * c["offset"][i] for i in range(len(off))],
                [-c["offset"][i] / c["length"] + 0.0 * s for i in range(len(off))])
    return Routing("converging", {"offset": off, "length": float(length)}, path, dim=len(off))


def on_circle(radius, angle):
    """The offset (y_a, y_b) = radius (cos angle, sin angle) (angle in rad, from d_2 towards d_3)."""
    return (radius * np.cos(angle), radius * np.sin(angle))


# --------------------------------------------------------------------------------------------
# The fibre tangent e and its rate, for the two models


def _is_rod(x):
    return "d1" in x


def rod_strains(x):
    """(Gamma, K) of the 3D rod configuration x (quadratic in q)."""
    d = [x[n] for n in DIRECTORS]
    Gamma = cosserat_rod.shear_strain(x["r"], d) - ufl.as_vector([1.0, 0.0, 0.0])
    return Gamma, cosserat_rod.curvature(d)


def rod_strain_rates(xm, w):
    """(gamma_dot, kappa_dot) of the velocities w at xm: the rates the rod's compliance rows use
    (C_N Ndot = R^T v' + (phi'.w_i)_i,  C_M Mdot = J_K w); linear in w."""
    d = [xm[n] for n in DIRECTORS]
    ws = [w[n] for n in RATES]
    gamma = cosserat_rod.frame(d).T * w["v"].dx(0) + ufl.as_vector([ufl.inner(xm["r"].dx(0), wi) for wi in ws])
    return gamma, cosserat_rod.curvature_rate(d, ws)


def fibre_tangent(x, y, dy):
    """e = R^T p' of the fibre at offset y (y' = dy), from the strains of x."""
    if _is_rod(x):
        Gamma, K = rod_strains(x)
        y3, dy3 = ufl.as_vector([0.0, y[0], y[1]]), ufl.as_vector([0.0, dy[0], dy[1]])
        return ufl.as_vector([1.0, 0.0, 0.0]) + Gamma + ufl.cross(K, y3) + dy3
    Gamma, kappa = x["Gamma"], x["kappa"]
    return ufl.as_vector([1.0 + Gamma[0] - y[0] * kappa, Gamma[1] + dy[0]])


def fibre_tangent_rate(xm, w, y):
    """edot(xm; w): the rate of e for the velocities (or test functions) w; linear in w."""
    if _is_rod(xm):
        gamma, kappa = rod_strain_rates(xm, w)
        return gamma + ufl.cross(kappa, ufl.as_vector([0.0, y[0], y[1]]))
    from rodfem.forms.planar_beam import S_HAT, rotation
    gamma = rotation(xm["phi"]).T * (w["v"].dx(0) - w["omega"] * S_HAT * xm["r"].dx(0))
    return ufl.as_vector([gamma[0] - y[0] * w["omega"].dx(0), gamma[1]])


# --------------------------------------------------------------------------------------------
# The ports


def _history(value, what):
    """A callable t -> float from a number or a callable."""
    if callable(value):
        return value
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{what} must be a number or a function of t (got {value!r})") from None
    return lambda t: v


@dataclass
class _Actuator:
    """What the actuators share: an input history, a routing, a segment, run-time constants.

    The port protocol of rodfem/core/body.py: bind(mesh, space), update(t),
    input_map(step, test, dx, ds), power(step, dx, ds), observables(X, dx, ds), name.
    """
    value: object
    routing: Routing
    radius: float
    segment: tuple = None
    name: str = ""
    constant: fem.Constant = field(default=None, init=False, repr=False)
    INPUT = "input"

    def __post_init__(self):
        self.history = _history(self.value, f"{self.name}: {self.INPUT}")
        self.value = self.input    # value(t), as a Load's: what statics reads (analysis/statics.py set_load)
        if not isinstance(self.routing, Routing):
            self.routing = straight(self.routing)
        if not (np.isfinite(self.radius) and self.radius > 0):
            raise ParameterError(f"{self.name}: the cross-section radius must be > 0 (got {self.radius!r})")
        if self.segment is not None:
            s0, s1 = (float(v) for v in self.segment)
            if not (0 <= s0 < s1):
                raise ParameterError(f"{self.name}: segment must be (s0, s1) with 0 <= s0 < s1 (got {self.segment!r})")
            self.segment = (s0, s1)
        # the offset over the segment now (over the whole rod at bind, when L is known; at s = 0 now)
        self._check_offset(*(self.segment or (0.0, 0.0)))
        self._check_input(self.history(0.0), 0.0)

    def _check_offset(self, s0, s1):
        y, _ = self.routing.numeric(np.linspace(s0, s1, 2001))
        worst = float(np.max(np.linalg.norm(y, axis=0)))
        if worst > self.radius * (1 + 1e-12):
            raise ParameterError(f"{self.name}: the offset |y| = {worst:g} leaves the cross-section of radius "
                                 f"{self.radius:g}")

    def _check_input(self, value, t):
        if not np.isfinite(value):
            raise ParameterError(f"{self.name}: {self.INPUT} must be finite (got {value!r} at t = {t:g})")

    # -- the port protocol ----------------------------------------------------------------
    def bind(self, mesh, space):
        self.rod = "d1" in space.names
        if not self.rod and "kappa" not in space.names:
            raise ParameterError(f"{self.name}: actuators act on the 3D rod or the planar beam (fields {space.names})")
        want = 2 if self.rod else 1
        if self.routing.dim != want:
            raise ParameterError(f"{self.name}: the {'3D rod' if self.rod else 'planar beam'} needs an offset with "
                             f"{want} component(s) (got {self.routing.dim})")
        x = mesh.geometry.x[:, 0]
        length = mesh.comm.allreduce(float(x.max()) if len(x) else -np.inf, op=MPI.MAX)
        if self.segment is None:
            self.segment_ufl = None
        else:
            if self.segment[1] > length * (1 + 1e-12):
                raise ParameterError(f"{self.name}: segment end {self.segment[1]:g} beyond the rod (L = {length:g})")
            for end in self.segment:
                here = bool(np.any(np.isclose(x, end, rtol=0, atol=1e-12 * length)))
                if not mesh.comm.allreduce(here, op=MPI.LOR):
                    raise ParameterError(f"{self.name}: segment end s = {end:g} must be a mesh node "
                                     f"(an element boundary)")
            self.segment_ufl = [fem.Constant(mesh, v) for v in self.segment]
        if self.segment is None:
            self._check_offset(0.0, length)
        self.s = ufl.SpatialCoordinate(mesh)[0]
        c = {k: fem.Constant(mesh, np.asarray(v, dtype=float)) for k, v in self.routing.params.items()}
        self.params = c
        self.y, self.dy = self.routing.path(self.s, c, ufl)
        self.constant = fem.Constant(mesh, float(self.history(0.0)))
        self._bind_more(mesh)

    def _bind_more(self, mesh):
        pass

    def input(self, t):
        """The input at time t, checked (one line if it is not finite, or a negative tension)."""
        value = float(self.history(t))
        self._check_input(value, t)
        return value

    def update(self, t):
        self.constant.value = self.input(t)

    def indicator(self):
        """1 on the actuator's segment (quadrature points are interior: the ends are nodes)."""
        if self.segment_ufl is None:
            return 1.0
        s0, s1 = self.segment_ufl
        return ufl.conditional(ufl.And(ufl.ge(self.s, s0), ufl.le(self.s, s1)), 1.0, 0.0)

    def input_map(self, step, test, dx, ds):
        """B u: the term -<u, B(x)^T delta> of the balance rows."""
        return -self.pairing(step, test) * dx

    def power(self, step, dx, ds):
        """y.u with the midpoint flows (h times it is the work of the step)."""
        return self.pairing(step, {n: step.mid(n) for n in step.x0}) * dx


@dataclass
class Chamber(_Actuator):
    """Pneumatic chamber: gauge pressure p(t) (number or function of t), area A, centroid offset
    `routing` (a Routing, or (y_a, y_b) / a number for a straight chamber), inside a section of
    `radius`, along `segment` = (s0, s1) (None: the whole rod).  Input p, output Vdot."""
    area: float = 0.0
    INPUT = "pressure"

    def __post_init__(self):
        self.name = self.name or "chamber"
        if not (np.isfinite(self.area) and 0 < self.area < np.pi * self.radius ** 2):
            raise ParameterError(f"{self.name}: chamber area must be > 0 and below the section's pi radius^2 "
                             f"(got {self.area!r})")
        super().__post_init__()

    def _bind_more(self, mesh):
        self.area_c = fem.Constant(mesh, float(self.area))

    def volume_density(self, x):
        """A e_1.e: the chamber volume per unit reference length."""
        return self.area_c * self.indicator() * fibre_tangent(x, self.y, self.dy)[0]

    def pairing(self, step, w):
        """p A e_1 . edot(x_m; w): the pressure's power density (= p Vdot for the midpoint flows)."""
        xm = {n: step.mid(n) for n in step.x0}
        return self.constant * self.area_c * self.indicator() * fibre_tangent_rate(xm, w, self.y)[0]

    def observables(self, X, dx, ds):
        return {f"volume_{self.name}": self.volume_density(X) * dx}


@dataclass
class Tendon(_Actuator):
    """Tendon: tension tau(t) >= 0 (number or function of t) along `routing` (a Routing, or
    (y_a, y_b) / a number for a straight tendon) inside a section (or spacer discs) of `radius`,
    fixed at s_end = `end` (None: the tip), pulled at s = 0.  Input tau, output -ldot."""
    end: float = None
    INPUT = "tension"

    def __post_init__(self):
        self.name = self.name or "tendon"
        if self.end is not None:
            self.segment = (0.0, float(self.end))
        super().__post_init__()

    def _check_input(self, value, t):
        super()._check_input(value, t)
        if value < 0:
            raise ParameterError(f"{self.name}: tension must be >= 0, a tendon cannot push "
                                 f"(got {value:g} at t = {t:g})")

    def tangent(self, x):
        return fibre_tangent(x, self.y, self.dy)

    def length_density(self, x):
        e = self.tangent(x)
        return self.indicator() * ufl.sqrt(ufl.inner(e, e))

    def pairing(self, step, w):
        """-tau g(e_n, e_{n+1}) . edot(x_m; w): with the midpoint flows, h times it is
        -tau (l_{n+1} - l_n) exactly at every quadrature point (discrete gradient of |e|)."""
        e0, e1 = self.tangent(step.x0), self.tangent(step.x1)
        g = (e0 + e1) / (ufl.sqrt(ufl.inner(e0, e0)) + ufl.sqrt(ufl.inner(e1, e1)))
        xm = {n: step.mid(n) for n in step.x0}
        return -self.constant * self.indicator() * ufl.inner(g, fibre_tangent_rate(xm, w, self.y))

    def observables(self, X, dx, ds):
        return {f"length_{self.name}": self.length_density(X) * dx}


# --------------------------------------------------------------------------------------------
# Closed forms: a free arm (clamped at s = 0, no gravity) under uniform actuation
#
# The tendon length and the chamber volume depend on the strains only, so the
# equilibrium of a free arm is POINTWISE (no ODE):
#     N = K_se Gamma = sum_i p_i A_i e_1 - sum_j tau_j e_j/|e_j|
#     M = K_bt K     = sum_i p_i A_i y_i x e_1 - sum_j tau_j y_j x e_j/|e_j|
# with e_j = e_1 + Gamma + K x y_j + y_j'.  Straight routings: (Gamma, K) is
# constant along s.  Helical routings with one common rate f on an isotropic
# section: in the frame E that co-rotates with the routing (E = R Q(f s),
# Q a rotation by f s about e_1) every y_j, y_j' = f e_1 x y_j is constant,
# so the strains in that frame are constant; E has the constant curvature
# Omega = K~ + f e_1 and the tangent t = e_1 + Gamma~: the centreline is a
# helix (a circular arc when Omega is normal to t).


def hat(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def pointwise_strains(K_se, K_bt, tendons=(), chambers=(), N_ext=(0.0, 0.0, 0.0), M_ext=(0.0, 0.0, 0.0),
                      z0=None, tol=1e-14):
    """(Gamma, K) with K_se Gamma = N, K_bt K = M at one point of a free arm:

        N = N_ext + sum_i p_i A_i e_1       - sum_j tau_j e_j/|e_j|
        M = M_ext + sum_i p_i A_i y_i x e_1 - sum_j tau_j y_j x e_j/|e_j|,   e_j = e_1 + Gamma + K x y_j + y_j'

    K_se = (EA, GA_2, GA_3), K_bt = (GJ, EI_2, EI_3) (body frame); tendons: (tau, y, y') with
    y = (y_a, y_b); chambers: (p, A, y); N_ext, M_ext: the resultants of the other loads (body frame).
    Fixed-point iteration (a contraction when tau |y|^2 << EI, tau << EA), Newton if it stalls.
    """
    K_se, K_bt = np.asarray(K_se, float), np.asarray(K_bt, float)
    e1 = np.array([1.0, 0.0, 0.0])
    T = [(float(t), np.array([0.0, *y]), np.array([0.0, *dy])) for t, y, dy in tendons]
    C = [(float(p), float(A), np.array([0.0, *y])) for p, A, y in chambers]
    N0 = np.asarray(N_ext, float) + sum((p * A * e1 for p, A, _ in C), np.zeros(3))
    M0 = np.asarray(M_ext, float) + sum((p * A * np.cross(y, e1) for p, A, y in C), np.zeros(3))
    stiff = np.concatenate([K_se, K_bt])

    def resultants(z):
        G, K = z[:3], z[3:]
        N, M = N0.copy(), M0.copy()
        for tau, y, dy in T:
            e = e1 + G + np.cross(K, y) + dy
            N -= tau * e / np.linalg.norm(e)
            M -= tau * np.cross(y, e) / np.linalg.norm(e)
        return np.concatenate([N, M])

    z = np.zeros(6) if z0 is None else np.array(z0, dtype=float)
    for _ in range(60):                      # fixed point z <- K^-1 resultants(z)
        z_new = resultants(z) / stiff
        if np.max(np.abs(z_new - z)) <= tol * max(1.0, np.max(np.abs(z_new))):
            return z_new[:3], z_new[3:]
        z = z_new
    for _ in range(50):                      # Newton (finite-difference Jacobian)
        F = stiff * z - resultants(z)
        J = np.empty((6, 6))
        for k in range(6):
            dz = np.zeros(6)
            dz[k] = 1e-7 * max(1e-3, abs(z[k]))
            J[:, k] = (stiff * (z + dz) - resultants(z + dz) - stiff * (z - dz) + resultants(z - dz)) / (2 * dz[k])
        step = np.linalg.solve(J, F)
        z = z - step
        if np.max(np.abs(step)) <= tol * max(1.0, np.max(np.abs(z))):
            return z[:3], z[3:]
    raise RuntimeError("pointwise_strains: no convergence")


def uniform_equilibrium(K_se, K_bt, tendons=(), chambers=(), rate=0.0):
    """The strains (Gamma~, K~) of the free arm (no gravity), constant in the frame co-rotating at `rate`.

    tendons: (tau, y) with y = (y_a, y_b) the offset at s = 0 (a helical routing at `rate`: its
    y' = rate e_1 x y in the co-rotating frame; rate = 0: straight); chambers: (p, A, y) (straight).
    """
    if rate and (K_se[1] != K_se[2] or K_bt[1] != K_bt[2]):
        raise ValueError("a helical routing needs an isotropic section (GA_2 = GA_3, EI_2 = EI_3)")
    T = [(tau, y, (-rate * y[1], rate * y[0])) for tau, y in tendons]
    return pointwise_strains(K_se, K_bt, T, chambers)


def shooting_statics(K_se, K_bt, length, tendons=(), chambers=(), force=(0.0, 0.0, 0.0), R0=np.eye(3),
                     steps=400, G0=None):
    """Static shape of an arm clamped at s = 0 (R0 = [d1 d2 d3] there) under tendons (tau, Routing),
    chambers (p, A, Routing) and a uniform force per length `force` (gravity), by shooting (RK4 in s).

    An independent check of the finite elements (strong form, composite cuts as in Rucker & Webster):
    cutting rod AND tendons at s, the distal part carries F(s) = force (L - s) and the moment
    G(s) - r x F with G(s) = int_s^L r x force; the rod's resultants are then:

        n = F - sum_j tau_j t_j,   m = G - r x F - sum_j (R y_j) x tau_j t_j

    (t_j the tendon's unit tangent), solved pointwise for the strains (`pointwise_strains`), and
    r' = R (e_1 + Gamma), R' = R hat(K), G' = -r x force.  The unknown G(0) makes G(L) = 0.
    Newton on G(0) starts from `G0` (default 0): where there are several equilibria (a column above its
    buckling load), the guess selects one.  Returns (s, r(s), R(s)).
    """
    f = np.asarray(force, float)
    h = length / steps

    def routings(s):
        T = []
        for tau, routing in tendons:
            y, dy = routing.numeric([s])
            T.append((tau, y[:, 0], dy[:, 0]))
        C = []
        for p, A, routing in chambers:
            y, _ = routing.numeric([s])
            C.append((p, A, y[:, 0]))
        return T, C

    def rhs(s, r, R, G, z0):
        F = f * (length - s)
        T, C = routings(s)
        Gm, K = pointwise_strains(K_se, K_bt, T, C, R.T @ F, R.T @ (G - np.cross(r, F)), z0=z0)
        return R @ (np.array([1.0, 0.0, 0.0]) + Gm), R @ hat(K), -np.cross(r, f), np.concatenate([Gm, K])

    def integrate(G0, keep=False):
        r, R, G, z = np.zeros(3), np.array(R0, float), np.array(G0, float), None
        out = [(0.0, r, R)]
        for k in range(steps):
            s = k * h
            k1 = rhs(s, r, R, G, z)
            z = k1[3]
            k2 = rhs(s + h / 2, r + h / 2 * k1[0], R + h / 2 * k1[1], G + h / 2 * k1[2], z)
            k3 = rhs(s + h / 2, r + h / 2 * k2[0], R + h / 2 * k2[1], G + h / 2 * k2[2], z)
            k4 = rhs(s + h, r + h * k3[0], R + h * k3[1], G + h * k3[2], z)
            r = r + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
            R = R + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
            G = G + h / 6 * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2])
            if keep:
                out.append(((k + 1) * h, r, R))
        return G, out

    G0 = np.zeros(3) if G0 is None else np.array(G0, float)
    scale = max(np.linalg.norm(f) * length ** 2, 1e-300)
    for _ in range(30):
        GL, _ = integrate(G0)
        if np.linalg.norm(GL) <= 1e-13 * scale or not np.any(f):
            break
        J = np.empty((3, 3))
        for k in range(3):
            d = np.zeros(3)
            d[k] = 1e-6 * scale
            J[:, k] = (integrate(G0 + d)[0] - GL) / d[k]
        G0 = G0 - np.linalg.solve(J, GL)
    _, out = integrate(G0, keep=True)
    return np.array([o[0] for o in out]), np.array([o[1] for o in out]), np.array([o[2] for o in out])


def uniform_centreline(Gamma, K, s, rate=0.0, start=(0.0, 0.0, 0.0), R0=np.eye(3)):
    """Centreline r(s) and directors R(s) of a rod whose strains are (Gamma, K) in the frame
    co-rotating at `rate` (exact: r' = E t, E' = E hat(Omega), t = e_1 + Gamma, Omega = K + rate e_1).
    R0 = [d1 d2 d3] at s = 0 (columns).  Returns r (len(s), 3) and the frames E (len(s), 3, 3)."""
    t = np.array([1.0, 0.0, 0.0]) + np.asarray(Gamma, float)
    Om = np.asarray(K, float) + rate * np.array([1.0, 0.0, 0.0])
    w = np.linalg.norm(Om)
    W = hat(Om)
    rs, Es = [], []
    for si in np.atleast_1d(s):
        # exp(s W) = I + sin(ws)/w W + (1 - cos ws)/w^2 W^2;  int_0^s exp = s I + c W + d W^2
        if w * si < 1e-6:   # the series (relative error < 1e-13)
            b, c, d = si - w ** 2 * si ** 3 / 6, si ** 2 / 2 - w ** 2 * si ** 4 / 24, si ** 3 / 6
        else:
            b = np.sin(w * si) / w
            c, d = (1 - np.cos(w * si)) / w ** 2, (w * si - np.sin(w * si)) / w ** 3
        E = np.eye(3) + b * W + c * W @ W
        intE = si * np.eye(3) + c * W + d * W @ W
        rs.append(np.asarray(start, float) + R0 @ intE @ t)
        Es.append(R0 @ E)
    return np.array(rs), np.array(Es)
