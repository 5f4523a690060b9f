"""Components: springs and dampers between two points, with their own energy and dissipation.

A component ties a point of body a to a point of body b (or to the ground) like a joint
(rodfem/core/joints.py), but through a stored energy or a resistance instead of a constraint.
Both are written in forms/components.py with a MEASURE xi(a, b, a0, b0) of the two points'
frames that is quadratic in their coordinates q (like a joint's g: the squared distance
|x_b - x_a|^2, the relative position x_b - x_a, the relative angle phi_b - phi_a), so that

    xi(q_{n+1}) - xi(q_n) = G(q_m) (q_{n+1} - q_n),   G = d xi / dq,  q_m = (q_n + q_{n+1})/2,

exactly (the engine finds the quadratic form by polarization and refuses any other xi).

* A `Potential` stores V(q) = psi(xi(q)) for ANY energy psi of the measure (Kinon, Morandin,
  Schulze, "Discrete gradient methods for port-Hamiltonian differential-algebraic equations",
  arXiv 2505.18810: E x' = (J - R) z + B u with z = grad H).  Its force on the momentum rows of
  the two points is G(q_m)^T z with the co-energy:

      midpoint:           z = psi'(xi(q_m))
      discrete gradient:  z = psi'(xi_m) + [psi(xi_1) - psi(xi_0) - psi'(xi_m).dxi] dxi / |dxi|^2,
                          xi_m = (xi_0 + xi_1)/2, dxi = xi_1 - xi_0   (Gonzalez, J Nonlinear Sci 6 (1996))

  so that, with the kinematic rows q_{n+1} - q_n = h v_m, the force does the work
  z . dxi = psi(xi_1) - psi(xi_0) = V(q_{n+1}) - V(q_n) exactly under the discrete gradient for
  any psi (and under the midpoint rule only when psi is linear in xi).  The discrete gradient is
  taken in the measure, not in q: for a spring (xi = |d|^2) the force stays along d, so the
  component carries no net force or moment and the momentum maps stay conserved.  Where
  |dxi| <= 1e-3 |xi| the bracket (a cancellation) is replaced by its Taylor term
  D^3 psi(xi_m)[dxi, dxi, dxi] / 24, as in rodfem/core/integrators.py.

* A `Resistance` is a damper: the force eta G(q_m)^T G(q_m) v_m on the momentum rows, with a
  coefficient eta(xi(q_m)) >= 0 that may depend on the measure at the midpoint (R(x) of the
  PH-DAE).  It dissipates h d_n = h eta |G(q_m) v_m|^2 >= 0 in the step (the `dissipated` column).

* A `Dissipator` is a nonlinear resistance: the force G(q_m)^T f(xi_m, xi'_m) on the momentum rows
  with any law f of the measure and its rate at the step's midpoint (xi_m = xi(q_m),
  xi'_m = G(q_m) v_m) that resists the motion, xi'_m . f >= 0 (regularized Coulomb friction,
  forms/contact.py).  It dissipates h d_n = h xi'_m . f >= 0 in the step, exactly the work its force
  takes from the kinetic energy (the kinematic rows give q_{n+1} - q_n = h v_m); a law that would
  supply energy is refused in one line.

The energy functions psi are plain functions of numbers (written with numpy): the engine
differentiates them by the complex step (exact first derivatives), the second and third
derivatives (Newton's matrix, the Taylor term) by differences of those.
"""
import warnings
from dataclasses import dataclass
from typing import Callable, Optional, Union

import numpy as np

from rodfem.core.joints import Point, QuadraticForms, point_kind
from rodfem.errors import ConstraintError

COMPLEX_STEP = 1e-30
COMPLEX_WARNING = getattr(np, "exceptions", np).ComplexWarning   # a complex number made real (math.sqrt)
TAYLOR_BELOW = 1e-3     # |dxi| <= TAYLOR_BELOW |xi|: the Taylor term instead of the difference quotient


def _values(fn, xi):
    return np.atleast_1d(np.asarray(fn(xi), dtype=float))


