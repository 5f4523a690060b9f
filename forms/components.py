"""Springs and dampers between two points: their measures, energies and damping laws.

A component (rodfem/core/components.py) is a MEASURE xi(a, b, a0, b0) of two points' frames
(`a.x` the position, `a.d` the directors, `a.phi` the angle; a0, b0 at t = 0), quadratic in
their coordinates like a joint's g (forms/joints.py), with either

* an energy psi(xi): a spring, V = psi(xi(q)); the discrete-gradient rule keeps
  H_{n+1} - H_n + dissipated = supplied exact for any psi, the midpoint rule only for a psi
  linear in xi (Kinon, Morandin, Schulze, arXiv 2505.18810, Sec. 4);
* a damping coefficient eta >= 0: a damper, force eta G^T G v, dissipated power eta |xi'|^2.

A spring's energy is written like a material (forms/string_materials.py): one function of the
squared length c = |x_b - x_a|^2, so its force stays along the line between the points.
A new spring law is a new function here; the engine needs nothing else.

    system.connect(spring(quartic(k=50.0, rest_length=1.0)), p1.point(), p3.point())
    system.connect(damper(1.0), p2.point(), p3.point())
"""
import numpy as np

from rodfem.core.components import feedback, potential, resistance

# -- measures (quadratic in the points' coordinates) -------------------------------------------

def squared_length(a, b, a0, b0):
    """c = |x_b - x_a|^2."""
    d = b.x - a.x
    return [d @ d]


def separation(a, b, a0, b0):
    """The relative position d = x_b - x_a (its rate: the relative velocity)."""
    return b.x - a.x


def relative_angle(a, b, a0, b0):
    """theta = (phi_b - phi_a) - (phi_b - phi_a)(0) of planar points."""
    return [(b.phi - a.phi) - (b0.phi - a0.phi)]


def misalignment(a, b, a0, b0):
    """mu = 3 - tr(C^T R_a^T R_b), C = R_a(0)^T R_b(0): 2 (1 - cos theta) for the rotation theta of b
    relative to a since t = 0 (3D points with directors; about theta^2 for small angles)."""
    C = a0.R.T @ b0.R
    return [3.0 - sum(C[i, j] * (a.d[i] @ b.d[j]) for i in range(3) for j in range(3))]


# -- energies of the squared length c ----------------------------------------------------------

def quartic(k, rest_length):
    """psi(c) = k/2 (c - l0^2)^2: the spring of Kinon, Morandin, Schulze's four-particle example
    (small-stretch stiffness 4 k l0^2).  Quadratic in c, so its discrete gradient in c is psi'(c_bar)
    at the mean c_bar = (c_n + c_{n+1})/2 -- but not psi'(c(q_m)), the midpoint rule's."""
    return lambda c: 0.5 * k * (c - rest_length**2) ** 2


def hookean(k, rest_length):
    """psi(c) = k/2 (sqrt(c) - l0)^2: the linear spring of stiffness k (non-polynomial in q)."""
    return lambda c: 0.5 * k * (np.sqrt(c) - rest_length) ** 2


def tension_only(k, rest_length):
    """psi(c) = k/2 max(sqrt(c) - l0, 0)^2: a cable that pulls but does not push (C^1)."""
    return lambda c: 0.5 * k * np.where(np.real(np.sqrt(c)) > rest_length, np.sqrt(c) - rest_length, 0.0) ** 2


# -- components --------------------------------------------------------------------------------

def spring(energy):
    """A spring between the two points with the energy psi(c) of the squared length c."""
    return potential(squared_length, energy, "spring")


def rotational_spring(energy):
    """A planar rotational spring with the energy psi(theta) of the relative angle."""
    return potential(relative_angle, energy, "rotational spring")


def torsional_spring(k):
    """A 3D rotational spring V = k/2 (3 - tr(C^T R_a^T R_b)) = k (1 - cos theta) (about k theta^2 / 2)."""
    return potential(misalignment, lambda mu: 0.5 * k * mu, "torsional spring")


