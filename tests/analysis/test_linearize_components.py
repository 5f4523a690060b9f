"""The linear model of systems with components (springs, dampers, control laws; rodfem/core/components.py)
against answers derived by hand, not by rodfem:

* a taut chain of point masses on springs between two ground points: its longitudinal and
  transverse frequencies are those of the discrete chain, omega_j = 2 sqrt(K / m) sin(j pi / (2 (n + 1))),
  with K the springs' axial stiffness d^2 V / dl^2 longitudinally and K_t = T / l transversally (a
  transverse offset w lengthens a spring of length l to sqrt(l^2 + w^2) = l + w^2 / (2 l) + ...,
  so V grows by T w^2 / (2 l), T = dV/dl the tension: the geometric stiffness of the pre-stress);
* a point mass on a spring and a damper to the ground: m s^2 + c s + k = 0 along the spring and
  m s^2 + c s + T / l = 0 across it;
* a pinned wheel under PD control (a virtual spring and damper, or the same law in Python):
  J s^2 + kd s + kp = 0; a law that feeds energy in (negative damping, a circulatory stiffness) is
  reported as not passive and still linearized exactly;
* the spring-damper-chain scene (`rodfem modes`): the vertical bounce of the column of boxes is a
  chain of masses m on the four corner springs of each gap, K = 4 k, and its twist is held by
  the springs' tensions alone.
"""
import json

import numpy as np
import pytest
import scipy.linalg as sl

from rodfem import System
from rodfem.analysis.linearize import Linearization, natural_modes
from rodfem.analysis.statics import Statics
from rodfem.core.joints import ground
from rodfem.forms import joints
from rodfem.forms.components import control_law, damper, feedback, hookean, pd_control, quartic, separation, spring
from rodfem.forms.rigid_body import PlanarRigidBody, PointMass


def eigenvalues(lin, pencil="rate"):
    """The finite eigenvalues of the linear model E x' = A x ('rate'), or of the pencil of modes
    (A_modes, E_modes: constraints on position level, 'modes'), by dense QZ, sorted by imaginary part."""
    A, E = (lin.A, lin.E) if pencil == "rate" else (lin.Am, lin.Em)
    s = sl.eig(A.toarray(), E.toarray(), right=False)
    s = s[np.isfinite(s) & (np.abs(s) < 1e8)]
    return s[np.lexsort((s.real, s.imag))]


def nearest(s, exact):
    """For each exact eigenvalue, the relative distance to the nearest computed one."""
    return np.array([np.min(np.abs(s - e)) / abs(e) for e in exact])


def from_modes(lin, omega):
    """The eigenvalues s = -zeta |s| + i omega of natural_modes."""
    return -lin.damping * omega / np.sqrt(1 - lin.damping**2) + 1j * omega


# -- (1) the taut chain --------------------------------------------------------------------------

LAWS = {   # energy of the squared length c, the axial stiffness d^2V/dl^2 and the tension dV/dl at length l
    "hookean": (hookean, lambda k, l0, l: k, lambda k, l0, l: k * (l - l0)),
    "quartic": (quartic, lambda k, l0, l: 2 * k * (l**2 - l0**2) + 4 * k * l**2, lambda k, l0, l: 2 * k * l * (l**2 - l0**2)),
}


def taut_chain(n, m, k, l0, l, law):
    s = System()
    masses = [s.add(f"m{i + 1}", PointMass(m, dim=2), initial=PointMass.initial([(i + 1) * l, 0.0])) for i in range(n)]
    points = [ground((0.0, 0.0))] + [p.point() for p in masses] + [ground(((n + 1) * l, 0.0))]
    for i in range(n + 1):
        s.connect(spring(LAWS[law][0](k, l0)), points[i], points[i + 1], name=f"spring{i}")
    return s