class Energy:
    """psi(xi) of a measure with m components and its derivatives (numbers)."""

    def __init__(self, psi: Callable, m: int, where: str):
        self.psi, self.m, self.where = psi, m, where

    def __call__(self, xi) -> float:
        value = np.asarray(self.psi(xi[0] if self.m == 1 else xi), dtype=float)
        if value.shape not in ((), (1,)):
            raise ConstraintError(f"{self.where}: the energy must return one number (got shape {value.shape})")
        return float(value.reshape(()))

    def gradient(self, xi) -> np.ndarray:
        """d psi / d xi by the complex step (exact to round-off)."""
        g = np.zeros(self.m)
        for k in range(self.m):
            z = np.asarray(xi, dtype=complex)
            z[k] += 1j * COMPLEX_STEP
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("error", COMPLEX_WARNING)
                    value = np.asarray(self.psi(z[0] if self.m == 1 else z))
            except (TypeError, COMPLEX_WARNING) as err:
                raise ConstraintError(f"{self.where}: the energy must accept complex numbers "
                                      f"(write it with numpy, not math): {err}") from None
            g[k] = float(np.imag(value).reshape(())) / COMPLEX_STEP
        return g

    def hessian(self, xi, order=2) -> np.ndarray:
        """d^2 psi / d xi^2 by central differences of the gradient: `order` 2 for Newton's matrix
        (steps 1e-6 max(1, |xi_k|)), 4 for the linear model (rodfem/analysis/linearize.py: the
        five-point stencil, steps 1e-3 max(|xi|_inf, 1e-4), ~1e-12 relative for an energy that
        varies on the scale of |xi|)."""
        if order == 4:
            return _symmetric(_five_point(self.gradient, np.asarray(xi, dtype=float), 1e-4))
        H = np.zeros((self.m, self.m))
        for k in range(self.m):
            step = 1e-6 * max(1.0, abs(xi[k]))
            e = np.zeros(self.m)
            e[k] = step
            H[:, k] = (self.gradient(xi + e) - self.gradient(xi - e)) / (2 * step)
        return _symmetric(H)

    def third(self, xi, u) -> float:
        """D^3 psi(xi)[u, u, u] by the second difference of the directional derivative."""
        n = np.linalg.norm(u)
        if n == 0:
            return 0.0
        e = u / n
        # the step on the scale of xi (not of 1): an energy that varies on a small scale of its measure
        # (a contact's penalty, xi ~ the penetration) is resolved; the round-off of the difference,
        # eps |psi'| / step^2, enters z times dxi^2 <= (1e-3 |xi|)^2: at most eps |psi'|
        step = 1e-3 * max(float(np.max(np.abs(xi))), n, 1e-300)

        def slope(t):
            return self.gradient(xi + t * e) @ e
        return (slope(step) - 2 * slope(0.0) + slope(-step)) / step**2 * n**3