def damper(eta):
    """A damper on the relative velocity, force eta (v_b - v_a); eta a number or a function
    eta(d) of the relative position d = x_b - x_a at the step's midpoint.  It resists every relative motion,
    a rigid rotation of the pair too (the four-particle example's damper); `dashpot` does not."""
    return resistance(separation, eta, "damper")


def dashpot(c):
    """A dashpot along the line between the points: force c (e . (v_b - v_a)) e, e = (x_b - x_a)/|x_b - x_a|
    (objective: a rigid rotation of the pair dissipates nothing).  As a damper on the rate of the
    squared length c2 = |x_b - x_a|^2, eta = c / (4 c2) at the step's midpoint."""
    return resistance(squared_length, lambda length2: c / (4.0 * length2), "dashpot")


def rotational_damper(eta):
    """A planar rotational damper on the relative angular velocity."""
    return resistance(relative_angle, eta, "rotational damper")


def length_dependent(eta0, alpha):
    """eta = eta0 (1 + alpha |x_b - x_a|^2) (the four-particle example's damper)."""
    return lambda d: eta0 * (1.0 + alpha * float(d @ d))


# -- controllers at a port (Ortega, van der Schaft, Maschke, Escobar, Automatica 38 (2002)) ------

def pd_control(kp, kd, set_point=0.0, measure=relative_angle):
    """PD control of the measure (default: the relative angle, e.g. a hub's angle to the ground)
    towards set_point (a number or a function of t): u = -kp (xi - r(t)) - kd xi'.  As a port-
    Hamiltonian controller it is a virtual spring psi = kp/2 (xi - r(t))^2 (energy shaping: the
    closed loop's energy has its minimum at the set point) and a damper kd (damping injection),
    exactly passive: with a constant set point the closed loop only loses energy; a moving set
    point supplies the work of the moving spring anchor (in `supplied`)."""
    r = set_point if callable(set_point) else (lambda t, value=float(set_point): value)
    spring_part = potential(measure, lambda xi, t: 0.5 * kp * (xi - r(t)) ** 2, "P", timed=True)
    return spring_part, resistance(measure, kd, "D")


def control_law(law, measure=relative_angle):
    """Any control law u = law(t, xi, xi') of the measure at the port (default: the relative angle,
    u a moment), read at the step's midpoint; its supplied work h u xi' is recorded."""
    return feedback(measure, law, "control")


def rest_to_rest(start, end, t0, t1):
    """A smooth set point from `start` at t0 to `end` at t1, at rest at both ends: the quintic
    r = start + (end - start) (10 s^3 - 15 s^4 + 6 s^5), s = (t - t0)/(t1 - t0) (zero velocity and
    acceleration at t0 and t1)."""
    def r(t):
        s = min(max((t - t0) / (t1 - t0), 0.0), 1.0) if t1 > t0 else 1.0
        return start + (end - start) * s**3 * (10 - 15 * s + 6 * s**2)
    return r


class PID:
    """PID control of the measure towards r(t): u = -kp e - ki z - kd xi', e = xi - r(t), z' = e (the
    derivative acts on the measurement, so a set-point step gives no kick).  The integral z is the
    controller's state; the midpoint rule gives z_{n+1} = z_n + h e_{n+1/2} and the input of a step
    uses z_{n+1/2} = z_n + h/2 e_{n+1/2}.  The integral action is not passive: its work is in
    `supplied`, and `state` (z) is kept in the checkpoint."""

    def __init__(self, kp, ki, kd, set_point=0.0):
        self.kp, self.ki, self.kd = float(kp), float(ki), float(kd)
        self.r = set_point if callable(set_point) else (lambda t, value=float(set_point): value)
        self.state = [0.0]

    def u(self, t, xi, rate, h):
        e = xi - self.r(t)
        return -self.kp * e - self.ki * (self.state[0] + 0.5 * h * e) - self.kd * rate

    def advance(self, t, xi, rate, h):
        self.state = [self.state[0] + h * (xi - self.r(t))]


def pid_control(kp, ki, kd, set_point=0.0, measure=relative_angle):
    """PID control at a port (default measure: the relative angle): `PID` as a control law."""
    return feedback(measure, PID(kp, ki, kd, set_point), "PID")
