"""Link, twist and writhe of a rod's centreline and director frame (Calugareanu-White-Fuller).

A ribbon is a curve x(s) with a unit vector u(s) normal to its tangent t.  For a closed ribbon the
linking number of x with x + eps u is an integer, and (Calugareanu, White, "Self-linking and the
Gauss integral in higher dimensions", Amer J Math 91 (1969) 693-728, DOI 10.2307/2373348)

    Lk = Tw + Wr,     Tw = 1/(2 pi) int (t x u) . u' ds,
                      Wr = 1/(4 pi) oint oint (t(s) x t(s')) . (x(s) - x(s')) / |x(s) - x(s')|^3 ds ds'.

Discretely the curve is the polygon through given nodes, and both terms are taken exactly for it:

* `writhe(points)`: the Gauss double integral over a closed polygon, segment pair by segment pair,
  in closed form: the pair (i, j) contributes the signed solid angle Omega_ij / (4 pi) of the
  quadrangle its four end points span (Klenin & Langowski, "Computation of writhe in modeling of
  supercoiled DNA", Biopolymers 54 (2000) 307-317, DOI 10.1002/1097-0282(20001015)54:5<307::AID-BIP20>3.0.CO;2-Y,
  method 1a); Wr = sum over i != j.  A planar polygon has Wr = 0; so has a pair whose four points are
  coplanar to round-off (|volume| <= 1e-12 of its scale: e.g. collinear segments, whose normals are noise).
* `twist(points, u)`: the ribbon vectors u_i on the edges (made normal to each edge), carried from edge
  to edge by the discrete parallel transport (the smallest rotation taking t_i to t_{i+1}); Tw is the
  sum of the angles between the carried u_i and u_{i+1} about t_{i+1}, over 2 pi (each in (-pi, pi]:
  the edges must be short enough that the ribbon turns by less than pi between neighbours).
* `fuller(tangents, ds)`: Fuller's formula for the writhe of a curve relative to a straight one along
  the axis e (Fuller, "Decomposition of the linking number of a closed ribbon: a problem from molecular
  biology", PNAS 75 (1978) 3557-3561, DOI 10.1073/pnas.75.8.3557):

      Wr = 1/(2 pi) int (e x t) . t' / (1 + e . t) ds,

  valid as long as the curve can be deformed to the straight one without passing through itself and
  with t never equal to -e (a rod folded back, e.g. a plectoneme, breaks it: then only the Gauss
  integral holds).

An OPEN rod whose two ends lie on one straight axis, with their tangents along it (a rod clamped at
one end and twisted at the other about the axis through both), is closed by `closure`: the axis is
extended beyond both ends by `far` and the curve returns along a line at the distance `far` from the
axis.  As far grows the return's contribution vanishes (as length / far) and Wr tends to the writhe
of the rod with its ends extended to infinity along the axis.  Its ribbon on the extensions is the
end directors' (no twist there), so Tw + Wr changes continuously with the rod's motion and jumps by
+-2 only when the rod passes through itself (or through the axis beyond its ends): from a straight,
untwisted start, Lk = Tw + Wr equals the number of turns the ends have been turned relative to each
other.
"""
import numpy as np


def _unit(a):
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


def _safe_unit(a):
    n = np.linalg.norm(a, axis=-1, keepdims=True)
    return np.where(n > 0, a / np.where(n > 0, n, 1.0), 0.0)


def writhe(points):
    """The writhe of the CLOSED polygon through `points` (n, 3) (the last joined to the first):
    sum over segment pairs i != j of Omega_ij / (4 pi) (Klenin & Langowski 2000, method 1a)."""
    x = np.asarray(points, dtype=float)
    if x.ndim != 2 or x.shape[1] != 3 or len(x) < 3:
        raise ValueError(f"writhe: points must be an array (n >= 3, 3) (got shape {x.shape})")
    a, b = x, np.roll(x, -1, axis=0)                 # segment i: a_i -> b_i
    n = len(x)
    i, j = np.triu_indices(n, k=2)
    keep = ~((i == 0) & (j == n - 1))                # the last segment is the first one's neighbour
    i, j = i[keep], j[keep]
    r1, r2, r3, r4 = a[i], b[i], a[j], b[j]
    r13, r14, r23, r24 = r3 - r1, r4 - r1, r3 - r2, r4 - r2
    n1 = _safe_unit(np.cross(r13, r14))
    n2 = _safe_unit(np.cross(r14, r24))
    n3 = _safe_unit(np.cross(r24, r23))
    n4 = _safe_unit(np.cross(r23, r13))

    def asin(p, q):
        return np.arcsin(np.clip(np.einsum("ij,ij->i", p, q), -1.0, 1.0))
    omega = asin(n1, n2) + asin(n2, n3) + asin(n3, n4) + asin(n4, n1)
    volume = np.einsum("ij,ij->i", np.cross(r4 - r3, r2 - r1), r13)
    size = np.linalg.norm(r4 - r3, axis=1) * np.linalg.norm(r2 - r1, axis=1) * np.linalg.norm(r13, axis=1)
    sign = np.where(np.abs(volume) > 1e-12 * size, np.sign(volume), 0.0)   # coplanar pairs (round-off): 0
    return float(2.0 * np.sum(omega * sign) / (4.0 * np.pi))


