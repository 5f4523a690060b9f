"""Contact between rods (and strings): two bodies' centrelines, or one rod with itself, by a penalty
energy of the gap between their tubes.

Discretization: segment-to-segment closest points (the point-to-point beam contact of Wriggers &
Zavarise, "On contact between three-dimensional beams undergoing large deflections", Commun Numer
Methods Eng 13 (1997) 429-438, DOI 10.1002/(SICI)1099-0887(199706)13:6<429::AID-CNM70>3.0.CO;2-X).
The centreline is the polyline through the nodes of the position field (the vertices and, for P2,
the mid-nodes: two segments per element).  For a segment x(a) = (1 - a) x_i + a x_{i+1} of one body
and y(b) = (1 - b) y_j + b y_{j+1} of the other

    d_ij = min over a, b in [0, 1] of |x(a) - y(b)|,        g_ij = d_ij - (r_A + r_B),

the distance of the two segments (clamped closest points: a segment's end counts) less the two
tubes' radii, and the contact's stored energy is the sum over the segment pairs of the cubic penalty
of forms/contact.py:

    V = sum_ij w_ij psi(g_ij),      psi(g) = k/3 <-g>^3      (force k <-g>^2 per contact point),

with the weights w_ij = min(1, l_i / zone) min(1, l_j / zone) of the segments' lengths l at rest and
the contact zone `zone` (below; w = 1 without one).

By the envelope theorem its gradient is the normal force -psi'(g) n (n = (x_c - y_c) / d, x_c, y_c
the closest points) shared by the segments' nodes as (1 - a, a) and (1 - b, b): the forces on the
two bodies are equal and opposite and have no moment about any point (x_c - y_c is along n), so V
conserves the pair's linear and angular momentum.

What the discretization is and is not:
* A crossing of two rods (the angle between them not small) is resolved at any mesh: the closest
  points of the two segments that cross are found wherever along them the crossing lies.
* A crossing close to a node is also seen by the neighbouring segment pair (both closest points at
  the shared node): V then counts it twice (a crossing at a node of both rods: four times), so the
  stiffness of a point contact is between k and 4 k, and the force a given penetration makes varies
  by that factor along the rod.  V is still one continuous, piecewise smooth energy of the nodes:
  the balance and the momenta hold exactly, and a static contact force equals the load it carries.
* Segments shorter than the contact zone: two crossing tubes penetrating by d overlap where their
  centrelines are closer than R, over a zone of radius sqrt(2 R d) about the crossing, and every
  segment pair in it is in contact -- about (sqrt(2 R d) / l)^2 pairs: without weights a fine mesh
  makes the contact that many times stiffer.  With zone = sqrt(2 R d) at the penetration d the
  stiffness is meant for, the weights make V a Riemann sum of the double integral
  int int psi ds dt / zone^2 on a fine mesh (mesh-independent: for two lines crossing at the angle
  theta, 2 pi k (R p^4/4 - p^5/5) / (3 zone^2 sin theta) at the penetration p, pi/4 (1 - 4 p/5R) of one
  point contact at p = d) and the point contact on a coarse one (l >= zone; in between, up to about 4
  point contacts); a line contact has the stiffness k / max(l, zone) per length.  The weights are
  constants of the pair: the balance and momenta are unchanged.
* Nearly parallel segments (line contact, a rod folded onto itself) are a sum of point contacts,
  about one per segment pair; their closest points are not unique when exactly parallel (V has a
  kink there: the force moves from one end of the segment to the other).
* Self-contact: the segment pairs of one rod closer along the rod than the exclusion length
  (by default pi r: a rod bent back on itself with the tightest radius its section allows, r,
  touches itself at arc distance pi r) are left out, the neighbours always.

A rigid body's sphere (`System.contact(law, rod, ball)`, either order): the sphere of radius R_s (the
law's radius on the rigid body's side) about the body's position x is the segment of zero length
[x, x], so that for each segment of the rod

    d_j = min over b in [0, 1] of |x - y(b)|,        g_j = d_j - (R_s + r_rod),

the distance of the centre to the segment (`closest_points` takes the point's own branch: the clamped
projection), and the same energy V = sum_j w_j psi(g_j) (the point's weight 1).  The force -psi'(g) n
acts at the centre (on x) and at the rod's closest point: it has no moment about x, so it does not turn
the rigid body (its rotation plays no part in the gap).  With friction the sphere is a side without a
section, as a string (below): the friction acts at its centre, and the couple of its arm is not applied
to the rigid body's rotation (it shows in name.Mf).

Friction (`friction=Coulomb(mu_s, mu_k, eps, v_s)`, forms/contact.py's regularized Coulomb law, the same
object as an obstacle's) acts at the CONTACT POINT of the two tubes.  With the closest points x_c, y_c
(parameters a, b), their distance d and the normal n (from y_c to x_c) of the midpoint state X_m, the
contact point c = x_c - rho_a n = y_c + rho_b n divides x_c - y_c in the ratio of the radii,

    rho_a = r_A d / R,   rho_b = r_B d / R        (`arms`; the tubes' surfaces when d = R),

so it is one point of both bodies at any penetration.  On a body with a director section (a 3D rod) c is
the material point x_c + u of the section, u = -rho_a n (body b: +rho_b n), with the coordinates beta
(sum_k beta_k d_k(a) = u, `section_coordinates`) in the section frame d_k(a) interpolated at the
closest point from the nodes' midpoint directors.  The point's velocity is forms/contact.py's
`section_point_velocity`, the obstacle friction's: v(a) + sum_k beta_k w_k(a) (v + omega x u for a
rigid section motion).  A body without a section (a string) has u = 0: its point is x_c.  The slip is
the tangential part of the relative velocity of the two bodies' points at the step's midpoint,

    v_t = (I - n n^T) [v_c,a - v_c,b],    v_c = sum_nodes s_i (v_i + sum_k beta_k w_k,i),  s = (1 - a, a) resp. (1 - b, b),

and the friction force on body a's point is f = -mu(|v_t|) N v_t / sqrt(|v_t|^2 + eps^2), with the
pair's normal force of the step N = -w z >= 0 (z the penalty's difference quotient, w the pair's
weight); -f acts on body b's.  Tested with the virtual velocity of the point, f goes to the segment's
position rows as s_i f and to its director rows as s_i beta_k f: the force f at x_c and the couple
u x f on the section.  So

* linear momentum: the forces sum to zero;
* angular momentum: the discrete moment of a node's loads is x_m x F + sum_k d_k,m x G_k (the
  rows tested with the rotation theta x x_m, theta x d_k,m), which for a pair is
  (x_c + u_a) x f - (y_c + u_b) x f = (c - c) x f = 0: exact (that is why beta solves the frame,
  which is not orthonormal at the midpoint and between nodes, instead of taking D^T u).  Against a
  string only the rod's couple acts: the pair's moment is then rho_s n x f (name.Mf; rho_s the
  string's share of d, f the force on body a);
* energy: the work of the step, tested with the midpoint velocities, is h f . v_t <= 0, booked in
  `dissipated` (H_{n+1} - H_n + dissipated = supplied stays exact);
* a rod sliding across another picks up spin until the points roll on each other (v_t -> 0).

It is not a regularization of the set-valued law that sticks exactly: see forms/contact.py for the
creep at eps and the time step the stiff damper wants.

Energy consistency: the integrator (rodfem/core/bodycontact.py) takes the penalty's difference
quotient in the distance, z = [psi(g_{n+1}) - psi(g_n)] / (d_{n+1} - d_n) (`quotient`, exact in
closed form for the cubic), times a discrete gradient of the distance that keeps the momenta; see
there.  Strings use the same code (their radius: the tube about the centreline).
"""
import numpy as np