class Component:
    """What a Potential and a Resistance share: the two points and the quadratic measure."""

    def __init__(self, measure: Callable, a: Point, b: Point, name: str):
        self.measure, self.a, self.b, self.name = measure, a, b, name

    def describe(self):
        return f"{self.name} ({self.a.describe()} - {self.b.describe()})"

    def bind(self, frame_a, frame_b, qa0, qb0, scale, rule, forms=None):
        """Fix the quadratic form xi(q) = 1/2 q.Q_k q + c_k.q + e_k, q = (q_a, q_b) (found by `forms`, a
        QuadraticForms, when given)."""
        na, qa0, qb0 = len(qa0), np.asarray(qa0, float), np.asarray(qb0, float)
        a0, b0 = frame_a(qa0), frame_b(qb0)
        self.frames, self.na, self.rule = (frame_a, frame_b), na, rule

        def xi(q):
            return np.asarray(self.measure(frame_a(q[:na]), frame_b(q[na:]), a0, b0), dtype=float).ravel()
        if len(a0.x) != len(b0.x):
            raise ConstraintError(f"{self.describe()} connects a {len(a0.x)}D point to a {len(b0.x)}D point")
        try:
            xi(np.concatenate([qa0, qb0]))
        except (TypeError, ValueError, IndexError) as err:
            raise ConstraintError(f"{self.describe()} does not fit points that have "
                                  f"{a0.kind} and {b0.kind} ({err})") from None
        try:
            self.Q, self.c, self.e = (forms or QuadraticForms()).find(
                xi, np.concatenate([qa0, qb0]), scale, key=(self.measure, na, point_kind(self.a), point_kind(self.b)))
        except ConstraintError as err:
            raise ConstraintError(f"{self.describe()}: its measure {err}") from None
        self.m = len(self.e)
        self.q_initial = np.concatenate([qa0, qb0])

    def observe(self, q1, v1, t1, q0, v0, t0) -> dict:
        """History columns of the state (q1, v1) at t1 after the step from (q0, v0) at t0 (none)."""
        return {}

    def xi(self, q):
        """The measure xi(q)."""
        return 0.5 * np.einsum("i,kij,j->k", q, self.Q, q) + self.c @ q + self.e

    def G(self, q):
        """d xi / dq at q (m x n)."""
        return np.einsum("kij,j->ki", self.Q, q) + self.c