@pytest.mark.parametrize("law", ["hookean", "quartic"])
def test_taut_chain_frequencies(law):
    """n = 6 masses, stretched 25 %: all 2 n frequencies (6 longitudinal, 6 transverse) to 1e-10,
    in a model that is port-Hamiltonian (J skew, R = 0, E^T Q symmetric and >= 0: in tension)."""
    n, m, k, l0, l = 6, 0.7, 40.0, 0.8, 1.0
    s = taut_chain(n, m, k, l0, l, law)
    lin = Linearization(s)
    omega, _, _ = natural_modes(lin, 2 * n, "dense")
    K, T = LAWS[law][1](k, l0, l), LAWS[law][2](k, l0, l)
    j = np.arange(1, n + 1)
    shape = 2 * np.sin(j * np.pi / (2 * (n + 1)))
    exact = np.sort(np.concatenate([shape * np.sqrt(K / m), shape * np.sqrt(T / l / m)]))
    assert len(omega) == 2 * n
    assert np.max(np.abs(np.sort(omega) / exact - 1)) <= 1e-10, (np.sort(omega), exact)
    assert np.max(np.abs(lin.f0)) <= 1e-12 * K * l                    # an equilibrium
    assert lin.checks["ph_residual"] <= 1e-12 and lin.checks["R_norm"] == 0.0 and lin.checks["passive"]
    EQ = (lin.E.T @ lin.Q).toarray()
    assert np.max(np.abs(EQ - EQ.T)) <= 1e-10 * np.max(np.abs(EQ))
    assert np.min(np.linalg.eigvalsh(0.5 * (EQ + EQ.T))) > 0
    # Hess: the springs' energy; on the positions it is the stiffness matrix (the chain's tridiagonal)
    x = [i for i, st in enumerate(lin.states) if st[3] == "position"]
    assert np.allclose(lin.Hess.toarray()[np.ix_(x, x)], lin.Q.toarray()[np.ix_(x, x)], rtol=0, atol=1e-10 * K)


def test_slack_geometric_stiffness_is_what_makes_the_transverse_modes():
    """The same chain at its rest length (T = 0): the transverse stiffness vanishes, only the n
    longitudinal modes oscillate (the geometric stiffness is the only transverse stiffness)."""
    n, m, k, l0 = 4, 1.0, 10.0, 1.0
    lin = Linearization(taut_chain(n, m, k, l0, l0, "hookean"))
    omega, _, _ = natural_modes(lin, 2 * n, "dense")
    j = np.arange(1, n + 1)
    assert np.allclose(np.sort(omega), 2 * np.sqrt(k / m) * np.sin(j * np.pi / (2 * (n + 1))), rtol=1e-10)


# -- (2) the damped mass-spring -----------------------------------------------------------------

def test_damped_mass_spring_eigenvalues():
    """A 2D point mass on a pre-stretched linear spring and a damper to the ground: the linear model's
    eigenvalues are the roots of m s^2 + c s + k (along) and m s^2 + c s + T/l (across), and the damper
    is R = c on the velocities (symmetric, >= 0)."""
    m, k, c, l0, l = 2.0, 50.0, 1.5, 0.8, 1.0
    s = System()
    a = s.add("a", PointMass(m, dim=2), initial=PointMass.initial([l, 0.0]))
    s.connect(spring(hookean(k, l0)), ground((0.0, 0.0)), a.point())
    s.connect(damper(c), ground((0.0, 0.0)), a.point())
    lin = Linearization(s)
    exact = np.concatenate([np.roots([m, c, k]), np.roots([m, c, k * (l - l0) / l])])
    got = eigenvalues(lin)
    assert len(got) == 4 and np.max(nearest(got, exact)) <= 1e-11, (got, exact)    # measured 8e-13
    omega, _, _ = natural_modes(lin, 2, "dense")
    upper = exact[exact.imag > 0]
    assert np.max(nearest(from_modes(lin, omega), upper)) <= 1e-11
    v = [i for i, st in enumerate(lin.states) if st[3] == "velocity"]
    assert np.allclose(lin.R.toarray()[np.ix_(v, v)], c * np.eye(2), rtol=0, atol=1e-14)
    assert lin.checks["ph_residual"] <= 1e-14 and lin.checks["passive"]


def test_state_dependent_damping_is_read_at_the_point():
    """eta(d) = 3 + |d|^2 at |d| = 1.2: the model is that of the constant c = 3 + 1.44."""
    m, k, l = 1.0, 20.0, 1.2
    s = System()
    a = s.add("a", PointMass(m, dim=2), initial=PointMass.initial([l, 0.0]))
    s.connect(spring(hookean(k, l)), ground((0.0, 0.0)), a.point())
    s.connect(damper(lambda d: 3.0 + d @ d), ground((0.0, 0.0)), a.point())
    got = eigenvalues(Linearization(s))
    c = 3.0 + l**2
    exact = np.concatenate([np.roots([m, c, k]), [0.0, -c / m]])
    assert np.max([np.min(np.abs(got - e)) for e in exact]) <= 1e-12 * k, (got, exact)


# -- (3, 4) PD control of a wheel -----------------------------------------------------------------

J_WHEEL, KP, KD = 0.4, 6.0, 0.9


