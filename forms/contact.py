"""Contact with obstacles and Coulomb friction as energy-consistent ports (normal contact by a penalty
energy, friction as a dissipative element).

Obstacles: a plane through p with the outward normal n (any orientation), a sphere (a circle in 2D)
of centre c and radius R, an infinite cylinder of axis (p, a) and radius R.  Each is described by a
MEASURE xi(x) of a point x that is QUADRATIC (or linear) in x, and the distance d(xi) of x to the
obstacle's surface:

    plane     xi = n . (x - p),                    d = xi
    sphere    xi = |x - c|^2 - R^2,                      d = sqrt(xi + R^2) - R
    cylinder  xi = |x - p|^2 - (a . (x - p))^2 - R^2,    d = sqrt(xi + R^2) - R

(xi vanishes on the surface: near contact it is ~ 2 R d, on the scale of the penetration, which is
what the components' Taylor threshold -- 1e-3 |xi| -- needs).

A body of radius r (a rod's or string's cross-section, the tube of radius r about its centreline)
has the GAP g = d(xi(x)) - r; g < 0 is a penetration.

Normal contact: a stored energy of the gap, the one-sided cubic penalty

    psi(g) = k/3 <-g>^3       (<y> = max(y, 0); C^2: force k <-g>^2, stiffness 2 k <-g>)

so smooth enough for Newton.  `stiffness_for(load, penetration)` = load / penetration^2 is the k at
which the force (per unit length for a distributed contact) `load` penetrates `penetration`: the
scenes choose the penetration they accept under the bodies' weight (e.g. 1e-3 of the rod's radius)
and get k from it -- a stiffness relative to the load the contact carries, not to the bodies'
elastic stiffness (a rod's EA is irrelevant to how far it sinks into the ground).

Energy consistency (Hesch & Betsch, IJNME 77 (2009) 1468-1500, DOI 10.1002/nme.2466: contact
energies integrated with the discrete gradient; Gonzalez, J Nonlinear Sci 6 (1996) 449-467,
DOI 10.1007/BF02440162).  The energy Psi(xi) = psi(d(xi) - r) is a function of the one scalar xi,
and its co-energy in a step is the difference quotient (rodfem/core/integrators.py,
`Step.scalar_effort`)

    z = [Psi(xi_{n+1}) - Psi(xi_n)] / (xi_{n+1} - xi_n)

(the Taylor term where |xi_{n+1} - xi_n| <= 1e-3 of the measure's scale: for the plane's cubic
penalty it is exact, psi being a cubic on either side of g = 0).  Since xi is quadratic in x,
xi_{n+1} - xi_n = grad xi(x_m) . (x_{n+1} - x_n) exactly, and the force on the balance of momentum
is z grad xi(x_m).  With the kinematic rows x_{n+1} - x_n = h v_m (pointwise: position and velocity
share their space) its work in the step is exactly Psi_{n+1} - Psi_n, so

    H_{n+1} - H_n + dissipated = supplied,    H including the contact energy,

to round-off for ANY energy of the measure (the midpoint rule: only for psi linear in xi).

* Distributed contact of a rod, string or planar beam (`Contact`, listed in `System.add(...,
  contacts=[...])`): the energy int psi(g(r(s))) ds joins the body's H, the force
  int z grad xi . delta v ds its momentum row, with z the pointwise difference quotient at the
  quadrature points -- the same rule as the energy's (Gauss-Lobatto points = the nodes of the P1 and
  P2 centreline: the contact is lumped at the nodes, and the penetration is checked there).
* Point masses and rigid bodies (`plane_contact`, `sphere_contact`, `cylinder_contact`): the same
  energy as a component (rodfem/core/components.py: `Potential` of the quadratic measure) between
  the ground and a point of the body (a box's corners: `System.connect(law, GROUND, body.point(o))`).

Friction: REGULARIZED Coulomb friction on the slip velocity v_t of the contact point (the tangential
part of its velocity, n = grad xi / |grad xi| at x_m):

    f_t = -mu(|v_t|) N v_t / sqrt(|v_t|^2 + eps^2),     N = -z |grad xi(x_m)| >= 0,

with the normal force N of the step (the penalty's discrete gradient) and a Stribeck-type blend of
the static and kinetic coefficients

    mu(s) = mu_k + (mu_s - mu_k) exp(-(s / v_s)^2).

It is a regularization, not the exact set-valued law: a sticking contact creeps at the slip
velocity ~ eps f_t / (mu N) (eps = 2e-4 m/s by default), and dissipates about eps f_t^2 / (mu N) per
unit time, which is what "no energy lost while rolling" means here (a relative 5e-5 over the rolling
rod's half second).  The law is a stiff damper on the slip (rate ~ mu N / (m eps)): the implicit
midpoint rule rings on it unless the step resolves it (h mu N / (m_eff eps) of a few), and a sticking
contact needs eps << v_s (the force must reach mu_s N at a slip where mu is still ~ mu_s).
Sticking holds as long as the tangential force needs less than mu_s N (at a slip << v_s the
coefficient is mu_s); once sliding (slip >> v_s) the force is mu_k N.  The force's
work in a step, with the midpoint slip v_t,m, is

    h f_t . v_t,m = -h mu N |v_t,m|^2 / sqrt(|v_t,m|^2 + eps^2) <= 0,

booked in `dissipated` (h d_n >= 0 every step, exactly what the force takes out).  The contact point
of a body with a cross-section is the surface point x - r n: its velocity is v - r sum_{i=2,3}
(n . d_i) w_i for a rod with directors (the material point of the section circle in the plane of
d2, d3 facing the obstacle), v - r omega (-n_y, n_x) for a planar beam, v for a string or a point.
The friction of a rolling rod thus acts on its spin as well (`section_point_velocity`: the force at
the section point x + sum_k beta_k d_k is the force f on the centreline and the couple
(sum_k beta_k d_k) x f on the section).

Rod-rod and self-contact (forms/rod_contact.py) take the same law and the same section kinematics at
the contact point of two segments' tubes.  Not here: moving
obstacles, the exact (non-regularized) Coulomb law, rolling resistance, contact in statics.
"""
from dataclasses import dataclass
from typing import Optional

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from rodfem.core.components import dissipator, potential
from rodfem.errors import InputError

