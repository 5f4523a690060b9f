"""Servo constraints: a point made to follow a prescribed path by unknown inputs (inverse dynamics).

A joint (rodfem/core/joints.py) prescribes motion through reactions G^T lambda at the very
points it constrains.  A SERVO constraint prescribes an output of the system, the position of a
point along a path (Blajer & Kolodziejczyk, "A geometric approach to solving problems of
control constraints: theory and a DAE framework", Multibody Syst Dyn 11 (2004) 343-364),

    g_s(q) = x_P(q) - x_P(0) = path(t) - path(0)      (m conditions, along chosen axes),

and enforces it by the INPUTS of actuators elsewhere: forces B(q) u, u in R^m unknown, on the
momentum rows of the actuated points.  The multiplier's column is B, not G_s^T:

    M v' = f(q, v) - G^T lambda + B(q) u,     q' = v,     g(q) = 0,     g_s(q) = path(t).

When the point is reached only through other bodies (a crane: the trolley pushed, the payload
prescribed), G_s M^{-1} B is singular and the DAE has a higher index: five for the overhead
crane (Altmann & Heiland, "Simulation of multibody systems with servo constraints through
optimal control", Multibody Syst Dyn 40 (2017) 75-98, doi:10.1007/s11044-016-9558-z).

An actuator is written like a component (rodfem/core/components.py): a measure xi(a, b, a0, b0),
quadratic in the coordinates of its two points, with an optional scalar gain s(xi); its input
u acts as the generalized force

    B(q) u = s(xi(q)) G_xi(q)^T u,      G_xi = d xi / dq,

e.g. a force u along a fixed direction e on a point (`along`: xi = e . x, s = 1), or a winch
pulling two points together with the tension u (`winch`: xi = |x_b - x_a|^2, s = -1/(2 sqrt(xi))).

Discretely (midpoint values, u held over the step like the multipliers of a joint, so that
u_{n+1} is the input of the step t_n -> t_{n+1}, the value a load u(t) takes at t_{n+1/2}):

    momentum rows of the actuated points:   - B(q_m) u
    the servo's own rows:                   G_s(q_m) v_m - (path(t_{n+1}) - path(t_n))/h = 0

g_s is linear in q, so the kinematic rows q_{n+1} - q_n = h v_m put the point ON the path at
every t_n (to the solver's tolerance).  The inputs supply the work h u . B(q_m)^T v_m in a step,
booked in `supplied`: H_{n+1} - H_n = -h d_n + h y.u still holds exactly.  The history gets the
inputs `name.u1 ...` (at t = 0: the inputs that balance the start, `start_multipliers`) and, in
`constraint_residual`, the distance from the path.

What the midpoint rule can and cannot do with it (`step_inputs`): the positions and the inputs
that act on the point itself converge at O(h^2); an input that reaches the point at relative
degree r > 2 carries parasitic solutions (-1)^n p(n) (the rule's zeros at z = -1), which a
zero-phase filter (`smoothed`) removes -- but at r = 4 (index 5) they grow in time, the faster
the smaller h, so the direct servo converges only down to some step (for the crane
of demos/crane_inverse.py, h = 0.025; benchmarks/bench_servo.py).  A servo whose zero dynamics
are unstable (the payload of a finite-element cable, whose consistent mass couples its ends at
once) has no bounded solution at all: see demos/crane_inverse.py.
"""
from dataclasses import dataclass
from math import comb
from typing import Callable, Optional, Sequence

import numpy as np
from numpy.polynomial import Polynomial

from rodfem.core.components import _differences
from rodfem.core.joints import GROUND, Point, quadratic_form
from rodfem.errors import ConstraintError


@dataclass(frozen=True)
class Actuator:
    """What an input does: a quadratic measure xi(a, b, a0, b0) of two points and the gain s(xi)
    (a scalar, None for 1) of its generalized force s(xi) G_xi^T u."""
    measure: Callable
    label: str = "input"
    gain: Optional[Callable] = None

    def between(self, a: Point, b: Point) -> "Input":
        return Input(self, a, b)

    def at(self, point: Point) -> "Input":
        """The actuator between the ground and `point`."""
        return Input(self, GROUND, point)


@dataclass(frozen=True)
class Input:
    """An actuator placed between points a and b (a may be GROUND)."""
    actuator: Actuator
    a: Point
    b: Point

    def describe(self):
        return f"{self.actuator.label} ({self.a.describe()} - {self.b.describe()})"


def along(direction) -> Actuator:
    """A force u e along the fixed direction e (normalized) on a point: xi = e . (x_b - x_a)."""
    e = np.asarray(direction, dtype=float)
    if e.ndim != 1 or not np.linalg.norm(e) > 0:
        raise ConstraintError(f"a force direction must be a nonzero vector (got {np.asarray(direction).tolist()})")
    e = e / np.linalg.norm(e)
    return Actuator(lambda a, b, a0, b0: [e @ (b.x - a.x)], f"force along {np.round(e, 6).tolist()}")


