"""Joints: power-preserving interconnections of bodies through points, as index-2 constraints.

A joint ties a point of body a to a point of body b (or to the ground) by a
position-level constraint g(q_a, q_b) = 0, written in forms/joints.py as a
plain function of the two points' `Frame`s.  With q the configuration
coordinates of both points (positions, directors, angles), v their
velocities (the flows paired with q) and lambda the joint's multipliers,
the joint adds to the step residual (index 2, velocity level, as in Kinon, Morandin & Schulze, Appl. Numer. Math. 2026)

    momentum rows of a and b:   + G(q_m)^T lambda          (the reaction forces)
    the joint's own rows:       G(q_m) v_m - (g_p(t_{n+1}) - g_p(t_n))/h = 0

with G = dg/dq, q_m, v_m midpoint values and lambda at t_{n+1}.  g must be
QUADRATIC in q (true for every joint of director-based bodies): then
g(q_{n+1}) - g(q_n) = G(q_m)(q_{n+1} - q_n) = h G(q_m) v_m exactly (the
kinematic rows give q_{n+1} - q_n = h v_m node by node), so the position
constraint holds to round-off for all time; and tested with v_m the
reactions do no work, lambda . G(q_m) v_m = 0: the joint adds no energy.
A driven joint (prescribed motion g(q) = g_p(t)) is an input port: it
supplies the work -lambda . (g_p(t_{n+1}) - g_p(t_n)) in a step.

The engine never looks inside g: it finds the quadratic form
g_k(q) = 1/2 q.Q_k q + c_k.q + e_k by polarization (exact for a quadratic g),
and refuses a g that is not quadratic.
"""
from dataclasses import dataclass
from typing import Callable, Optional, Sequence

import numpy as np

from rodfem.errors import ConstraintError


@dataclass
class Frame:
    """A material point seen by a joint: position x, directors d (3D bodies), angle phi (planar bodies)."""
    x: np.ndarray
    d: Optional[Sequence[np.ndarray]] = None
    phi: Optional[float] = None

    @property
    def kind(self):
        """What the point carries, in words (for error messages)."""
        if self.d is not None:
            return "directors (3D)"
        return "an angle (planar)" if self.phi is not None else "a position only"

    @property
    def R(self):
        """[d1 d2 d3] (columns)."""
        return np.column_stack(self.d)


@dataclass(frozen=True)
class Point:
    """A point of a body: an end ('left', 'right'), the rigid body itself ('body'), or a node at
    s (markers), with an `offset` in the body's frame (rigid bodies, rod ends)."""
    body: object                 # the System's BodyRef (None: the ground)
    where: str
    offset: tuple = ()
    s: Optional[float] = None     # a node at arc length s; for the ground: its directors, if given

    def describe(self):
        if self.body is None:
            return f"ground{tuple(self.offset) if any(self.offset) else ''}"
        tail = f" + {tuple(self.offset)}" if any(self.offset) else ""
        return f"{self.body.name}.{self.where}{tail}"


def ground(x: Sequence[float] = (), R=None) -> Point:
    """A fixed point of the world at position x (default the origin), with the world axes
    (or the directors R = [d1 d2 d3]) and angle 0."""
    return Point(None, "ground", tuple(np.asarray(x, dtype=float).ravel()),
                 None if R is None else tuple(np.asarray(R, dtype=float).ravel()))


GROUND = ground()   # the world frame at the origin


ROUNDOFF = 1e-13   # coefficients below this, relative to g's scale, are the polarization's round-off


