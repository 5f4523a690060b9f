"""Servo constraints (rodfem/core/servo.py): inverse dynamics of two differentially flat cranes against
their closed forms, the open-loop replay of the computed inputs, the energy balance with the inputs'
work, and one-line errors for bad servos.

The oracles are the flatness parametrizations (Fliess, Levine, Martin, Rouchon; Blajer &
Kolodziejczyk's overhead crane): with the payload's path x_P(t) prescribed, its acceleration fixes
the rope force m (x_P'' + g e_z), hence the rope's direction e and everything else:

* rail crane (trolley of mass M on a rail at height 0 pushed by F, payload m hanging from a
  winch with the tension T): e = (x_P'' + g e_z)/|.|, T = m |x_P'' + g e_z|, the trolley where the
  rope meets the rail, x_T = x_P - z_P a_x/(a_z + g), and F = M x_T'' + m a_x;
* hoisting trolley (trolley M moved in space by the force F, payload on a rigid rope of length l):
  x_T = x_P + l e, F = M (x_T'' + g e_z) + m (x_P'' + g e_z).

Both are index-5 servo problems (the payload is reached only through the rope).
"""
import numpy as np
import pytest

from rodfem import GROUND, ConstraintError, Load, System, run
from rodfem.analysis.statics import Statics
from rodfem.core.servo import Transfer, along, smoothed, step_inputs, winch
from rodfem.errors import ParameterError
from rodfem.forms import joints
from rodfem.forms.components import control_law, squared_length
from rodfem.forms.rigid_body import PointMass

TIGHT = {"snes_atol": 1e-12, "snes_rtol": 1e-14}
g, l = 9.81, 1.0


def column(result, name):
    return np.array([row[name] for row in result.rows])


def points(system, M, m, dim, trolley_loads=()):
    """Trolley at the origin, payload l below it, both under gravity (and the trolley's extra loads)."""
    down = np.eye(dim)[-1]
    trolley = system.add("trolley", PointMass(M, dim), initial=PointMass.initial(np.zeros(dim)),
                         loads=[Load("v", -M * g * down, "domain", "gravity"), *trolley_loads])
    payload = system.add("payload", PointMass(m, dim), initial=PointMass.initial(-l * down),
                         loads=[Load("v", -m * g * down, "domain", "gravity")])
    system.marker("trolley", trolley.point())
    system.marker("payload", payload.point())
    return trolley.point(), payload.point()


# -- the rail crane (planar: x, z) -------------------------------------------------------------
RAIL = dict(M=2.0, m=0.5, path=Transfer((0.0, -l), (1.0, -l + 0.3), 0.0, 2.0))


def rail_crane(path=RAIL["path"], inputs=None):
    system = System(newton_options=TIGHT)
    trolley, payload = points(system, RAIL["M"], RAIL["m"], 2)
    system.join(joints.slider((1.0, 0.0)), GROUND, trolley, name="rail")
    system.servo(payload, path, inputs or [along((1.0, 0.0)).at(trolley), winch().between(trolley, payload)],
                 name="servo")
    return system


def rail_flat(path, t):
    """(x_T, F, T) of the rail crane at the times t (exact derivatives of the path)."""
    M, m = RAIL["M"], RAIL["m"]
    out = []
    for s in np.atleast_1d(t):
        (x, z), (_, vz), (ax, az), (jx, jz), (sx, sz) = (path(s, k) for k in range(5))
        # x_T = x - q, q = N/D with N = z a_x, D = a_z + g: q'' by the quotient rule
        N, N1, N2 = z * ax, vz * ax + z * jx, az * ax + 2 * vz * jx + z * sx
        D, D1, D2 = az + g, jz, sz
        q2 = (N2 * D**2 - 2 * N1 * D1 * D - N * D2 * D + 2 * N * D1**2) / D**3
        out.append((x - N / D, M * (ax - q2) + m * ax, m * np.hypot(ax, az + g)))
    return np.array(out).T