def winch() -> Actuator:
    """A cable of variable length between a and b pulled with the tension u (u > 0 pulls the
    points together): force -u (x_b - x_a)/|x_b - x_a| on b, the opposite on a."""
    return Actuator(lambda a, b, a0, b0: [(b.x - a.x) @ (b.x - a.x)], "winch",
                    gain=lambda c: -0.5 / np.sqrt(c))


class Servo:
    """`point`'s coordinates along `axes` follow path(t), enforced by the inputs (see the module
    docstring).  Bound by the System like a joint; its multipliers are the inputs u."""
    multiplier = "u"   # the history names its multipliers name.u1, name.u2, ...

    def __init__(self, point: Point, path: Callable, inputs: Sequence[Input], axes=None, name: str = "servo"):
        self.point, self.path, self.inputs, self.name = point, path, tuple(inputs), name
        self.axes = None if axes is None else [int(k) for k in np.atleast_1d(axes)]
        self.a, self.b = GROUND, point   # what the System reads of a joint's two points
        points = [GROUND, point]
        for i in self.inputs:
            if not isinstance(i, Input):
                raise ConstraintError(f"servo {name}: an input must be an actuator placed on points, e.g. "
                                      f"along((1, 0, 0)).at(trolley) (got {i!r})")
            points += [i.a, i.b]
        self.points = list(dict.fromkeys(points))   # each point once, in order

    def describe(self):
        return f"servo {self.name} ({self.point.describe()})"

    def bind(self, frames, q0s, scale):
        """Fix the quadratic forms of g_s and of the actuators' measures over q = all points' coordinates."""
        sizes = [len(q) for q in q0s]
        cuts = np.cumsum([0] + sizes)
        q0 = np.concatenate([np.asarray(q, float) for q in q0s])
        initial = [f(q) for f, q in zip(frames, q0s)]

        def of(fn, a, b):
            ia, ib = self.points.index(a), self.points.index(b)
            return lambda q: np.asarray(fn(frames[ia](q[cuts[ia]:cuts[ia + 1]]), frames[ib](q[cuts[ib]:cuts[ib + 1]]),
                                           initial[ia], initial[ib]), dtype=float).ravel()
        x0 = initial[self.points.index(self.point)].x
        axes = list(range(len(x0))) if self.axes is None else self.axes
        if any(not 0 <= k < len(x0) for k in axes) or len(set(axes)) != len(axes):
            raise ConstraintError(f"{self.describe()}: axes {axes} are not distinct axes of a {len(x0)}D point")
        self.axes = axes
        self.start = x0[axes]
        p0 = self._path(0.0)
        if np.max(np.abs(p0 - self.start)) > 1e-9 * scale:
            raise ConstraintError(f"{self.describe()}: the path starts at {np.round(p0, 9).tolist()}, the point is at "
                                  f"{np.round(self.start, 9).tolist()}: start the path where the point is")
        self.Q, self.c, self.e = quadratic_form(of(lambda a, b, a0, b0: (b.x - b0.x)[axes], GROUND, self.point),
                                                len(q0), scale)
        self.size = len(self.e)
        self.measures, width = [], 0
        for i in self.inputs:
            where = f"{self.describe()}: input {i.describe()}"
            xi = of(i.actuator.measure, i.a, i.b)
            try:
                xi(q0)
            except (TypeError, ValueError, IndexError) as err:
                raise ConstraintError(f"{where} does not fit its points ({err})") from None
            try:
                Q, c, e = quadratic_form(xi, len(q0), scale)
            except ConstraintError as err:
                raise ConstraintError(f"{where}: its measure {err}") from None
            self.measures.append((Q, c, e, i.actuator.gain))
            width += len(e)
        if width != self.size:
            raise ConstraintError(f"{self.describe()} prescribes {self.size} coordinate(s) with {width} input(s): "
                                  "give as many inputs as prescribed coordinates")
        B = self.input_map(q0)
        if not np.all(np.isfinite(B)) or np.linalg.matrix_rank(B, tol=1e-10 * max(1.0, np.abs(B).max())) < width:
            raise ConstraintError(f"{self.describe()}: its inputs act along dependent directions at t = 0")

    def _path(self, t):
        value = np.atleast_1d(np.asarray(self.path(t), dtype=float))
        if value.shape != (len(self.axes),) or not np.all(np.isfinite(value)):
            raise ConstraintError(f"{self.describe()}: path(t) must give {len(self.axes)} finite number(s) "
                                  f"(the point's axes {self.axes}); at t = {t:g} it gave {value.tolist()}")
        return value

    def prescribed(self, t):
        """g_p(t) = path(t) - path(0)."""
        return self._path(t) - self.start

    def position_residual(self, q, t):
        """x_P(q) - path(t) along the axes."""
        return 0.5 * np.einsum("i,kij,j->k", q, self.Q, q) + self.c @ q + self.e - self.prescribed(t)

    def input_map(self, q):
        """B(q) = [s_k(xi_k) G_k(q)^T] (n x m)."""
        cols = []
        for Q, c, e, gain in self.measures:
            G = np.einsum("kij,j->ki", Q, q) + c
            cols.append(G.T * (1.0 if gain is None else self._gain(gain, Q, c, e, q)))
        return np.hstack(cols)

    @staticmethod
    def _gain(gain, Q, c, e, q):
        xi = 0.5 * np.einsum("i,kij,j->k", q, Q, q) + c @ q + e
        return float(np.asarray(gain(xi[0] if len(xi) == 1 else xi), dtype=float).reshape(()))

    def step(self, q0, q1, v0, v1, u, h, t0, t1):
        """(r_v, r_u, dr_v/dq1, dr_v/du, dr_u/dq1, dr_u/dv1, work) of one step: r_v = -B(q_m) u on the
        momentum rows, r_u = G_s v_m - (g_p(t1) - g_p(t0))/h, work = h u . B(q_m)^T v_m."""
        qm, vm = 0.5 * (q0 + q1), 0.5 * (v0 + v1)
        Gs = np.einsum("kij,j->ki", self.Q, qm) + self.c
        B = self.input_map(qm)
        r_v = -B @ u
        r_u = Gs @ vm - (self.prescribed(t1) - self.prescribed(t0)) / h
        drv_dq = np.zeros((len(qm), len(qm)))
        k = 0
        for Q, c, e, gain in self.measures:
            uk = u[k:k + len(e)]
            k += len(e)
            s = 1.0 if gain is None else self._gain(gain, Q, c, e, qm)
            drv_dq -= 0.5 * s * np.einsum("k,kij->ij", uk, Q)
            if gain is not None:   # d s / d q1 = s'(xi_m) G(q_m) / 2, s' by central differences
                G = np.einsum("kij,j->ki", Q, qm) + c
                xi = 0.5 * np.einsum("i,kij,j->k", qm, Q, qm) + c @ qm + e
                ds = _differences(lambda x: gain(x[0] if len(x) == 1 else x), xi, 1e-7) @ G
                drv_dq -= 0.5 * np.outer(G.T @ uk, ds)
        drl_dq = 0.5 * np.einsum("kij,j->ki", self.Q, vm)
        return r_v, r_u, drv_dq, -B, drl_dq, 0.5 * Gs, h * float(u @ (B.T @ vm))