def quadratic_form(g, n, scale=1.0):
    """(Q[m, n, n], c[m, n], e[m]) with g(q) = 1/2 q.Q_k q + c_k.q + e_k, by polarization.

    Exact for a quadratic g (each entry is a combination of values of g at
    points 0, +-s e_i, s(e_i + e_j) with a step s = `scale`; coefficients at the
    differences' round-off, below ROUNDOFF relative, are set to zero); raises
    ConstraintError if g is not quadratic (checked at random points).
    """
    s = float(scale)
    e = np.atleast_1d(np.asarray(g(np.zeros(n)), dtype=float))
    I = np.eye(n) * s
    gp = np.array([np.atleast_1d(g(I[i])) for i in range(n)])
    gm = np.array([np.atleast_1d(g(-I[i])) for i in range(n)])
    c = ((gp - gm) / (2 * s)).T
    Q = np.zeros((len(e), n, n))
    diag = (gp + gm - 2 * e) / s**2
    for i in range(n):
        Q[:, i, i] = diag[i]
        for j in range(i + 1, n):
            qij = (np.atleast_1d(g(I[i] + I[j])) - gp[i] - gp[j] + e) / s**2
            Q[:, i, j] = Q[:, j, i] = qij
    # entries zero in exact arithmetic come out of the differences as round-off (~1e-16 of g's values):
    # zero, so that the joints' matrix entries are only those that can be nonzero (rodfem/core/joint_batch.py)
    noise = ROUNDOFF * (np.abs(Q).max(axis=(1, 2), initial=0.0) + np.abs(c).max(axis=1, initial=0.0) / s
                        + np.abs(e) / s**2)
    Q[np.abs(Q) <= noise[:, None, None]] = 0.0
    c[np.abs(c) <= s * noise[:, None]] = 0.0
    rng = np.random.default_rng(0)
    for _ in range(3):
        q = rng.standard_normal(n) * s
        exact = np.atleast_1d(g(q))
        model = 0.5 * np.einsum("i,kij,j->k", q, Q, q) + c @ q + e
        if np.max(np.abs(exact - model)) > 1e-9 * max(1.0, np.max(np.abs(exact))):
            raise ConstraintError("is not quadratic in the coordinates of its points "
                                  "(use director-based bodies or a point without offset)")
    return Q, c, e


class QuadraticForms:
    """The quadratic forms found while a System is bound, reused for a function that is a known one
    shifted: many equal joints (a chain's hinges, a net's knots) cost a few evaluations each, not
    the polarization's (n + 1)(n + 2)/2.

    For a function g' of the same `key` (the same constraint between the same kinds of points) with
    initial coordinates q0' = q0 + T, the candidate is the known form moved by T,

        g'(q) = g(q - T):   Q' = Q,  c'_k = c_k - Q_k T,  e'_k = e_k - c_k.T + 1/2 T.Q_k T,

    accepted only if it equals g' at q0' and at two random points: two different quadratics agree
    at a random point with probability zero (their difference is a nonzero polynomial), so an
    accepted candidate is g' itself; otherwise g' is polarized afresh (and becomes the known one)."""

    def __init__(self):
        self.known = {}

    def find(self, g, q0, scale=1.0, key=None):
        """(Q, c, e) of g (quadratic in n = len(q0) coordinates) by `quadratic_form`, or moved from the
        last form found for `key`."""
        q0, s = np.asarray(q0, dtype=float), float(scale)
        if key is not None and key in self.known:
            (Q, c, e), known_q0 = self.known[key]
            if known_q0.shape == q0.shape:
                T = q0 - known_q0
                QT = np.einsum("kij,j->ki", Q, T)
                moved = (Q, c - QT, e - c @ T + 0.5 * QT @ T)
                rng = np.random.default_rng(len(self.known))
                if all(_agrees(g, moved, q, s) for q in (q0, q0 + s * rng.standard_normal(q0.shape),
                                                         q0 + s * rng.standard_normal(q0.shape))):
                    return moved
        form = quadratic_form(g, len(q0), s)
        if key is not None:
            self.known[key] = (form, q0)
        return form


def point_kind(p):
    """What a point contributes to a QuadraticForms key: its body's model, place and offset (the
    ground's: its position and axes)."""
    return (None if p.body is None else id(p.body.body.model), p.where, p.offset, p.s)


def _agrees(g, form, q, scale):
    """Whether the quadratic form (Q, c, e) equals g at q (to the tolerance of `quadratic_form`'s check)."""
    Q, c, e = form
    exact = np.atleast_1d(g(q))
    model = 0.5 * np.einsum("i,kij,j->k", q, Q, q) + c @ q + e
    return exact.shape == model.shape and bool(
        np.max(np.abs(exact - model), initial=0.0) <= 1e-9 * max(1.0, np.max(np.abs(exact), initial=0.0), scale ** 2))