class Potential(Component):
    """Stored energy V = psi(xi(q)) between two points (see the module docstring); with `timed`,
    psi(xi, t): its change in time (a moving set point) is work supplied to the system,
    [psi(xi_1, t_1) - psi(xi_1, t_m)] + [psi(xi_0, t_m) - psi(xi_0, t_0)] in a step, and z is the
    discrete gradient of psi(., t_m), so that V_{n+1} - V_n = z . dxi + that work exactly."""
    dissipative = False

    def __init__(self, measure: Callable, energy: Callable, a: Point, b: Point, name: str, timed: bool = False):
        super().__init__(measure, a, b, name)
        self.psi, self.timed, self.columns = energy, timed, None

    def energy_at(self, t) -> Energy:
        """psi(., t) (psi itself when the energy does not depend on time)."""
        if not self.timed:
            return self.energy_of
        return Energy(lambda xi: self.psi(xi, t), self.m, self.describe())

    def bind(self, *args, **kwargs):
        super().bind(*args, **kwargs)
        self.energy_of = Energy(self.psi, self.m, self.describe())
        psi = self.energy_at(0.0)
        V0 = psi(self.xi(self.q_initial))
        psi.gradient(self.xi(self.q_initial))   # refuses an energy that cannot be differentiated
        if not np.isfinite(V0):
            raise ConstraintError(f"{self.describe()}: the energy is not finite in the initial configuration "
                                  f"(V = {V0}); place the points where it is defined")

    def energy(self, q, t=0.0) -> float:
        return self.energy_at(t)(self.xi(q))

    def observe(self, q1, v1, t1, q0, v0, t0):
        """`name.V`: the stored energy at t1; and the law's own columns (`columns(xi, psi'(xi))`,
        e.g. a contact's normal force and gap), named name.column."""
        out = {f"{self.name}.V": self.energy(q1, t1)}
        if self.columns is not None:
            xi = self.xi(q1)
            z = self.energy_at(t1).gradient(xi)
            out.update({f"{self.name}.{k}": float(v) for k, v in
                        self.columns(xi[0] if self.m == 1 else xi, z[0] if self.m == 1 else z).items()})
        return out

    def co_energy(self, psi, xi0, xi1, xim):
        """(z, dz/dxi1) of the step: the midpoint gradient or the discrete gradient in xi."""
        if self.rule != "discrete-gradient":
            return psi.gradient(xim), None
        xi_bar = 0.5 * (xi0 + xi1)
        dxi = xi1 - xi0
        grad = psi.gradient(xi_bar)
        n2 = float(dxi @ dxi)
        size = max(float(np.max(np.abs(xi0))), float(np.max(np.abs(xi1))))
        if n2 > (TAYLOR_BELOW * size) ** 2:
            bracket = psi(xi1) - psi(xi0) - grad @ dxi
        else:
            bracket = psi.third(xi_bar, dxi) / 24.0
        z = grad + (bracket / n2 if n2 > 0 else 0.0) * dxi
        if self.m == 1 and n2 > (TAYLOR_BELOW * size) ** 2:
            # one measure: z is the difference quotient, dz/dxi1 = (psi'(xi1) - z) / dxi exactly (Newton
            # converges through a step that crosses a kink of psi, e.g. a contact's onset)
            return z, 2.0 * (psi.gradient(xi1) - z).reshape(1, 1) / dxi[0]
        return z, psi.hessian(xi_bar)

    def at_rest(self, q, t=0.0):
        """(r_v, dr_v/dq) of statics: the force G(q)^T psi'(xi(q)) and its derivative."""
        psi = self.energy_at(t)
        G, xi = self.G(q), self.xi(q)
        z = psi.gradient(xi)
        return G.T @ z, np.einsum("k,kij->ij", z, self.Q) + G.T @ psi.hessian(xi) @ G

    def linear(self, q, v, t=0.0):
        """The linear model's terms at (q, v), time t (rodfem/analysis/linearize.py): the force
        r_v = G^T psi'(xi) on the momentum rows, dr_v/dq = G^T psi''(xi) G + sum_k psi'_k(xi) Q_k (the
        Hessian of V: the spring's own stiffness and the geometric stiffness of its pre-stress),
        dr_v/dv = 0, and that Hessian again as the spring's part of Hess (its energy joins H)."""
        psi = self.energy_at(t)
        G, xi = self.G(q), self.xi(q)
        z = psi.gradient(xi)
        stiffness = G.T @ psi.hessian(xi, order=4) @ G + np.einsum("k,kij->ij", z, self.Q)
        return {"force": G.T @ z, "dq": stiffness, "dv": np.zeros((len(q), len(q))), "hessian": stiffness}

    def step(self, q0, q1, v0, v1, h, t0, t1):
        """(r_v, dr_v/dq1, dr_v/dv1, supplied, dissipated): r_v = G(q_m)^T z on the momentum rows."""
        qm = 0.5 * (q0 + q1)
        Gm = self.G(qm)
        xi0, xi1, xim = self.xi(q0), self.xi(q1), self.xi(qm)
        tm = 0.5 * (t0 + t1)
        psi = self.energy_at(tm)
        z, hess = self.co_energy(psi, xi0, xi1, xim)
        if hess is None:   # midpoint: z = psi'(xi(q_m)), dz/dq1 = psi''(xi_m) G_m / 2
            hess = psi.hessian(xim)
            dz_dq = 0.5 * hess @ Gm
        else:              # discrete gradient: dz/dq1 ~ psi''(xi_bar) G(q1) / 2 (Newton's matrix; exact for m = 1)
            dz_dq = 0.5 * hess @ self.G(q1)
        r_v = Gm.T @ z
        dr_dq = 0.5 * np.einsum("k,kij->ij", z, self.Q) + Gm.T @ dz_dq
        work = 0.0
        if self.timed:
            before, after = self.energy_at(t0), self.energy_at(t1)
            work = (after(xi1) - psi(xi1)) + (psi(xi0) - before(xi0))
        return r_v, dr_dq, np.zeros((len(q1), len(q1))), work, 0.0


