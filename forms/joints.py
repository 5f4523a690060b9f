"""Joints (kinematic pairs) as position-level constraints g(a, b) = 0 between two points.

Each joint is a function g(a, b, a0, b0) of the two points' frames now (a, b)
and at t = 0 (a0, b0): `a.x` the position, `a.d` the directors (3D bodies),
`a.phi` the angle (planar bodies).  rodfem (rodfem/core/joints.py)
makes it an index-2 constraint G(q_m) v_m = 0 with multipliers lambda, the
reaction forces G^T lambda, exact for the quadratic g written here: for
director-based bodies every pair below is quadratic in the coordinates, so
g = 0 holds to round-off for all time.  Orientation conditions are written
relative to the initial configuration (the constant relative rotation
C = R_a(0)^T R_b(0)), so a joint holds whatever the bodies' initial frames.

A new joint is a new function here; the engine needs nothing else.
"""
import numpy as np


def _carried(a, C):
    """The directors of a's frame rotated by the constant relative rotation C: R_a C (columns)."""
    return [sum(C[i, j] * a.d[i] for i in range(3)) for j in range(3)]


def _relative_rotation(a0, b0):
    return a0.R.T @ b0.R


def _others(axis):
    return (axis + 1) % 3, (axis + 2) % 3


# -- 3D pairs (director-based bodies, rod ends) --------------------------------------------

def spherical(a, b, a0, b0):
    """Spherical (ball) joint: the points coincide, x_a = x_b (3 conditions)."""
    return a.x - b.x


def locked_rotation(a, b, a0, b0):
    """b's frame keeps its initial orientation relative to a's: b.d_j . (R_a C)_k = 0, j < k (3 conditions)."""
    t = _carried(a, _relative_rotation(a0, b0))
    return [b.d[0] @ t[1], b.d[0] @ t[2], b.d[1] @ t[2]]


def rigid(a, b, a0, b0):
    """Rigid connection (welded): spherical + locked rotation (6 conditions)."""
    return [*spherical(a, b, a0, b0), *locked_rotation(a, b, a0, b0)]


def revolute(axis=0):
    """Revolute (hinge) pair about a's director d_axis: the points coincide and a's d_axis stays
    along the axis b carries, a.d_axis . (R_b C^T)_j = 0 for the two other j (5 conditions).  The
    hinge is fixed in both bodies (in b: where a's d_axis was at t = 0), like the cylindrical
    pair's axis; b's own d_axis need not start along it."""
    j, k = _others(axis)

    def revolute(a, b, a0, b0):
        s = _carried(b, _relative_rotation(a0, b0).T)     # R_b C^T: a's frame as b carries it
        return [*spherical(a, b, a0, b0), a.d[axis] @ s[j], a.d[axis] @ s[k]]
    return revolute


def prismatic(axis=0):
    """Prismatic (slider) pair along a's director d_axis: rotation locked, and b's point moves on the
    line through a's point along d_axis: (x_b - x_a) . d_j fixed for the two other j (5 conditions)."""
    j, k = _others(axis)

    def prismatic(a, b, a0, b0):
        r0 = b0.x - a0.x
        return [*locked_rotation(a, b, a0, b0),
                (b.x - a.x) @ a.d[j] - r0 @ a0.d[j], (b.x - a.x) @ a.d[k] - r0 @ a0.d[k]]
    return prismatic


def cylindrical(axis=0):
    """Cylindrical pair along a's director d_axis: b may turn about and slide along it (4 conditions):
    a.d_axis stays along the axis b carries, a.d_axis . (R_b C^T)_j = 0, and (x_b - x_a) . a.d_j is
    fixed, for the two other j.  (Turning about b's d_axis instead would be another axis than the
    slide's when b's d_axis does not start along a's.)"""
    j, k = _others(axis)

    def cylindrical(a, b, a0, b0):
        s = _carried(b, _relative_rotation(a0, b0).T)     # R_b C^T: a's frame as b carries it
        r0 = b0.x - a0.x
        return [a.d[axis] @ s[j], a.d[axis] @ s[k],
                (b.x - a.x) @ a.d[j] - r0 @ a0.d[j], (b.x - a.x) @ a.d[k] - r0 @ a0.d[k]]
    return cylindrical


def _axis(frame, axis):
    """A body-fixed direction of `frame`: a director index 0, 1, 2 or components (n_1, n_2, n_3) in its
    directors, n_i d_i (linear in the directors, so a product of two axes is quadratic)."""
    if np.ndim(axis) == 0:
        return frame.d[int(axis)]
    n = np.asarray(axis, dtype=float)
    return sum(n[i] * frame.d[i] for i in range(3))


def universal(axis_a=0, axis_b=0):
    """Universal (Hooke, cardan) joint: the points coincide and a's joint axis stays perpendicular
    to b's, a.n_a . b.n_b = 0 (4 conditions).  Each axis is fixed in its body: a director index
    or components in the body's directors (a ground frame: in its R); they must be perpendicular
    at t = 0.  b may turn about n_a and n_b, not about n_a x n_b."""
    def universal(a, b, a0, b0):
        return [*spherical(a, b, a0, b0), _axis(a, axis_a) @ _axis(b, axis_b)]
    return universal


def position(a, b, a0, b0):
    """b's point keeps its initial position relative to a's point in space (3 conditions; with a
    `drive` it follows a prescribed path: x_b - x_a - (x_b - x_a)(0) = g_p(t))."""
    return (b.x - a.x) - (b0.x - a0.x)


def distance(a, b, a0, b0):
    """A massless rigid link: |x_b - x_a|^2 keeps its initial value (1 condition; planar or 3D)."""
    return [(b.x - a.x) @ (b.x - a.x) - (b0.x - a0.x) @ (b0.x - a0.x)]


# -- planar pairs (planar beams, planar rigid bodies) ---------------------------------------

def pin(a, b, a0, b0):
    """Planar pin (revolute) joint: the points coincide, x_a = x_b; the angles are independent (2 conditions)."""
    return a.x - b.x


def planar_rigid(a, b, a0, b0):
    """Planar rigid connection: the points coincide and the angles keep their difference (3 conditions)."""
    return [*(a.x - b.x), (b.phi - a.phi) - (b0.phi - a0.phi)]


def angle(a, b, a0, b0):
    """The relative angle phi_b - phi_a (1 condition: with a `drive`, a prescribed rotation)."""
    return [(b.phi - a.phi) - (b0.phi - a0.phi)]


def slider(direction):
    """b's point moves along the line through a's point with the fixed (spatial) `direction`:
    its offset across the line is held (planar or 3D; d - 1 conditions)."""
    n = np.asarray(direction, dtype=float)
    n = n / np.linalg.norm(n)
    normals = np.linalg.svd(n[None, :])[2][1:]   # an orthonormal basis of the normal space

    def slider(a, b, a0, b0):
        return [(b.x - a.x - (b0.x - a0.x)) @ m for m in normals]
    return slider
