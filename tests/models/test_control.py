"""Controllers at a port (forms/components.py): PD as a virtual spring and damper against the Cayley
recurrence of J theta'' + kd theta' + kp (theta - r) = 0, against the same law written in Python,
and passivity of the closed loop with the flexible arm (robot-arm-control)."""
import numpy as np
import pytest
from mpi4py import MPI
from processes import assert_same_history, serial_and_parallel

from rodfem import Load, System, run
from rodfem.app.scene import load
from rodfem.core.joints import ground
from rodfem.forms import joints
from rodfem.forms.components import control_law, pd_control, pid_control, rest_to_rest
from rodfem.forms.rigid_body import PlanarRigidBody

TIGHT = {"snes_atol": 1e-12, "snes_rtol": 1e-14}


def column(result, name):
    return np.array([row[name] for row in result.rows])


def pd_wheel(controller, rule, kp, kd, target):
    s = System(integrator=rule, newton_options=TIGHT)
    wheel = s.add("wheel", PlanarRigidBody(2.0, 0.4), initial=PlanarRigidBody.initial((0.0, 0.0), omega=0.5))
    s.join(joints.pin, ground((0.0, 0.0)), wheel.point())
    if controller == "pd":
        s.connect(pd_control(kp, kd, target), ground((0.0, 0.0)), wheel.point(), name="hub")
    else:
        s.connect(control_law(lambda t, th, om: -kp * (th - target) - kd * om), ground((0.0, 0.0)), wheel.point(),
                  name="hub")
    return s


@pytest.mark.parametrize("controller", ["pd", "law"])
@pytest.mark.parametrize("rule", ["midpoint", "discrete-gradient"])
def test_pd_on_a_wheel_follows_the_recurrence(controller, rule):
    """A wheel (J = 0.4) pinned at its centre, PD towards theta* = 1 from rest-ish (omega0 = 0.5):
    e = theta - theta* obeys J e'' + kd e' + kp e = 0, whose midpoint discretization is the Cayley
    map of [[0, 1], [-kp/J, -kd/J]] -- both as components and as a Python law, to round-off.  The
    PD's stored energy is kp/2 e^2 (`hub_P.V`), its dissipation sum h kd omega_m^2."""
    J, kp, kd, h, n = 0.4, 6.0, 0.9, 0.05, 80
    s = pd_wheel(controller, rule, kp, kd, 1.0)
    result = run(s, h, n * h)
    A = np.array([[0.0, 1.0], [-kp / J, -kd / J]])
    M = np.linalg.solve(np.eye(2) - 0.5 * h * A, np.eye(2) + 0.5 * h * A)
    z, lost = np.array([-1.0, 0.5]), 0.0
    for _ in range(n):
        z1 = M @ z
        lost += h * kd * (0.5 * (z[1] + z1[1])) ** 2
        z = z1
    body = s.body("wheel")
    assert body.space.nodal(body.x0, "phi")[1].item() - 1.0 == pytest.approx(z[0], abs=1e-12)
    assert body.space.nodal(body.x0, "omega")[1].item() == pytest.approx(z[1], abs=1e-12)
    if controller == "pd":
        assert column(result, "hub_P.V")[-1] == pytest.approx(0.5 * kp * z[0] ** 2, abs=1e-12)
        assert column(result, "dissipated")[-1] == pytest.approx(lost, rel=1e-10)
        assert np.all(np.diff(column(result, "H")) <= 1e-14)      # passive: the closed loop only loses energy
    else:   # the law's work is the supplied energy: H (the wheel's only) - supplied is constant
        assert column(result, "supplied")[-1] == pytest.approx(column(result, "H")[-1] - column(result, "H")[0],
                                                               abs=1e-12)
        assert column(result, "hub.u1")[-1] == pytest.approx(-kp * z[0] - kd * z[1], abs=0.2 * kp * h)


def arm(controller, t_end=4.0, **extra):
    scene = load("robot-arm-control")
    p = scene.values({"controller": controller, "t_end": t_end, **extra})
    system = scene.build(p, MPI.COMM_WORLD)
    return run(system, p["dt"], p["t_end"]), p


def test_robot_arm_reaches_the_set_angle_and_stops_vibrating():
    """PD at the hub of the flexible arm: the balance (arm + virtual spring) - supplied + dissipated is
    exact every step; after the set point rests (t >= t_move) the closed loop's energy decreases
    monotonically; the tip settles at the set angle (|error| <= 1e-2 rad for t >= 3 s: measured
    7.3e-3) and its vibration decays (max tip deflection on [3, 4] <= a third of that on [2, 3])."""
    result, p = arm("pd")
    t, H = column(result, "t"), column(result, "H")
    assert np.max(np.abs(column(result, "balance_error"))) <= 1e-12 * np.max(H)
    resting = t >= p["t_move"]
    assert np.all(np.diff(H[resting]) <= 1e-14)
    assert np.all(np.diff(column(result, "dissipated")) >= 0)
    error = np.abs(column(result, "tip_angle") - p["angle"])
    deflection = np.abs(column(result, "tip_deflection"))
    assert np.max(error[t >= 3.0]) <= 1e-2
    late, earlier = np.max(deflection[t >= 3.0]), np.max(deflection[(t >= 2.0) & (t < 3.0)])
    assert late <= earlier / 3 and late <= 1e-2, (late, earlier)