class Resistance(Component):
    """A damper: the force eta G(q_m)^T G(q_m) v_m, dissipating h eta |G(q_m) v_m|^2 >= 0."""
    dissipative = True

    def __init__(self, measure: Callable, coefficient: Union[float, Callable], a: Point, b: Point, name: str):
        super().__init__(measure, a, b, name)
        self.coefficient = coefficient

    def bind(self, *args, **kwargs):
        super().bind(*args, **kwargs)
        self.eta(self.q_initial)

    def eta(self, q) -> float:
        """The coefficient eta(xi(q)) at the configuration q (checked: finite and >= 0)."""
        return self.coefficient_of(self.xi(q))

    def coefficient_of(self, xi) -> float:
        if callable(self.coefficient):
            value = self.coefficient(xi[0] if self.m == 1 else xi)
        else:
            value = self.coefficient
        value = np.asarray(value, dtype=float)
        if value.shape not in ((), (1,)) or not np.isfinite(value).all() or float(value.reshape(())) < 0:
            raise ConstraintError(f"{self.describe()}: the damping coefficient must be one number >= 0 "
                                  f"(got {value.tolist()})")
        return float(value.reshape(()))

    def at_rest(self, q, t=0.0):
        """Statics: a damper exerts no force at rest."""
        return np.zeros(len(q)), np.zeros((len(q), len(q)))

    def linear(self, q, v, t=0.0):
        """The linear model's terms at (q, v) (rodfem/analysis/linearize.py): the force
        r_v = eta G^T G v, dr_v/dv = eta(xi) G^T G (its part of R: symmetric, >= 0) and dr_v/dq, which
        vanishes at rest (v = 0: only eta's value at the point matters there)."""
        G = self.G(q)
        rate = G @ v
        eta = self.eta(q)
        dq = eta * (np.einsum("k,kij->ij", rate, self.Q) + G.T @ np.einsum("kij,j->ki", self.Q, v))
        if callable(self.coefficient) and np.any(rate):   # d eta / dq = eta'(xi) G
            dq += np.outer(G.T @ rate, _five_point(self.coefficient_of, self.xi(q), 1e-4)[0] @ G)
        return {"force": eta * G.T @ rate, "dq": dq, "dv": eta * G.T @ G, "hessian": None}

    def step(self, q0, q1, v0, v1, h, t0, t1):
        qm, vm = 0.5 * (q0 + q1), 0.5 * (v0 + v1)
        Gm = self.G(qm)
        rate = Gm @ vm
        eta = self.eta(qm)
        r_v = eta * Gm.T @ rate
        dr_dv = 0.5 * eta * Gm.T @ Gm
        dr_dq = 0.5 * eta * (np.einsum("k,kij->ij", rate, self.Q) + Gm.T @ np.einsum("kij,j->ki", self.Q, vm))
        if callable(self.coefficient):   # d eta / d q1 = eta'(xi_m) G_m / 2, eta' by central differences
            deta = _differences(self.coefficient_of, self.xi(qm), 1e-7) @ Gm
            dr_dq += 0.5 * np.outer(Gm.T @ rate, deta)
        return r_v, dr_dq, dr_dv, 0.0, h * eta * float(rate @ rate)