class Joint:
    """g(frame_a, frame_b, a0, b0) = drive(t) between points a and b (a0, b0: their initial frames).

    `coordinates` is set by the System: for each side, the frame builder
    q -> Frame and the initial coordinates q(0).
    """

    def __init__(self, constraint: Callable, a: Point, b: Point, name: str = "", drive: Callable = None):
        self.constraint, self.a, self.b, self.drive = constraint, a, b, drive
        self.name = name or getattr(constraint, "__name__", "joint")

    def bind(self, frame_a, frame_b, qa0, qb0, scale, forms=None):
        """Fix the quadratic form of g(q), q = (q_a, q_b), from the frame builders and q(0) (found by
        `forms`, a QuadraticForms, when given: the System's, shared by its joints)."""
        na, qa0, qb0 = len(qa0), np.asarray(qa0, float), np.asarray(qb0, float)
        a0, b0 = frame_a(qa0), frame_b(qb0)

        def g(q):
            return np.asarray(self.constraint(frame_a(q[:na]), frame_b(q[na:]), a0, b0), dtype=float).ravel()
        where = f"joint {self.name} ({self.a.describe()} - {self.b.describe()})"
        if len(a0.x) != len(b0.x):
            raise ConstraintError(f"{where} joins a {len(a0.x)}D point to a {len(b0.x)}D point")
        try:
            g(np.concatenate([qa0, qb0]))
        except (TypeError, ValueError, IndexError) as err:
            kinds = " and ".join(f.kind for f in (a0, b0))
            raise ConstraintError(f"{where} does not fit points that have {kinds} ({err})") from None
        try:
            key = (self.constraint, na, point_kind(self.a), point_kind(self.b))
            self.Q, self.c, self.e = (forms or QuadraticForms()).find(g, np.concatenate([qa0, qb0]), scale, key)
        except ConstraintError as err:
            raise ConstraintError(f"{where} {err}") from None
        self.size = len(self.e)
        q0 = np.concatenate([qa0, qb0])
        self.q_initial = q0
        gap = np.max(np.abs(self.position_residual(q0, 0.0))) if self.size else 0.0
        if gap > 1e-9 * scale:
            raise ConstraintError(f"{where} does not hold in the initial configuration "
                                  f"(|g| = {gap:.3g}): place the points where the joint puts them")
        if self.drive is not None:
            d0 = np.atleast_1d(np.asarray(self.drive(0.0), float))
            if d0.shape != (self.size,) or np.any(np.abs(d0) > 1e-12 * scale):
                raise ConstraintError(f"{where}: drive(t) must give {self.size} values, zero at t = 0 (got {d0})")

    def prescribed(self, t):
        """g_p(t) (zero for an ordinary joint)."""
        if self.drive is None:
            return np.zeros(self.size)
        return np.atleast_1d(np.asarray(self.drive(t), dtype=float))

    def position_residual(self, q, t):
        """g(q) - g_p(t)."""
        return 0.5 * np.einsum("i,kij,j->k", q, self.Q, q) + self.c @ q + self.e - self.prescribed(t)

    def step(self, q0, q1, v0, v1, lam, h, t0, t1):
        """Residual rows and their derivatives for one step.

        Returns (r_v, r_lam, dr_v/dq1, dr_v/dlam, dr_lam/dq1, dr_lam/dv1, work):
        r_v = G(q_m)^T lam (added to the momentum rows), r_lam = G(q_m) v_m - dg_p/h,
        work = -lam . (g_p(t1) - g_p(t0)) (nonzero only for a driven joint).
        """
        qm, vm = 0.5 * (q0 + q1), 0.5 * (v0 + v1)
        G = np.einsum("kij,j->ki", self.Q, qm) + self.c
        dgp = self.prescribed(t1) - self.prescribed(t0)
        r_v = G.T @ lam
        r_lam = G @ vm - dgp / h
        drv_dq = 0.5 * np.einsum("k,kij->ij", lam, self.Q)
        drl_dq = 0.5 * np.einsum("kij,j->ki", self.Q, vm)
        return r_v, r_lam, drv_dq, G.T, drl_dq, 0.5 * G, -float(lam @ dgp)