def wheel(law, inertia=J_WHEEL):
    s = System()
    w = s.add("wheel", PlanarRigidBody(2.0, inertia), initial=PlanarRigidBody.initial((0.0, 0.0)))
    s.join(joints.pin, ground((0.0, 0.0)), w.point())
    s.connect(law, ground((0.0, 0.0)), w.point(), name="hub")
    return s


def pd_as_components(set_point=1.0):
    return pd_control(KP, KD, set_point)


def pd_in_python(set_point=1.0):
    r = set_point if callable(set_point) else (lambda t: set_point)
    return control_law(lambda t, th, om: -KP * (th - r(t)) - KD * om)


@pytest.mark.parametrize("controller", [pd_as_components, pd_in_python])
def test_pd_wheel_eigenvalues(controller):
    """About the set point theta* = 1 (statics): the eigenvalues are the roots of J s^2 + kd s + kp,
    the PD's spring and damper, or the same law in Python, alike.  The closed loop is passive
    (R = kd on omega, Q_phiphi = kp)."""
    s = wheel(controller())
    Statics(s).solve(t=0.0)
    assert s.body("wheel").space.nodal(s.body("wheel").x0, "phi")[1].item() == pytest.approx(1.0, abs=1e-12)
    lin = Linearization(s)
    exact = np.roots([J_WHEEL, KD, KP])
    got = eigenvalues(lin, "modes")
    assert len(got) == 2 and np.max(nearest(got, exact)) <= 1e-12, (got, exact)
    rate = eigenvalues(lin)       # and two zeros: the pin's rows on velocity level leave x(0) free
    assert len(rate) == 4 and np.max(nearest(rate, exact)) <= 1e-12 and np.sum(np.abs(rate) <= 1e-12) == 2, rate
    omega, _, _ = natural_modes(lin, 1, "dense")
    assert np.max(nearest(from_modes(lin, omega), exact[exact.imag > 0])) <= 1e-12
    assert lin.checks["passive"] and lin.checks["ph_residual"] <= 1e-12 and np.max(np.abs(lin.f0)) <= 1e-12
    w = [i for i, st in enumerate(lin.states) if st[0] == "wheel.omega"]
    p = [i for i, st in enumerate(lin.states) if st[0] == "wheel.phi"]
    assert lin.R.toarray()[w[0], w[0]] == pytest.approx(KD, rel=1e-12)
    assert lin.Q.toarray()[p[0], p[0]] == pytest.approx(KP, rel=1e-10)
    if controller is pd_in_python:
        assert lin.feedback["hub"]["passive"] and lin.feedback["hub"]["stiffness"] == [[pytest.approx(KP, rel=1e-12)]]


@pytest.mark.parametrize("controller", [pd_as_components, pd_in_python])
def test_a_moving_set_point_is_read_at_the_linearization_time(controller):
    """r(t) = 0.1 t, the wheel at rest at theta = 0, linearized at t = 2: the drift f0 is the PD's
    torque kp r(2) on the omega row (J omega' = kp (r - theta)); about the statics at t = 2 the
    wheel rests at r(2) = 0.2 and f0 = 0."""
    s = wheel(controller(lambda t: 0.1 * t))
    lin = Linearization(s, t=2.0)
    w = [i for i, st in enumerate(lin.states) if st[0] == "wheel.omega"]
    assert lin.f0[w[0]] == pytest.approx(KP * 0.2, rel=1e-12)
    assert np.max(np.abs(np.delete(lin.f0, w))) == 0.0
    s = wheel(controller(lambda t: 0.1 * t))
    Statics(s).solve(t=2.0)
    lin = Linearization(s)              # the time of the static solve
    assert lin.t == 2.0 and np.max(np.abs(lin.f0)) <= 1e-9 * KP * 0.2        # (static Newton's tolerance)
    assert s.body("wheel").space.nodal(s.body("wheel").x0, "phi")[1].item() == pytest.approx(0.2, abs=1e-10)


def test_a_law_that_feeds_energy_in_is_not_passive():
    """u = -kp theta + kd theta' (negative damping): the roots of J s^2 - kd s + kp (unstable), and the
    checks say that the law is not passive (R has a negative entry: A is not (J - R) Q with R >= 0)."""
    s = wheel(control_law(lambda t, th, om: -KP * th + KD * om))
    lin = Linearization(s)
    got = eigenvalues(lin, "modes")
    exact = np.roots([J_WHEEL, -KD, KP])
    assert np.max(nearest(got, exact)) <= 1e-12 and np.all(got.real > 0)
    assert not lin.checks["passive"] and lin.checks["not_passive"] == ["hub"]
    assert lin.feedback["hub"]["damping_lowest_eigenvalue"] == pytest.approx(-KD, rel=1e-12)
    assert np.min(np.linalg.eigvalsh(lin.R.toarray())) == pytest.approx(-KD, rel=1e-12)