class Feedback(Component):
    """A control law at a port: the input u = law(t, xi, xi') (generalized forces along the measure,
    m numbers) acts on the points as G^T u, read at the step's midpoint t_m, xi(q_m), G(q_m) v_m, and
    supplies the work h u . xi'_m = u . (xi_{n+1} - xi_n) (exact: xi is quadratic).  Any Python
    function: Newton's matrix takes its derivatives by differences.

    A law with a state of its own (a controller's integrator, forms/components.py: `PID`) is an
    object with `u(t, xi, rate, h)` (the input at the step's midpoint, from its state at t_n),
    `advance(t, xi, rate, h)` (its state at t_{n+1}, once the step is accepted) and `state` (a list
    of numbers: checkpointed with the run)."""
    dissipative = False

    def __init__(self, measure: Callable, law: Callable, a: Point, b: Point, name: str):
        super().__init__(measure, a, b, name)
        self.law = law
        self.stateful = hasattr(law, "advance")

    def u(self, t, xi, rate, h=0.0):
        x, r = (xi[0], rate[0]) if self.m == 1 else (xi, rate)
        value = self.law.u(t, x, r, h) if self.stateful else self.law(t, x, r)
        value = np.atleast_1d(np.asarray(value, dtype=float))
        if value.shape != (self.m,) or not np.all(np.isfinite(value)):
            raise ConstraintError(f"{self.describe()}: the control law must return {self.m} finite "
                                  f"number(s) (got {value.tolist()} at t = {t:g})")
        return value

    def advance(self, q0, q1, v0, v1, h, t0, t1):
        """The law's state at t_{n+1} (a stateful law), from the accepted step."""
        if self.stateful:
            qm, vm = 0.5 * (q0 + q1), 0.5 * (v0 + v1)
            xi, rate = self.xi(qm), self.G(qm) @ vm
            self.law.advance(0.5 * (t0 + t1), xi[0] if self.m == 1 else xi, rate[0] if self.m == 1 else rate, h)

    def bind(self, *args, **kwargs):
        super().bind(*args, **kwargs)
        self.u(0.0, self.xi(self.q_initial), np.zeros(self.m))

    def observe(self, q1, v1, t1, q0, v0, t0):
        """`name.u1 ...`: the input of the last step (at its midpoint; at t = 0 the law at the state);
        read before the step is accepted, so a stateful law still has its state at t_n."""
        if q0 is None or t1 == t0:
            q, v, t, h = q1, v1, t1, 0.0
        else:
            q, v, t, h = 0.5 * (q0 + q1), 0.5 * (v0 + v1), 0.5 * (t0 + t1), t1 - t0
        u = self.u(t, self.xi(q), self.G(q) @ v, h)
        return {f"{self.name}.u{i + 1}": float(x) for i, x in enumerate(u)}

    def at_rest(self, q, t=0.0):
        G, xi = self.G(q), self.xi(q)
        u = self.u(t, xi, np.zeros(self.m))
        du = _differences(lambda x: self.u(t, x, np.zeros(self.m)), xi, 1e-7)
        return -G.T @ u, -(np.einsum("k,kij->ij", u, self.Q) + G.T @ du @ G)

    def linear(self, q, v, t=0.0):
        """The linear model's terms at (q, v), time t (rodfem/analysis/linearize.py): the force
        r_v = -G^T u(t, xi, xi'), dr_v/dq = -(sum_k u_k Q_k + G^T (du/dxi) G + G^T (du/dxi') d(G v)/dq),
        dr_v/dv = -G^T (du/dxi') G, with du/dxi and du/dxi' by the fourth-order stencil (steps
        1e-3 max(|.|, 1e-2)); and the law's stiffness K = -du/dxi and damping D = -du/dxi' (m x m).
        The law is a port-Hamiltonian (passive) element of the linear model when K is symmetric (a
        virtual spring) and D + D^T >= 0 (damping injection; its skew part is gyroscopic); any other
        law enters A all the same, but then A is not (J - R) Q with R >= 0 and E^T Q symmetric."""
        G, xi = self.G(q), self.xi(q)
        rate = G @ v
        u = self.u(t, xi, rate)
        du_dxi = _five_point(lambda x: self.u(t, x, rate), xi, 1e-2)
        du_drate = _five_point(lambda r: self.u(t, xi, r), rate, 1e-2)
        dq = -(np.einsum("k,kij->ij", u, self.Q) + G.T @ du_dxi @ G
               + G.T @ du_drate @ np.einsum("kij,j->ki", self.Q, v))
        return {"force": -G.T @ u, "dq": dq, "dv": -G.T @ du_drate @ G, "hessian": None,
                "stiffness": -du_dxi, "damping": -du_drate}

    def step(self, q0, q1, v0, v1, h, t0, t1):
        qm, vm, tm = 0.5 * (q0 + q1), 0.5 * (v0 + v1), 0.5 * (t0 + t1)
        Gm = self.G(qm)
        xim, rate = self.xi(qm), Gm @ vm
        u = self.u(tm, xim, rate, h)
        du_dxi = _differences(lambda x: self.u(tm, x, rate, h), xim, 1e-7)
        du_drate = _differences(lambda r: self.u(tm, xim, r, h), rate, 1e-7)
        drate_dq = 0.5 * np.einsum("kij,j->ki", self.Q, vm)
        r_v = -Gm.T @ u
        dr_dq = -(0.5 * np.einsum("k,kij->ij", u, self.Q) + Gm.T @ (0.5 * du_dxi @ Gm + du_drate @ drate_dq))
        dr_dv = -Gm.T @ (0.5 * du_drate @ Gm)
        return r_v, dr_dq, dr_dv, h * float(u @ rate), 0.0