# -- the penalty energy ---------------------------------------------------------------------------

def cubic_penalty(k):
    """psi(g) = k/3 <-g>^3 (UFL or numbers, complex too: the components' complex-step derivative)."""
    def psi(g):
        if isinstance(g, ufl.core.expr.Expr):
            return k / 3.0 * ufl.conditional(ufl.lt(g, 0.0), -g, 0.0) ** 3
        return k / 3.0 * np.where(np.real(g) < 0.0, -g, 0.0) ** 3
    return psi


def stiffness_for(load, penetration):
    """k of the cubic penalty at which the normal force `load` (per unit length for a distributed contact)
    penetrates `penetration`: k <penetration>^2 = load."""
    if not (np.isfinite(load) and load > 0):
        raise InputError(f"contact: load must be a positive force (got {load!r})")
    if not (np.isfinite(penetration) and penetration > 0):
        raise InputError(f"contact: penetration must be a positive length (got {penetration!r})")
    return float(load) / float(penetration) ** 2


def _dot(a, b):
    return ufl.inner(a, b) if isinstance(a, ufl.core.expr.Expr) or isinstance(b, ufl.core.expr.Expr) else a @ b


def _sqrt(x):
    return ufl.sqrt(x) if isinstance(x, ufl.core.expr.Expr) else np.sqrt(x)


def _unit(v, what):
    v = np.asarray(v, dtype=float)
    n = np.linalg.norm(v)
    if v.ndim != 1 or len(v) not in (2, 3) or not np.isfinite(n) or n == 0:
        raise InputError(f"contact: {what} must be a nonzero vector of 2 or 3 numbers (got {v.tolist()})")
    return v / n


def _point(p, dim, what):
    p = np.asarray(p, dtype=float)
    if p.shape != (dim,) or not np.all(np.isfinite(p)):
        raise InputError(f"contact: {what} must be {dim} finite numbers (got {p.tolist()})")
    return p


def _radius(R, what="radius"):
    if not (np.isfinite(R) and R > 0):
        raise InputError(f"contact: {what} must be a positive length (got {R!r})")
    return float(R)


# -- obstacles: a quadratic measure xi(x), the distance d(xi), grad xi --------------------------------