def _transport(u, t0, t1):
    """u carried by the smallest rotation taking the unit vector t0 to t1 (rows)."""
    c = np.einsum("ij,ij->i", t0, t1)[:, None]
    k = np.cross(t0, t1)
    return u * c + np.cross(k, u) + k * np.einsum("ij,ij->i", k, u)[:, None] / (1.0 + c)


def twist(points, ribbon):
    """Tw of the open polygon through `points` (n, 3) with the ribbon vectors `ribbon` (n - 1, 3) on its
    edges (made normal to each edge): sum of the angles between u_i carried to edge i + 1 and u_{i+1},
    about t_{i+1}, over 2 pi."""
    x, u = np.asarray(points, dtype=float), np.asarray(ribbon, dtype=float)
    if len(u) != len(x) - 1:
        raise ValueError(f"twist: one ribbon vector per edge: {len(x) - 1} (got {len(u)})")
    t = _unit(np.diff(x, axis=0))
    u = _unit(u - t * np.einsum("ij,ij->i", u, t)[:, None])
    carried = _transport(u[:-1], t[:-1], t[1:])
    angle = np.arctan2(np.einsum("ij,ij->i", np.cross(carried, u[1:]), t[1:]), np.einsum("ij,ij->i", carried, u[1:]))
    return float(np.sum(angle) / (2.0 * np.pi))


def fuller(tangents, ds, axis=(1.0, 0.0, 0.0)):
    """Fuller's writhe relative to the straight curve along `axis` of the curve with unit tangents
    `tangents` (n, 3) at equal arc-length steps ds (the midpoint rule on the tangent's increments:
    1/(2 pi) sum (e x t_m) . (t_{k+1} - t_k) / (1 + e . t_m), t_m the normalized mean)."""
    t = _unit(np.asarray(tangents, dtype=float))
    e = _unit(np.asarray(axis, dtype=float))
    tm = _unit(0.5 * (t[1:] + t[:-1]))
    return float(np.sum(np.einsum("ij,ij->i", np.cross(e, tm), np.diff(t, axis=0)) / (1.0 + tm @ e)) / (2 * np.pi))


def closure(points, axis=(1.0, 0.0, 0.0), far=1e3):
    """The closed polygon of an open curve whose ends lie on one axis: the points extended from the
    first and the last along -axis and +axis by `far` times the curve's size, then returned along a line
    parallel to the axis at that distance (a rectangle in a plane through the axis).  Returns the
    polygon's vertices (the curve's first, then the rest, then the four closure corners)."""
    x = np.asarray(points, dtype=float)
    e = _unit(np.asarray(axis, dtype=float))
    size = max(float(np.max(np.linalg.norm(x - x[0], axis=1))), 1e-300)
    side = np.cross(e, np.eye(3)[int(np.argmin(np.abs(e)))])
    side = _unit(side) * far * size
    start, end = x[0] - far * size * e, x[-1] + far * size * e
    return np.vstack([x, end, end + side, start + side, start])


def link(points, directors, axis=(1.0, 0.0, 0.0), far=1e3):
    """(Tw, Wr, Lk) of an open rod whose ends lie on the axis: `points` (n, 3) the centreline's nodes,
    `directors` (n, 3) a director normal to the axis at the ends (the ribbon; on each edge the mean of
    its two nodes').  Tw over the rod and its two extensions along the axis (the ribbon there: the end
    directors), Wr of the `closure`, Lk = Tw + Wr (see the module docstring)."""
    x, d = np.asarray(points, dtype=float), np.asarray(directors, dtype=float)
    e = _unit(np.asarray(axis, dtype=float))
    size = max(float(np.max(np.linalg.norm(x - x[0], axis=1))), 1e-300)
    ext = np.vstack([x[0] - size * e, x, x[-1] + size * e])
    ribbon = np.vstack([d[0], 0.5 * (d[1:] + d[:-1]), d[-1]])
    Tw = twist(ext, ribbon)
    Wr = writhe(closure(x, e, far))
    return Tw, Wr, Tw + Wr