class Dissipator(Component):
    """A nonlinear resistance (see the module docstring): the force G(q_m)^T f(xi_m, xi'_m),
    dissipating h xi'_m . f >= 0.  `law(xi, rate)` returns m numbers (Newton's matrix takes its
    derivatives by central differences); `columns(xi, rate, f)` (optional) names history columns."""
    dissipative = True

    def __init__(self, measure: Callable, law: Callable, a: Point, b: Point, name: str, columns=None):
        super().__init__(measure, a, b, name)
        self.law, self.columns = law, columns

    def bind(self, *args, **kwargs):
        super().bind(*args, **kwargs)
        self.force(self.xi(self.q_initial), np.zeros(self.m))

    def force(self, xi, rate) -> np.ndarray:
        value = self.law(xi[0] if self.m == 1 else xi, rate[0] if self.m == 1 else rate)
        value = np.atleast_1d(np.asarray(value, dtype=float))
        if value.shape != (self.m,) or not np.all(np.isfinite(value)):
            raise ConstraintError(f"{self.describe()}: the resistance law must return {self.m} finite "
                                  f"number(s) (got {value.tolist()})")
        return value

    def observe(self, q1, v1, t1, q0, v0, t0):
        """`name.f1 ...` (or the law's `columns`): its force at the state (q1, v1)."""
        xi, rate = self.xi(q1), self.G(q1) @ v1
        f = self.force(xi, rate)
        if self.columns is not None:
            return {f"{self.name}.{k}": float(v) for k, v in self.columns(xi, rate, f).items()}
        return {f"{self.name}.f{i + 1}": float(x) for i, x in enumerate(f)}

    def at_rest(self, q, t=0.0):
        """Statics: the force at rest, f(xi, 0) (zero for friction)."""
        G, xi = self.G(q), self.xi(q)
        f = self.force(xi, np.zeros(self.m))
        df = _differences(lambda x: self.force(x, np.zeros(self.m)), xi, 1e-7)
        return G.T @ f, np.einsum("k,kij->ij", f, self.Q) + G.T @ df @ G

    def linear(self, q, v, t=0.0):
        """The linear model's terms at (q, v): r_v = G^T f, dr_v/dv = G^T (df/drate) G (its part of R),
        dr_v/dq = sum_k f_k Q_k + G^T (df/dxi) G + G^T (df/drate) d(G v)/dq."""
        G, xi = self.G(q), self.xi(q)
        rate = G @ v
        f = self.force(xi, rate)
        df_dxi = _five_point(lambda x: self.force(x, rate), xi, 1e-2)
        df_drate = _five_point(lambda r: self.force(xi, r), rate, 1e-2)
        dq = (np.einsum("k,kij->ij", f, self.Q) + G.T @ df_dxi @ G
              + G.T @ df_drate @ np.einsum("kij,j->ki", self.Q, v))
        return {"force": G.T @ f, "dq": dq, "dv": G.T @ df_drate @ G, "hessian": None}

    def step(self, q0, q1, v0, v1, h, t0, t1):
        qm, vm = 0.5 * (q0 + q1), 0.5 * (v0 + v1)
        Gm = self.G(qm)
        xim, rate = self.xi(qm), Gm @ vm
        f = self.force(xim, rate)
        power = float(f @ rate)
        if power < -1e-12 * max(float(np.linalg.norm(f) * np.linalg.norm(rate)), 1e-300):
            raise ConstraintError(f"{self.describe()}: its law supplies energy (rate . f = {power:.3g} < 0); "
                                  "a resistance must satisfy rate . f >= 0")
        df_dxi = _differences(lambda x: self.force(x, rate), xim, 1e-7)
        df_drate = _differences(lambda r: self.force(xim, r), rate, 1e-7)
        drate_dq = 0.5 * np.einsum("kij,j->ki", self.Q, vm)
        r_v = Gm.T @ f
        dr_dq = 0.5 * np.einsum("k,kij->ij", f, self.Q) + Gm.T @ (0.5 * df_dxi @ Gm + df_drate @ drate_dq)
        dr_dv = Gm.T @ (0.5 * df_drate @ Gm)
        return r_v, dr_dq, dr_dv, 0.0, h * max(power, 0.0)