class MovingGround(Joint):
    """A joint g(a, b, a0, b0) = 0 between a GROUND frame that moves on a prescribed path,
    motion(t) = (x(t), R(t)) (R = [d1 d2 d3], the frame at t = 0: the ground point's own), and a body's
    point b: e.g. `prismatic(0)` to a frame turning about its d1 turns a rod's end about the axis and
    lets it slide along it.

    With p(t) = (x, d1, d2, d3)(t) the frame's 12 coordinates, g(p, q) is quadratic in (p, q) together
    (as every joint of forms/joints.py), so the step's rows are the plain joint's with p's increment
    known (p_{n+1} - p_n = h v_p):

        momentum rows of b:   + G_q(p_m, q_m)^T lambda
        the joint's rows:     G_q(p_m, q_m) v_m + G_p(p_m, q_m) (p_{n+1} - p_n)/h = 0,

    and g(p_{n+1}, q_{n+1}) - g(p_n, q_n) = G(p_m, q_m)(X_{n+1} - X_n) exactly: g = 0 holds to round-off
    for all time.  The reactions do the work -lambda . G_q (q_{n+1} - q_n) = lambda . G_p (p_{n+1} - p_n)
    on the body in a step: the work the motion supplies (booked in `supplied`)."""

    def __init__(self, constraint: Callable, a, b, name: str = "", motion: Callable = None):
        super().__init__(constraint, a, b, name)
        self.motion = motion

    def frame_coordinates(self, t):
        """p(t) = (x, d1, d2, d3) of the moving frame (12 numbers)."""
        x, R = self.motion(t)
        x, R = np.asarray(x, dtype=float).ravel(), np.asarray(R, dtype=float).reshape(3, 3)
        if x.shape != (3,) or not (np.all(np.isfinite(x)) and np.all(np.isfinite(R))):
            raise ConstraintError(f"joint {self.name}: motion(t) must give a finite position (3) and R (3 x 3) "
                                  f"(got {x}, {R} at t = {t:g})")
        return np.concatenate([x, R[:, 0], R[:, 1], R[:, 2]])

    def bind(self, frame_a, frame_b, qa0, qb0, scale, forms=None):
        """The quadratic form of g over (p, q) (polarized: `forms` is not used); Q, c, e of the base
        class: the form in q at p(0) (what the checks at the start see)."""
        p0 = self.frame_coordinates(0.0)
        fixed = frame_a(qa0)
        if np.max(np.abs(p0 - np.concatenate([fixed.x, *fixed.d]))) > 1e-12 * max(scale, 1.0):
            raise ConstraintError(f"joint {self.name}: motion(0) must be the ground point's frame "
                                  f"({fixed.x}, R = [d1 d2 d3]); got {p0}")

        def moving(p):
            return Frame(x=p[:3], d=[p[3:6], p[6:9], p[9:12]])
        self.full = None      # (the base class's checks see the form over (p, q))
        super().bind(moving, frame_b, p0, qb0, scale)
        self.full = (self.Q, self.c, self.e)
        Q, c, e = self.full
        self.Q = Q[:, 12:, 12:]
        self.c = c[:, 12:] + np.einsum("kij,j->ki", Q[:, 12:, :12], p0)
        self.e = e + c[:, :12] @ p0 + 0.5 * np.einsum("i,kij,j->k", p0, Q[:, :12, :12], p0)

    def position_residual(self, q, t):
        if self.full is None:
            return super().position_residual(q, t)
        X = np.concatenate([self.frame_coordinates(t), q])
        Q, c, e = self.full
        return 0.5 * np.einsum("i,kij,j->k", X, Q, X) + c @ X + e

    def step(self, q0, q1, v0, v1, lam, h, t0, t1):
        """As Joint.step, with the frame's coordinates p(t0), p(t1) before the body's."""
        p0, p1 = self.frame_coordinates(t0), self.frame_coordinates(t1)
        Q, c, _ = self.full
        Xm = np.concatenate([0.5 * (p0 + p1), 0.5 * (q0 + q1)])
        G = np.einsum("kij,j->ki", Q, Xm) + c
        Gp, Gq = G[:, :12], G[:, 12:]
        vm = 0.5 * (v0 + v1)
        r_v = Gq.T @ lam
        r_lam = Gq @ vm + Gp @ (p1 - p0) / h
        Qqq, Qqp = Q[:, 12:, 12:], Q[:, 12:, :12]
        drv_dq = 0.5 * np.einsum("k,kij->ij", lam, Qqq)
        drl_dq = 0.5 * (np.einsum("kij,j->ki", Qqq, vm) + np.einsum("kij,j->ki", Qqp, (p1 - p0) / h))
        return r_v, r_lam, drv_dq, Gq.T, drl_dq, 0.5 * Gq, float(lam @ (Gp @ (p1 - p0)))