def test_a_circulatory_law_is_linearized_and_flagged():
    """A 2D point mass held at its set point by u = -K d - D d' with a non-symmetric K (a follower-
    like, circulatory stiffness): the eigenvalues are those of m s^2 + D s + K = 0 (the companion
    matrix), and the law is reported as not passive (E^T Q is not symmetric)."""
    m = 1.5
    K = np.array([[8.0, 3.0], [-1.0, 5.0]])
    D = np.array([[0.4, 0.0], [0.0, 0.2]])
    x0 = np.array([1.0, 0.5])
    s = System()
    a = s.add("a", PointMass(m, dim=2), initial=PointMass.initial(x0))
    s.connect(feedback(separation, lambda t, d, dd: -K @ (d - x0) - D @ dd), ground((0.0, 0.0)), a.point(), name="hold")
    lin = Linearization(s)
    companion = np.block([[np.zeros((2, 2)), np.eye(2)], [-K / m, -D / m]])
    exact = np.linalg.eigvals(companion)
    got = eigenvalues(lin)
    assert len(got) == 4 and np.max(nearest(got, exact)) <= 1e-12, (got, exact)
    assert not lin.checks["passive"] and lin.checks["EtQ_asymmetry"] > 0.1
    assert lin.feedback["hold"]["stiffness_asymmetry"] == pytest.approx(4.0 / 8.0, rel=1e-10)


# -- the spring-damper-chain scene through `rodfem modes` -------------------------------------------

def test_cli_modes_of_the_spring_chain_scene_have_the_vertical_bounce(tmp_path, rodfem):
    """Two boxes (m = 1) hanging in the column of linear springs (k = 100 at each of the 4 corners,
    vertical), about the static equilibrium under gravity: the vertical modes are those of the
    chain of 2 masses on K = 4 k (a vertical linear spring's axial stiffness is k whatever its
    stretch), omega = 2 sqrt(4 k / m) sin(j pi / 6) = 20, 20 sqrt(3); the dashpots (c = 0.5 each,
    along the springs) make them the roots of m s^2 + 4 c mu_j s + 4 k mu_j, mu_j = 4 sin^2(j pi / 6)."""
    out = tmp_path / "modes"
    p = rodfem("modes", "spring-damper-chain", "--set", "n_bodies=2", "--count", "12", "--out", str(out))
    assert p.returncode == 0, p.stderr[-2000:]
    info = json.loads((out / "modes.json").read_text())
    omega, zeta = np.array(info["omega_rad_s"]), np.array(info["damping_ratio"])
    s = -zeta * omega / np.sqrt(1 - zeta**2) + 1j * omega
    m, k, c = 1.0, 100.0, 0.5
    mu = 4 * np.sin(np.arange(1, 3) * np.pi / 6) ** 2
    exact = [r for mj in mu for r in np.roots([m, 4 * c * mj, 4 * k * mj]) if r.imag > 0]
    assert np.max(nearest(s, exact)) <= 1e-10, (s, exact)
    # the twist about z: undamped (the dashpots are along the springs), stiffened only by the springs'
    # tensions T_g: a corner at radius r moves r theta across its spring, V = 4 T_g / (2 l_g) (r theta)^2
    # per gap.  Statics by hand: u_i the boxes' drops, mg - K u1 + K (u2 - u1) = 0 = mg - K (u2 - u1) - K u2
    a, g, l0 = 0.4, 9.81, 0.3
    length = 1.2 * l0
    K = 4 * k
    u = np.linalg.solve([[2 * K, -K], [-K, 2 * K]], [m * g, m * g])
    gaps = length + np.array([u[0], u[1] - u[0], -u[1]])
    kappa = 4 * (k * (gaps - l0) / gaps) * (a**2 / 2)
    stiffness = np.array([[kappa[0] + kappa[1], -kappa[1]], [-kappa[1], kappa[1] + kappa[2]]])
    twist = np.sqrt(np.linalg.eigvalsh(stiffness) / (m * 2 * a**2 / 12))
    assert np.max(nearest(s, 1j * twist)) <= 1e-10, (s, twist)