def test_rail_crane_against_flatness():
    """Trolley position, winch tension and trolley force of the rail crane converge to the flat
    solution at order 2 (h = 0.05, 0.025; measured x_T 6.4e-3 -> 1.6e-3, T 4.9e-3 -> 1.2e-3, F through
    the zero-phase filter 0.16 -> 0.041, of |F| <= 18.9 N); the payload sits on the path to Newton's
    tolerance (7.7e-11)."""
    errors = []
    for h in (0.05, 0.025):
        result = run(rail_crane(), h, 2.5)
        t = column(result, "t")
        x_T, _, _ = rail_flat(RAIL["path"], t)
        _, F, T = rail_flat(RAIL["path"], t[1:] - h / 2)    # the inputs of the steps: at their midpoints
        errors.append([np.max(np.abs(column(result, "trolley_x") - x_T)),
                       np.max(np.abs(column(result, "servo.u2")[1:] - T)),
                       np.max(np.abs(smoothed(column(result, "servo.u1")[1:]) - F))])
        assert np.max(column(result, "constraint_residual")) <= 1e-9
    coarse, fine = np.array(errors)
    assert np.all(fine <= [2e-3, 1.5e-3, 0.05]), fine
    assert np.all(coarse / fine >= 3.5), coarse / fine


# -- the hoisting trolley (3D, rigid rope) -----------------------------------------------------
HOIST = dict(M=1.0, m=0.5, path=Transfer((0.0, 0.0, -l), (0.8, 0.4, -l + 0.3), 0.0, 2.0))


def hoist_crane():
    system = System(newton_options=TIGHT)
    trolley, payload = points(system, HOIST["M"], HOIST["m"], 3)
    system.join(joints.distance, trolley, payload, name="rope")
    system.servo(payload, HOIST["path"], [along(e).at(trolley) for e in np.eye(3)], name="servo")
    return system


def hoist_flat(path, t):
    """(x_T, F) of the hoisting trolley at the times t: e = a/|a|, a = x_P'' + g e_z, and its
    derivatives e' = (a' - e n')/n, e'' = (a'' - 2 e' n' - e n'')/n with n = |a|."""
    M, m = HOIST["M"], HOIST["m"]
    up = np.array([0.0, 0.0, g])
    xs, Fs = [], []
    for s in np.atleast_1d(t):
        p, a, a1, a2 = path(s), path(s, 2) + up, path(s, 3), path(s, 4)
        n = np.linalg.norm(a)
        e = a / n
        n1 = e @ a1
        e1 = (a1 - e * n1) / n
        n2 = e1 @ a1 + e @ a2
        e2 = (a2 - 2 * e1 * n1 - e * n2) / n
        xs.append(p + l * e)
        Fs.append(M * (path(s, 2) + l * e2 + up) + m * a)
    return np.array(xs).T, np.array(Fs).T


def test_hoisting_trolley_against_flatness():
    """The 3D hoisting trolley on a rigid rope: trolley position and the three forces (through the
    zero-phase filter) converge at order 2 (measured x_T 5.2e-3 -> 1.3e-3, F 0.47 -> 0.12 of
    |F| <= 19.6 N); the payload sits on the path to Newton's tolerance."""
    errors = []
    for h in (0.05, 0.025):
        result = run(hoist_crane(), h, 2.5)
        t = column(result, "t")
        x_T, _ = hoist_flat(HOIST["path"], t)
        _, F = hoist_flat(HOIST["path"], t[1:] - h / 2)
        trolley = np.array([column(result, f"trolley_{c}") for c in "xyz"])
        forces = np.array([smoothed(column(result, f"servo.u{i}")[1:]) for i in (1, 2, 3)])
        errors.append([np.max(np.abs(trolley - x_T)), np.max(np.abs(forces - F))])
        assert np.max(column(result, "constraint_residual")) <= 1e-9
    coarse, fine = np.array(errors)
    assert np.all(fine <= [2e-3, 0.2]), fine
    assert np.all(coarse / fine >= 3.5), coarse / fine