def _symmetric(H):
    return 0.5 * (H + H.T)


def _five_point(f, x, floor):
    """The Jacobian of f at x by the fourth-order central stencil, steps 1e-3 max(|x|_inf, floor)
    (the linear model: truncation ~ 1e-12 of a function that varies on the scale of |x|)."""
    x = np.asarray(x, dtype=float)
    step = 1e-3 * max(float(np.max(np.abs(x))) if x.size else 0.0, floor)
    f0 = np.atleast_1d(f(x))
    J = np.zeros((len(f0), len(x)))
    for j in range(len(x)):
        e = np.zeros(len(x))
        e[j] = step
        J[:, j] = (8 * (np.atleast_1d(f(x + e)) - np.atleast_1d(f(x - e)))
                   - (np.atleast_1d(f(x + 2 * e)) - np.atleast_1d(f(x - 2 * e)))) / (12 * step)
    return J


def _differences(f, x, relative):
    """The Jacobian of f at x by central differences (steps `relative` max(1, |x_j|))."""
    x = np.asarray(x, dtype=float)
    f0 = np.atleast_1d(f(x))
    J = np.zeros((len(f0), len(x)))
    for j in range(len(x)):
        step = relative * max(1.0, abs(x[j]))
        e = np.zeros(len(x))
        e[j] = step
        J[:, j] = (np.atleast_1d(f(x + e)) - np.atleast_1d(f(x - e))) / (2 * step)
    return J


@dataclass(frozen=True)
class Law:
    """What forms/components.py writes: a measure and its energy psi ('potential'), damping
    coefficient eta ('resistance') or control law u ('feedback'); `System.connect(law, a, b)`
    places it between two points.  `timed`: psi(xi, t)."""
    kind: str
    measure: Callable
    value: object
    label: str
    timed: bool = False
    columns: Optional[Callable] = None

    def between(self, a: Point, b: Point, name: str) -> Component:
        if self.kind == "potential":
            component = Potential(self.measure, self.value, a, b, name, self.timed)
            component.columns = self.columns
            return component
        if self.kind == "dissipator":
            return Dissipator(self.measure, self.value, a, b, name, self.columns)
        return (Resistance if self.kind == "resistance" else Feedback)(self.measure, self.value, a, b, name)


def potential(measure: Callable, energy: Callable, label: str = "potential", timed: bool = False,
              columns: Optional[Callable] = None) -> Law:
    """Stored energy psi(xi) (or psi(xi, t) if `timed`) of the quadratic measure xi(a, b, a0, b0);
    `columns(xi, psi'(xi))` -> dict: history columns of its own (name.column)."""
    return Law("potential", measure, energy, label, timed, columns)


def dissipator(measure: Callable, law: Callable, label: str = "resistance", columns: Optional[Callable] = None) -> Law:
    """A nonlinear resistance: the force f = law(xi, xi') along the quadratic measure, with xi' . f >= 0;
    `columns(xi, rate, f)` -> dict: its history columns (default name.f1, ...)."""
    return Law("dissipator", measure, law, label, False, columns)


def resistance(measure: Callable, coefficient: Union[float, Callable], label: str = "damper") -> Law:
    """A damper on the rate of the quadratic measure xi(a, b, a0, b0), with the coefficient eta
    (a number, or a function eta(xi) of the measure at the step's midpoint)."""
    return Law("resistance", measure, coefficient, label)


def feedback(measure: Callable, law: Callable, label: str = "control") -> Law:
    """A control law u = law(t, xi, xi') acting along the quadratic measure xi(a, b, a0, b0)."""
    return Law("feedback", measure, law, label)