from rodfem.errors import InputError
from rodfem.forms.contact import DIRECTORS, RATES, Coulomb, section_kind, section_point_velocity


def closest_points(p0, p1, q0, q1):
    """The closest points of the segments [p0, p1] and [q0, q1] (arrays (n, 3) of n segment pairs):
    (d, a, b, n) with d the distance, a, b in [0, 1] the closest points' parameters along each segment,
    n the unit vector from y(b) to x(a).  The exact clamped minimization (Ericson, Real-Time Collision
    Detection, Morgan Kaufmann 2005, Sec. 5.1.9); parallel segments: a = 0 (one of the closest pairs); a
    segment of zero length (|q1 - q0|^2 <= 1e-28 of the pair's squared size: a point, b = 0) has the
    closest point of the other segment to it (Ericson's degenerate cases), and so has a point against a
    point (a = b = 0)."""
    u, v, w = p1 - p0, q1 - q0, p0 - q0
    A, E = np.einsum("ij,ij->i", u, u), np.einsum("ij,ij->i", v, v)
    B, C, F = np.einsum("ij,ij->i", u, v), np.einsum("ij,ij->i", u, w), np.einsum("ij,ij->i", v, w)
    tiny = 1e-28 * (A + E + np.einsum("ij,ij->i", w, w))
    point_p, point_q = A <= tiny, E <= tiny          # a segment of zero length: a point (a sphere's centre)
    A1, E1 = np.where(point_p, 1.0, A), np.where(point_q, 1.0, E)
    denom = A * E - B * B
    parallel = (denom <= 1e-14 * A * E) | point_p | point_q
    a = np.where(parallel, 0.0, np.clip((B * F - C * E) / np.where(parallel, 1.0, denom), 0.0, 1.0))
    b = (B * a + F) / E1
    low, high = b < 0.0, b > 1.0
    a = np.where(low, np.clip(-C / A1, 0.0, 1.0), np.where(high, np.clip((B - C) / A1, 0.0, 1.0), a))
    b = np.clip(b, 0.0, 1.0)
    # point to segment (Ericson's degenerate cases): the projection of the point, clamped
    a = np.where(point_q, np.where(point_p, 0.0, np.clip(-C / A1, 0.0, 1.0)), a)
    b = np.where(point_q, 0.0, np.where(point_p, np.clip(F / E1, 0.0, 1.0), b))
    diff = (p0 + a[:, None] * u) - (q0 + b[:, None] * v)
    d = np.sqrt(np.einsum("ij,ij->i", diff, diff))
    n = diff / np.maximum(d, 1e-300)[:, None]
    return d, a, b, n