def test_robot_arm_pd_equals_the_same_law_in_python():
    """The virtual spring and damper and the plain Python law u = -kp (phi - r(t)) - kd omega are two
    implementations of one controller: the same motion to round-off; the plant's energy H - V_P of
    the one is the other's H; the law's work is the PD's (spring + damper) work on the arm."""
    pd, _ = arm("pd", t_end=2.0)
    law, _ = arm("law", t_end=2.0)
    for c in ("tip_x", "tip_y", "hub_angle"):
        assert np.max(np.abs(column(pd, c) - column(law, c))) <= 1e-10, c
    plant = column(pd, "H") - column(pd, "hub_P.V")
    assert np.max(np.abs(plant - column(law, "H"))) <= 1e-10
    assert np.max(np.abs(column(law, "balance_error"))) <= 1e-12


def test_rest_to_rest_profile():
    r = rest_to_rest(0.5, 2.0, 1.0, 3.0)
    assert r(0.0) == 0.5 and r(1.0) == 0.5 and r(3.0) == 2.0 and r(9.0) == 2.0
    assert r(2.0) == pytest.approx(1.25)
    eps = 1e-6
    for t in (1.0 + eps, 3.0 - eps):     # at rest at both ends: slope and curvature vanish
        assert abs(r(t) - r(t - eps)) / eps <= 1e-4


@pytest.mark.mpi
@pytest.mark.parametrize("scene, args", [
    ("robot-arm-control", ["--set", "n_elements=8", "--set", "t_end=0.5", "--set", "frames=2"]),
    ("four-particle", ["--set", "t_end=1.0", "--set", "frames=2"]),
    ("spring-damper-chain", ["--set", "n_bodies=3", "--set", "t_end=0.2", "--set", "frames=2"]),
    ("crane-inverse", ["--set", "t_end=0.5", "--set", "frames=2"]),
], ids=["robot-arm-control", "four-particle", "spring-damper-chain", "crane-inverse"])
def test_mpi_two_ranks_match_serial(tmp_path, scene, args):
    """Components, controllers and servo constraints under mpirun -n 2 (the arm split over the ranks,
    the points of the hub on one of them; the particles and boxes shared out) give the serial history."""
    serial, parallel, _ = serial_and_parallel(tmp_path, ["run", scene, *args])
    assert_same_history(serial, parallel, rtol=1e-9)


@pytest.mark.parametrize("ki", [0.0, 4.0], ids=["pd", "pid"])
def test_pid_rejects_a_constant_disturbance_by_the_recurrence(ki):
    """A wheel held at theta* = 0.3 against a constant disturbance moment M by PID: the midpoint
    recurrence of J w' = -kp e - ki z - kd w + M, theta' = w, z' = e (linear: one 3x3 solve a step)
    to round-off; at the end PID has removed the offset (|e| <= 1e-3) while PD (ki = 0) keeps the
    offset M / kp."""
    J, kp, kd, M, target, h, n = 0.4, 6.0, 1.5, 0.9, 0.3, 0.05, 400
    s = System(newton_options=TIGHT)
    wheel = s.add("wheel", PlanarRigidBody(2.0, J), initial=PlanarRigidBody.initial((0.0, 0.0)),
                  loads=[Load("omega", M, "domain", "disturbance")])
    s.join(joints.pin, ground((0.0, 0.0)), wheel.point())
    s.connect(pid_control(kp, ki, kd, target), ground((0.0, 0.0)), wheel.point(), name="hub")
    result = run(s, h, n * h)
    # [theta, w, z]_{n+1}: A1 x1 = A0 x0 + c, from the three midpoint equations
    # (z_{n+1/2} = z_n + h/2 e_m = (z_n + z_{n+1})/2)
    A1 = np.array([[1.0, -h / 2, 0.0], [h / 2 * kp, J + h / 2 * kd, h / 2 * ki], [-h / 2, 0.0, 1.0]])
    A0 = np.array([[1.0, h / 2, 0.0], [-h / 2 * kp, J - h / 2 * kd, -h / 2 * ki], [h / 2, 0.0, 1.0]])
    c = np.array([0.0, h * (M + kp * target), -h * target])
    x = np.zeros(3)
    for _ in range(n):
        x = np.linalg.solve(A1, A0 @ x + c)
    body = s.body("wheel")
    theta = body.space.nodal(body.x0, "phi")[1].item()
    assert theta == pytest.approx(x[0], abs=1e-11)
    assert s.components[0].law.state[0] == pytest.approx(x[2], abs=1e-11)
    if ki:
        assert abs(theta - target) <= 1e-3
    else:
        assert theta - target == pytest.approx(M / kp, rel=1e-6)
    assert np.max(np.abs(column(result, "balance_error"))) <= 1e-12