# -- the open-loop replay and the energy ---------------------------------------------------------
def rail_replay(F, T):
    """The ordinary rail crane driven by the trolley force F(t) and the winch tension T(t) (a control
    law along the rope: force -T e on the payload, T e on the trolley)."""
    system = System(newton_options=TIGHT)
    push = Load("v", lambda t: np.array([F(t)[0], 0.0]), "domain", "trolley force")
    trolley, payload = points(system, RAIL["M"], RAIL["m"], 2, trolley_loads=[push])
    system.join(joints.slider((1.0, 0.0)), GROUND, trolley, name="rail")
    system.connect(control_law(lambda t, c, rate: -T(t)[1] / (2.0 * np.sqrt(c)), measure=squared_length),
                   trolley, payload, name="winch")
    return system


def test_replay_recovers_the_path_and_the_energy():
    """The inputs computed by the servo, fed back open loop with the same steps (held over each
    step), put the payload back on the path: the raw inputs to Newton's tolerance (measured 5.6e-11:
    the same discrete equations), the filtered ones (the continuous inputs to O(h^2)) to 5.1e-3 at
    h = 0.025 (2.0e-2 at h = 0.05: the replay's own O(h^2) error).  Both runs' energy balances close
    every step, and the servo books the same supplied work as the ordinary ports."""
    h, t_end = 0.025, 2.5
    inverse = run(rail_crane(), h, t_end)
    assert np.max(np.abs(column(inverse, "balance_error"))) <= 1e-12
    path = np.array([RAIL["path"](t) for t in column(inverse, "t")])
    for smooth, tolerance in ((False, 1e-9), (True, 7e-3)):
        u = step_inputs(inverse.rows, "servo", smooth=smooth)
        replay = run(rail_replay(u, u), h, t_end)
        payload = np.column_stack([column(replay, "payload_x"), column(replay, "payload_y")])
        assert np.max(np.abs(payload - path)) <= tolerance, (smooth, np.max(np.abs(payload - path)))
        assert np.max(np.abs(column(replay, "balance_error"))) <= 1e-12
        if not smooth:
            assert np.max(np.abs(column(replay, "supplied") - column(inverse, "supplied"))) <= 1e-9
            assert np.max(np.abs(column(replay, "H") - column(inverse, "H"))) <= 1e-9


def test_parasitic_mode_of_a_path_not_flat_at_rest():
    """A path whose 5th derivative jumps at the start (the quintic-to-nonic smoothstep, flat = 4)
    excites the midpoint rule's parasitic input (-1)^n p(n): the raw trolley force is off by
    hundreds of newtons and alternates step by step, while the trolley's position and the winch
    tension stay O(h^2) and the path exact."""
    h = 0.05
    path = Transfer((0.0, -l), (1.0, -l + 0.3), 0.0, 2.0, flat=4)
    result = run(rail_crane(path), h, 2.5)
    t = column(result, "t")
    x_T, _, _ = rail_flat(path, t)
    _, F, T = rail_flat(path, t[1:] - h / 2)
    raw = column(result, "servo.u1")[1:] - F
    assert np.max(np.abs(raw)) >= 100 * np.max(np.abs(F))
    assert np.all(raw[20:-1] * raw[21:] < 0)                            # alternates
    assert np.max(np.abs(column(result, "trolley_x") - x_T)) <= 1e-2
    assert np.max(np.abs(column(result, "servo.u2")[1:] - T)) <= 2e-3


# -- bad servos ------------------------------------------------------------------------------------
def bad(kind):
    system = System()
    trolley, payload = points(system, 1.0, 0.5, 2)
    push, lift = along((1.0, 0.0)).at(trolley), winch().between(trolley, payload)
    if kind == "start":
        system.servo(payload, lambda t: np.array([0.1, -l]), [push, lift])
    elif kind == "shape":
        system.servo(payload, lambda t: np.array([0.0, 0.0, -l]), [push, lift])
    elif kind == "inputs":
        system.servo(payload, lambda t: np.array([0.0, -l]), [push])
    elif kind == "axes":
        system.servo(payload, lambda t: np.array([0.0]), [push], axes=[2])
    elif kind == "direction":
        system.servo(payload, lambda t: np.array([0.0, -l]), [push, along((2.0, 0.0)).at(trolley)])
    elif kind == "ground":
        system.servo(payload, lambda t: np.array([0.0]), [along((1.0, 0.0)).at(GROUND)], axes=[0])
    elif kind == "not an input":
        system.servo(payload, lambda t: np.array([0.0]), [trolley], axes=[0])
    elif kind == "statics":
        system.servo(payload, lambda t: np.array([0.0, -l]), [push, lift])
        Statics(system)
    system.build()