def start_multipliers(system):
    """The multipliers of x_0 (joints' lambda, servos' u) that best balance the forces on the joints'
    points in x_0 (least squares; exact for a start at rest in a balanced configuration: a crane's
    rope tension m g).  Newton needs them in a servo's first step: its rows see the inputs only
    through state-dependent directions (a rope's restoring force on the payload is its tension
    times the trolley's offset), which vanish with lambda = u = 0 and leave the matrix singular."""
    points = system.points
    before = points.x0_values, points.times
    points.step(system.X0, system.t, system.t + system.dt, system.dt)
    system.X0.copy(system.X1)
    b = system.layout.create_vector()
    system.assembler.residual(system.X1, b)   # x_{n+1} = x_n: the momentum rows carry -(net force)
    vals, r = points.values(system.X0), points.values(b)
    lam = None
    if system.comm.rank == 0:
        rows = sorted({int(g) for j in system.joints for k, g in enumerate(j.v_index) if k in j.rows})
        where = {g: i for i, g in enumerate(rows)}
        C, rhs = np.zeros((len(rows), len(system.layout.multipliers))), np.zeros(len(rows))
        position = {int(g): k for k, g in enumerate(points.wanted)}
        for g in rows:
            rhs[where[g]] = -r[position[g]]
        t0, t1, h = points.times
        for j in system.joints:
            q, v = vals[j.q_at], vals[j.v_at]
            columns = j.step(q, q, v, v, np.zeros(j.size), h, t0, t1)[3]   # d r_v / d lambda
            for k in j.rows:
                C[where[int(j.v_index[k])], j.offset:j.offset + j.size] += columns[k]
        lam = np.linalg.lstsq(C, rhs, rcond=None)[0]
    lam = system.comm.bcast(lam, root=0)
    k, at = system.layout.owned_multipliers()
    for X in (system.X0, system.X1):
        X.getArray()[at] = lam[k]
    # no step has been taken: x_0 is observed at its own time (the t = 0 row's constraint residual
    # |g(q_0) - path(t_0)|, not against path(t_0 + h) with whatever h the system had when built)
    points.x0_values, points.times = before