class Plane:
    """The plane (a line in 2D) through `point` with the outward unit normal `normal` (the body's side)."""

    def __init__(self, normal, point=None):
        self.n = _unit(normal, "the plane's normal")
        self.dim = len(self.n)
        self.p = np.zeros(self.dim) if point is None else _point(point, self.dim, "the plane's point")
        self.scale = 1.0    # xi is a length

    def measure(self, x, n=None, p=None):
        """xi = n . (x - p)."""
        n = self.n if n is None else n
        p = self.p if p is None else p
        return _dot(n, x - p)

    def distance(self, xi):
        return xi

    def gradient(self, x, n=None, p=None):
        return self.n if n is None else n

    def constants(self, mesh):
        return {"n": fem.Constant(mesh, self.n), "p": fem.Constant(mesh, self.p)}

    def describe(self):
        return f"plane n = {np.round(self.n, 6).tolist()} through {self.p.tolist()}"


class Sphere:
    """A sphere (a circle in 2D) of centre `centre` and radius R: the body stays outside."""

    def __init__(self, centre, radius):
        self.p = np.asarray(centre, dtype=float)
        self.dim = len(self.p)
        _point(self.p, self.dim, "the sphere's centre")
        if self.dim not in (2, 3):
            raise InputError(f"contact: the sphere's centre must have 2 or 3 coordinates (got {self.p.tolist()})")
        self.R = _radius(radius, "the sphere's radius")
        self.scale = self.R ** 2   # xi is a squared length

    def measure(self, x, n=None, p=None):
        """xi = |x - c|^2 - R^2."""
        d = x - (self.p if p is None else p)
        return _dot(d, d) - self.R ** 2

    def distance(self, xi):
        """d = sqrt(xi + R^2) - R, written xi / (sqrt(xi + R^2) + R): without the cancellation, whose
        round-off the energy's difference quotient would magnify."""
        return xi / (_sqrt(xi + self.R ** 2) + self.R)

    def gradient(self, x, n=None, p=None):
        return 2.0 * (x - (self.p if p is None else p))

    def constants(self, mesh):
        return {"n": None, "p": fem.Constant(mesh, self.p)}

    def describe(self):
        return f"sphere centre {self.p.tolist()} radius {self.R:g}"


class Cylinder:
    """An infinite circular cylinder (3D) of axis through `point` along `axis`, radius R: the body
    stays outside (a string over a fixed drum: the capstan)."""

    def __init__(self, point, axis, radius):
        self.a = _unit(axis, "the cylinder's axis")
        if len(self.a) != 3:
            raise InputError("contact: a cylinder is a 3D obstacle (axis of 3 numbers); in 2D use Sphere (a circle)")
        self.dim = 3
        self.p = _point(point, 3, "the cylinder's point")
        self.R = _radius(radius, "the cylinder's radius")
        self.scale = self.R ** 2

    def measure(self, x, n=None, p=None):
        """xi = |x - p|^2 - (a . (x - p))^2 - R^2, the squared distance to the axis less R^2."""
        a = self.a if n is None else n
        d = x - (self.p if p is None else p)
        return _dot(d, d) - _dot(a, d) ** 2 - self.R ** 2

    def distance(self, xi):
        """d = sqrt(xi + R^2) - R, written xi / (sqrt(xi + R^2) + R): without the cancellation, whose
        round-off the energy's difference quotient would magnify."""
        return xi / (_sqrt(xi + self.R ** 2) + self.R)

    def gradient(self, x, n=None, p=None):
        a = self.a if n is None else n
        d = x - (self.p if p is None else p)
        return 2.0 * (d - _dot(a, d) * a)

    def constants(self, mesh):
        return {"n": fem.Constant(mesh, self.a), "p": fem.Constant(mesh, self.p)}

    def describe(self):
        return f"cylinder axis {np.round(self.a, 6).tolist()} through {self.p.tolist()} radius {self.R:g}"


# -- the section's kinematics: where friction acts on a body with a cross-section -------------------

DIRECTORS, RATES = ("d1", "d2", "d3"), ("w1", "w2", "w3")   # a director section and its rates w_k = d_t d_k


def section_kind(names, dim=3):
    """How a body's cross-section moves, from its fields' names: 'directors' (d1, d2, d3 and their rates
    w1, w2, w3: a 3D Cosserat rod), 'planar' (phi, omega of a planar beam, dim 2) or None (a string, a
    point: no section, friction acts at the centreline)."""
    names = set(names)
    if {*DIRECTORS, *RATES} <= names:
        return "directors"
    if {"phi", "omega"} <= names and dim == 2:
        return "planar"
    return None