@pytest.mark.parametrize("kind, words", [
    ("start", "start the path where the point is"), ("shape", "must give 2 finite number"),
    ("inputs", "as many inputs as prescribed"), ("axes", "are not distinct axes"),
    ("direction", "dependent directions"), ("ground", "needs at least one body"),
    ("not an input", "must be an actuator"), ("statics", "does not take servo constraints")])
def test_a_bad_servo_is_one_line(kind, words):
    with pytest.raises(ParameterError) as err:
        bad(kind)
    assert isinstance(err.value, ConstraintError) or kind == "statics"
    assert words in str(err.value) and "\n" not in str(err.value), str(err.value)


# -- the crane-inverse scene ------------------------------------------------------------------------
def test_crane_inverse_scene():
    """The scene solves the servo problem when it is built and runs the open-loop check: the filtered
    inputs keep the payload within 6.8e-3 m of the path (h = 0.025), the force applied is the flat one
    to 0.038 N (of 8.5 N); the raw inputs replay the path to Newton's tolerance.  A lift that would put
    the payload above the rail is refused in one line."""
    from mpi4py import MPI

    from rodfem.demos.crane_inverse import scene
    for replay, path_tolerance in (("filtered", 1e-2), ("raw", 1e-9)):
        p = scene.values({"replay": replay})
        result = run(scene.build(p, MPI.COMM_WORLD), p["dt"], p["t_end"])
        assert np.max(column(result, "path_error")) <= path_tolerance
        assert np.max(np.abs(column(result, "balance_error"))) <= 1e-12
        if replay == "filtered":
            assert np.max(np.abs(column(result, "F") - column(result, "F_flat"))) <= 0.06
            assert np.max(np.abs(column(result, "trolley_x") - column(result, "trolley_x_flat"))) <= 0.01
    with pytest.raises(ParameterError, match="lift"):
        scene.build(scene.values({"lift": 1.0}), MPI.COMM_WORLD)


def test_the_cable_servo_has_no_bounded_input():
    """crane-manoeuvre's cable (one element) with the payload's x prescribed by the trolley force: the
    force grows like exp(lambda t) at the rate of the cable's unstable zero dynamics, lambda =
    sqrt(6 N / (rhoA L^2)) = 7.7 /s for one element (N = 9.81 N, its tension; fitted 8.1 /s), to
    1.6e9 N after 3 s, although the payload stays on the path."""
    from rodfem.analysis.stepping import StepControl
    from rodfem.demos.crane_inverse import cable_servo
    # fixed steps of 0.05, full Newton steps (the backtracking line search gives up on the exploding
    # force at t = 2.25), no sub-steps
    system = cable_servo(1, 0.05)
    system.newton_options = {**system.newton_options, "snes_linesearch_type": "basic"}
    result = run(system, 0.05, 3.0, control=StepControl(dt_min=0.05))
    t, F = column(result, "t"), np.abs(column(result, "servo.u1"))
    assert F[-1] >= 1e8
    rate = np.polyfit(t[t >= 1.0], np.log(F[t >= 1.0]), 1)[0]
    assert rate == pytest.approx(np.sqrt(6 * 9.81 / 1.0), rel=0.1)
    assert np.max(column(result, "constraint_residual")) <= 1e-8


def test_newton_options_before_the_first_run_keep_the_start_residual():
    """The t = 0 row observes x_0 at t = 0: `set_newton_options` before the first run builds the system
    (the servo's starting multipliers) while its step is still the default 1, and that step's end time
    t = 1 was kept as the time of x_0 (the rail crane's path at t = 1 is 0.5 from x_0: residual 0.5).
    With and without the call the history is the same, its constraint residual at round-off."""
    rows = []
    for early in (False, True):
        system = rail_crane()
        if early:
            system.set_newton_options(TIGHT)
        result = run(system, 0.05, 0.2)
        assert np.max(column(result, "constraint_residual")) <= 1e-12
        rows.append(column(result, "trolley_x"))
    assert np.array_equal(rows[0], rows[1])