def section_coordinates(D, u):
    """beta (m, 3) with sum_k beta_k d_k = u: the coordinates of the arms u (m, 3) in the frames D (m, 3, 3)
    [pair, k, component] (solved: D is not orthonormal between nodes and at a step's midpoint, and the
    exact moment sum_k beta_k d_k x f = u x f keeps the angular momentum)."""
    return np.linalg.solve(np.transpose(D, (0, 2, 1)), u[:, :, None])[:, :, 0]


class RodContact:
    """Contact of two rods (or strings), or self-contact of one (`System.contact(law, a, b)`; b None:
    self-contact of a).

    stiffness: k of psi(g) = k/3 <-g>^3 per contact point (> 0; forms/contact.py's `stiffness_for(load,
    penetration)` gives the k at which a point force `load` penetrates `penetration`);
    radius: the tube radius r_A >= 0 of body a, radius_b that of body b (default r_A);
    exclude: self-contact only, the arc length along the rod within which segment pairs are left out
    (default pi r_A; >= 0);
    zone: the contact zone's size sqrt(2 R d) at the design penetration d (>= 0; 0: every segment pair
    weighs 1, see the module docstring);
    friction: None (frictionless) or a Coulomb of forms/contact.py (regularized Coulomb friction at the
    tubes' contact point, see the module docstring);
    name: the history columns' prefix.
    """

    def __init__(self, stiffness, radius, radius_b=None, exclude=None, zone=0.0, friction=None, name="rod_contact"):
        if not (np.isfinite(stiffness) and stiffness > 0):
            raise InputError(f"rod contact {name}: stiffness must be a positive number (got {stiffness!r})")
        radius_b = radius if radius_b is None else radius_b
        for what, r in (("radius", radius), ("radius_b", radius_b)):
            if not (np.isfinite(r) and r >= 0):
                raise InputError(f"rod contact {name}: {what} must be a length >= 0 (got {r!r})")
        exclude = np.pi * radius if exclude is None else exclude
        if not (np.isfinite(exclude) and exclude >= 0):
            raise InputError(f"rod contact {name}: exclude must be an arc length >= 0 (got {exclude!r})")
        if not (np.isfinite(zone) and zone >= 0):
            raise InputError(f"rod contact {name}: zone must be a length >= 0 (got {zone!r})")
        self.k, self.radii, self.exclude, self.name = float(stiffness), (float(radius), float(radius_b)), float(exclude), name
        self.zone = float(zone)
        if friction is not None and not isinstance(friction, Coulomb):
            raise InputError(f"rod contact {name}: friction must be a Coulomb (forms/contact.py) or None (got {friction!r})")
        self.friction = friction

    closest_points = staticmethod(closest_points)
    section_coordinates = staticmethod(section_coordinates)   # the contact point in a section's frame
    point_velocity = staticmethod(section_point_velocity)     # its velocity (forms/contact.py, as an obstacle's)

    @staticmethod
    def frame(names):
        """The (directors, rates) fields of a body with the fields `names` whose friction acts at its
        section's surface (a director section: a 3D rod), or None (a string: at its centreline)."""
        return (DIRECTORS, RATES) if section_kind(names) == "directors" else None

    def arms(self, d, self_contact):
        """(rho_a, rho_b) = (r_A, r_B) d / R: the closest points' distances to the contact point along n."""
        ra, rb = (self.radii[0],) * 2 if self_contact else self.radii
        R = ra + rb
        if R <= 0.0:
            return np.zeros_like(d), np.zeros_like(d)
        return ra * d / R, rb * d / R

    def reach(self, self_contact):
        """R = r_A + r_B: the centrelines' distance at which the tubes touch."""
        return 2 * self.radii[0] if self_contact else sum(self.radii)

    def energy(self, d, R):
        """psi(d - R) = k/3 <R - d>^3 (arrays)."""
        return self.k / 3.0 * np.maximum(R - d, 0.0) ** 3

    def slope(self, d, R):
        """d psi / d d = -k <R - d>^2 (the normal force is its negative)."""
        return -self.k * np.maximum(R - d, 0.0) ** 2

    def quotient(self, d0, d1, R):
        """z = [psi(d1 - R) - psi(d0 - R)] / (d1 - d0), in closed form (no cancellation): with the
        penetrations p = <R - d>, -k/3 (p0^2 + p0 p1 + p1^2) when both are in contact, the one-sided
        cubic over the interval where it starts or ends, and the slope psi'(d0) where d1 = d0."""
        p0, p1 = np.maximum(R - d0, 0.0), np.maximum(R - d1, 0.0)
        both = (p0 > 0) & (p1 > 0)
        dd = d1 - d0
        safe = np.where(dd == 0.0, 1.0, dd)
        mixed = self.k / 3.0 * (p1**3 - p0**3) / safe
        z = np.where(both, -self.k / 3.0 * (p0 * p0 + p0 * p1 + p1 * p1), mixed)
        return np.where(dd == 0.0, self.slope(d0, R), z)