def section_point_velocity(v, beta, rates):
    """The velocity v + sum_k beta_k w_k of the section's material point x + sum_k beta_k d_k (its
    coordinates beta_k in the director frame, the rates w_k = d_t d_k): v + omega x (sum_k beta_k d_k) for
    a rigid motion of the section (w_k = omega x d_k).  Linear in (v, w): with test functions in their
    place it is the virtual velocity, so a force f at the point acts on the centreline as f and on the
    section as the couple (sum_k beta_k d_k) x f.  UFL (beta, rates: sequences over k) or numpy (beta
    (m, K), rates (m, K, 3): m points at once, forms/rod_contact.py)."""
    if isinstance(beta, np.ndarray):
        return v + np.einsum("mk,mkj->mj", beta, rates)
    return v + sum(b * w for b, w in zip(beta, rates))


# -- friction ------------------------------------------------------------------------------------

@dataclass
class Coulomb:
    """Regularized Coulomb friction (module docstring): static and kinetic coefficients mu_s >= mu_k >= 0,
    the regularization velocity eps > 0 and the Stribeck velocity v_s > 0 of the blend
    mu(s) = mu_k + (mu_s - mu_k) exp(-(s/v_s)^2)."""
    mu_s: float
    mu_k: Optional[float] = None
    eps: float = 2e-4
    v_s: float = 1e-2

    def __post_init__(self):
        self.mu_k = self.mu_s if self.mu_k is None else self.mu_k
        if not (np.isfinite(self.mu_s) and self.mu_s >= 0):
            raise InputError(f"friction: mu_s must be a number >= 0 (got {self.mu_s!r})")
        if not (np.isfinite(self.mu_k) and 0 <= self.mu_k <= self.mu_s):
            raise InputError(f"friction: mu_k must be in [0, mu_s = {self.mu_s:g}] (got {self.mu_k!r})")
        for name in ("eps", "v_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise InputError(f"friction: {name} must be a positive velocity (got {value!r})")

    def force(self, N, vt, c=None):
        """f_t = -mu(|v_t|) N v_t / sqrt(|v_t|^2 + eps^2) (UFL with the constants c, or numbers)."""
        return self.factor(N, _dot(vt, vt), c) * vt

    def factor(self, N, s2, c=None):
        """-mu(s) N / sqrt(s^2 + eps^2) of the slip's square s2 = |v_t|^2 (f_t is it times v_t; numpy arrays
        elementwise: many contact points at once, e.g. forms/rod_contact.py's segment pairs)."""
        mu_s, mu_k, eps, v_s = ((c["mu_s"], c["mu_k"], c["eps"], c["v_s"]) if c is not None
                                else (self.mu_s, self.mu_k, self.eps, self.v_s))
        exp = ufl.exp if isinstance(s2, ufl.core.expr.Expr) else np.exp
        mu = mu_k + (mu_s - mu_k) * exp(-s2 / v_s ** 2)
        return -mu * N / _sqrt(s2 + eps ** 2)

    def constants(self, mesh):
        return {k: fem.Constant(mesh, float(getattr(self, k))) for k in ("mu_s", "mu_k", "eps", "v_s")}


# -- distributed contact of a flexible body --------------------------------------------------------

class Contact:
    """Contact of a body (rod, string, planar beam; a point mass too) with an obstacle along its whole
    length, an interaction of rodfem/core/body.py: `System.add(..., contacts=[Contact(...)])`.

    obstacle: Plane, Sphere or Cylinder (of the body's dimension); stiffness: k of psi = k/3 <-g>^3
    (> 0, per unit length; `stiffness_for`); radius: the body's radius r >= 0 (the gap is measured from
    the tube of radius r about the centreline); friction: a Coulomb or None; name: the columns' prefix.
    """

    def __init__(self, obstacle, stiffness, radius=0.0, friction: Optional[Coulomb] = None, name="contact"):
        if not isinstance(obstacle, (Plane, Sphere, Cylinder)):
            raise InputError(f"contact {name}: obstacle must be a Plane, Sphere or Cylinder (got {obstacle!r})")
        if not (np.isfinite(stiffness) and stiffness > 0):
            raise InputError(f"contact {name}: stiffness must be a positive number (got {stiffness!r})")
        if not (np.isfinite(radius) and radius >= 0):
            raise InputError(f"contact {name}: radius must be a length >= 0 (got {radius!r})")
        if friction is not None and not isinstance(friction, Coulomb):
            raise InputError(f"contact {name}: friction must be a Coulomb or None (got {friction!r})")
        self.obstacle, self.k, self.r, self.friction, self.name = obstacle, float(stiffness), float(radius), friction, name

    # -- binding -------------------------------------------------------------------------------
    def bind(self, body):
        model, space, mesh = body.model, body.space, body.mesh
        self.position = model.position
        self.velocity = model.kinematics[self.position]
        field = space.field(self.position)
        self.dim = field.shape[0] if field.shape else 1
        if self.dim != self.obstacle.dim:
            raise InputError(f"contact {self.name}: the body is {self.dim}D, the obstacle ({self.obstacle.describe()}) "
                             f"{self.obstacle.dim}D")
        self.section = section_kind(space.names, self.dim)
        if field.family == "P":   # Gauss-Lobatto: the points are the nodes of P1 and P2
            self.dc = ufl.Measure("dx", domain=mesh, metadata={"quadrature_rule": "GLL",
                                                               "quadrature_degree": max(2 * field.degree - 1, 1)})
        else:
            self.dc = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": max(2 * field.degree, 1)})
        self.c = {"k": fem.Constant(mesh, self.k), "r": fem.Constant(mesh, self.r), **self.obstacle.constants(mesh)}
        if self.friction is not None:
            self.c.update(self.friction.constants(mesh))
        # the Taylor term below 1e-3 of a penetration of 1e-3 of the scale: round-off of the quotient
        # ~ eps |Psi| / threshold stays far below the force
        self.threshold = 1e-6 * self.obstacle.scale
        self.body = body

    # -- UFL pieces ----------------------------------------------------------------------------
    def _xi(self, x):
        return self.obstacle.measure(x, self.c["n"], self.c["p"])

    def _grad(self, x):
        return self.obstacle.gradient(x, self.c["n"], self.c["p"])

    def _Psi(self, xi):
        """The energy density Psi(xi) = psi(d(xi) - r)."""
        return cubic_penalty(self.c["k"])(self.obstacle.distance(xi) - self.c["r"])

    def gap(self, x):
        """g = d(xi(x)) - r (UFL)."""
        return self.obstacle.distance(self._xi(x)) - self.c["r"]

    def surface_velocity(self, x, w, n):
        """The velocity of the contact point x - r n from the velocities w (dict: midpoint values or
        test functions) and the configuration x (dict) -- linear in w."""
        v = w[self.velocity]
        r = self.c["r"]
        if self.section == "directors":   # the section point -r (n.d2) d2 - r (n.d3) d3
            return section_point_velocity(v, [-r * ufl.inner(n, x[d]) for d in DIRECTORS[1:]], [w[wi] for wi in RATES[1:]])
        if self.section == "planar":
            return v - r * w["omega"] * ufl.as_vector([-n[1], n[0]])
        return v

    def _friction(self, x, w, z, grad):
        """(f_t, v_c): the friction force (per length) and the contact point's velocity."""
        norm = ufl.sqrt(ufl.inner(grad, grad))
        n = grad / norm
        N = -z * norm
        N = ufl.conditional(ufl.gt(N, 0.0), N, 0.0)
        vc = self.surface_velocity(x, w, n)
        vt = vc - ufl.inner(n, vc) * n
        return self.friction.force(N, vt, self.c), vt, n

    # -- the interaction's contract (rodfem/core/body.py) ----------------------------------------
    def energy(self, x, dx, ds):
        """int psi(g(r)) ds."""
        return self._Psi(self._xi(x[self.position])) * self.dc

    def _step_terms(self, step):
        pos = self.position
        xm = step.mid(pos)
        z = step.scalar_effort(self._Psi, self._xi(step.x0[pos]), self._xi(step.x1[pos]), self._xi(xm),
                               self.threshold)
        return z, self._grad(xm)

    def residual(self, step, test, dx, ds):
        """int z grad xi(x_m) . delta v ds  - int f_t . delta v_c ds (friction)."""
        z, grad = self._step_terms(step)
        F = z * ufl.inner(grad, test[self.velocity]) * self.dc
        if self.friction is not None:
            mid = {n: step.mid(n) for n in step.x0}
            ft, _, n = self._friction(mid, mid, z, grad)
            F -= ufl.inner(ft, self.surface_velocity(mid, test, n)) * self.dc
        return F

    def dissipation(self, step, dx, ds):
        """h int -f_t . v_t,m ds = h int mu N |v_t|^2 / sqrt(|v_t|^2 + eps^2) ds >= 0 (None without friction)."""
        if self.friction is None:
            return None
        z, grad = self._step_terms(step)
        mid = {n: step.mid(n) for n in step.x0}
        ft, vt, _ = self._friction(mid, mid, z, grad)
        return -step.h * ufl.inner(ft, vt) * self.dc

    def observables(self, x, dx, ds):
        """name.energy, name.N (the total normal force int N ds), its vector name.Fn_x, ... and the
        friction force name.Ft_x, ... of the state (psi'(xi) and the velocities at t_{n+1})."""
        pos = x[self.position]
        X = ufl.variable(self._xi(pos))
        z = ufl.diff(self._Psi(X), X)
        grad = self._grad(pos)
        axes = "xyz"[: self.dim]
        out = {f"{self.name}.energy": self.energy(x, dx, ds),
               f"{self.name}.N": -z * ufl.sqrt(ufl.inner(grad, grad)) * self.dc}
        for i, c in enumerate(axes):
            out[f"{self.name}.Fn_{c}"] = -z * grad[i] * self.dc
        if self.friction is not None:
            ft, _, _ = self._friction(x, x, z, grad)
            for i, c in enumerate(axes):
                out[f"{self.name}.Ft_{c}"] = ft[i] * self.dc
        return out

    def monitor(self, body):
        """name.penetration: the largest <-g> at the nodes of the state x_{n+1} (collective)."""
        _, values = body.space.nodal(body.x1, self.position)
        g = np.array([self.gap_of(x) for x in values]) if len(values) else np.zeros(0)
        worst = float(np.max(-g, initial=0.0))
        return {f"{self.name}.penetration": body.comm.allreduce(worst, op=MPI.MAX)}

    def gap_of(self, x):
        """g at the point x (numbers)."""
        return float(self.obstacle.distance(self.obstacle.measure(np.asarray(x, dtype=float)))) - self.r


# -- point contact of point masses and rigid bodies (components) ---------------------------------

def _ground_measure(obstacle):
    def measure(a, b, a0, b0):
        return [obstacle.measure(b.x)]
    return measure


def _separation(a, b, a0, b0):
    return b.x - a.x


def obstacle_contact(obstacle, stiffness, radius=0.0):
    """Normal contact of a point (a point mass, a rigid body's corner) with the obstacle, a component:
    `System.connect(obstacle_contact(...), GROUND, body.point(offset))` (the ground point at the origin).
    Its energy psi(d(xi) - r) of the obstacle's quadratic measure xi (the point's gap to the surface,
    minus the radius r of a ball around the point); columns name.V, name.N (normal force), name.gap."""
    if not (np.isfinite(stiffness) and stiffness > 0):
        raise InputError(f"contact: stiffness must be a positive number (got {stiffness!r})")
    if not (np.isfinite(radius) and radius >= 0):
        raise InputError(f"contact: radius must be a length >= 0 (got {radius!r})")
    psi = cubic_penalty(float(stiffness))

    def energy(xi):
        return psi(obstacle.distance(xi) - radius)

    def columns(xi, z):
        # N = -dpsi/dg = -z / (dd/dxi): d = xi (plane) or sqrt(xi + R^2) - R (dd/dxi = 1 / (2 (d + R)))
        slope = 1.0 if isinstance(obstacle, Plane) else 0.5 / np.sqrt(xi + obstacle.R ** 2)
        return {"N": -z / slope, "gap": obstacle.distance(xi) - radius}
    return potential(_ground_measure(obstacle), energy, "contact", columns=columns)


def obstacle_friction(obstacle, stiffness, friction: Coulomb, radius=0.0):
    """Regularized Coulomb friction of a point on the obstacle, a component (a `Dissipator` of
    rodfem/core/components.py on the point's position relative to the ground point at the origin):
    f = -f_t, with N = -psi'(g) of the penalty of the same stiffness at the step's midpoint and the
    slip v_t = v - (n . v) n.  Columns name.Ft_x, ... (the friction force on the point)."""
    if not isinstance(friction, Coulomb):
        raise InputError(f"contact: friction must be a Coulomb (got {friction!r})")
    k = float(stiffness)

    def law(x, v):
        x, v = np.asarray(x, dtype=float), np.asarray(v, dtype=float)
        grad = np.asarray(obstacle.gradient(x), dtype=float)
        norm = np.linalg.norm(grad)
        n = grad / norm
        g = obstacle.distance(obstacle.measure(x)) - radius
        N = k * max(-g, 0.0) ** 2
        vt = v - (n @ v) * n
        return -friction.force(N, vt)   # the resistance's generalized force (its rate . f >= 0)

    def columns(x, v, f):
        return {f"Ft_{c}": -fi for c, fi in zip("xyz", f)}
    return dissipator(_separation, law, "friction", columns=columns)