# -- paths and the computed inputs ---------------------------------------------------------------

class Transfer:
    """A rest-to-rest path from `start` (t <= t0) to `end` (t >= t1): start + (end - start) s_N(tau),
    tau = (t - t0)/(t1 - t0), with the smoothstep polynomial of degree 2N + 1 whose derivatives 1..N
    vanish at tau = 0 and 1,

        s_N(tau) = tau^(N+1) sum_{k=0}^{N} C(N+k, k) C(2N+1, N-k) (-tau)^k.

    path(t, k) is its k-th time derivative (exact: polynomial arithmetic)."""

    def __init__(self, start, end, t0, t1, flat=8):
        self.start, self.end = np.atleast_1d(np.asarray(start, float)), np.atleast_1d(np.asarray(end, float))
        if self.start.shape != self.end.shape or not t1 > t0 or int(flat) < 1:
            raise ConstraintError(f"a transfer needs start and end of one shape, t1 > t0 and flat >= 1 (got "
                                  f"{self.start.tolist()}, {self.end.tolist()}, t0 = {t0}, t1 = {t1}, flat = {flat})")
        self.t0, self.t1, self.flat = float(t0), float(t1), int(flat)
        N = self.flat
        tau = Polynomial([0.0, 1.0])
        self.s = tau ** (N + 1) * sum(comb(N + k, k) * comb(2 * N + 1, N - k) * (-tau) ** k for k in range(N + 1))

    def __call__(self, t, k=0):
        T = self.t1 - self.t0
        tau = min(max((float(t) - self.t0) / T, 0.0), 1.0)
        if k == 0:
            return self.start + (self.end - self.start) * self.s(tau)
        inside = self.t0 < float(t) < self.t1
        return (self.end - self.start) * (self.s.deriv(k)(tau) / T**k if inside else 0.0)


def smoothed(u):
    """The zero-phase filter (u_{n-1} + 2 u_n + u_{n+1})/4 of a sequence of step inputs (rows: steps;
    mirrored at the ends, where it is the mean of the last two).  It removes the parasitic inputs
    (-1)^n (a + b n) of the midpoint rule (see `step_inputs`) and adds h^2 u''/4 to a smooth input."""
    u = np.asarray(u, dtype=float)
    if len(u) < 2:
        return u.copy()
    padded = np.concatenate([u[1:2], u, u[-2:-1]])
    return 0.25 * (padded[:-2] + 2.0 * padded[1:-1] + padded[2:])


def step_inputs(rows, name, smooth=False):
    """The inputs a servo computed in a run (its history `rows`, dicts with 't' and 'name.u1', ...) as a
    function u(t) held over each step: u(t) = u_{n+1} for t_n < t <= t_{n+1}, the step's own value (a load
    u(t) is read at t_{n+1/2}: replayed with the same steps, it is the same input); u(t) = the row at t_0
    before it and the last row after the run.

    The midpoint rule determines an input that reaches the path only through other bodies (relative
    degree r > 2, e.g. a trolley force moving a payload on a rope: r = 4) up to parasitic solutions
    (-1)^n p(n), deg p <= r - 2: its transfer function from u to the path has r - 1 zeros at z = -1
    (the implicit midpoint rule is the Tustin map s = (2/h)(z - 1)/(z + 1), whose relative degree r
    becomes zeros at z = -1, less the one of the step-held input), so the exact discrete inverse has
    poles there.  They ride on the smooth input, invisible in the positions, excited where the path
    is not flat enough at rest (derivatives of order r + 1 and above that do not vanish there), and
    for r = 4 they grow in time, the faster the smaller h (measured; nothing damps them at z = -1).
    smooth=True gives the input through `smoothed` (Tomizuka's zero-phase treatment of zeros at
    z = -1: "Zero phase error tracking algorithm for digital control", J Dyn Syst Meas
    Control 109 (1987) 65-68, doi:10.1115/1.3143822)."""
    t = np.array([r["t"] for r in rows], dtype=float)
    columns = sorted((k for k in rows[0] if k.startswith(f"{name}.u") and k[len(name) + 2:].isdigit()),
                     key=lambda k: int(k[len(name) + 2:]))
    if not columns:
        raise ConstraintError(f"the history has no inputs of a servo named {name!r}")
    u = np.array([[r[c] for c in columns] for r in rows], dtype=float)
    if smooth:
        u[1:] = smoothed(u[1:])

    def value(time):
        n = int(np.searchsorted(t, float(time), side="left"))
        return u[min(n, len(u) - 1)].copy()
    return value
