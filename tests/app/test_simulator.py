"""The step interface (rodfem/app/simulator.py): a user's loop through `Simulator.step` against the
built-in time loop and the built-in controller, save/restore, reset, bad input, mpirun."""

import numpy as np
import pytest
from mpi4py import MPI
from processes import assert_same_rows, script_on_ranks

from rodfem import NewtonFailure, ParameterError, Simulator, run
from rodfem.app.scene import load
from rodfem.forms.components import rest_to_rest

PORT = "beam.hub moment"
H = 0.01


def arm(**extra):
    return Simulator("robot-arm-control", controller="external", n_elements=4, **extra)


def column(rows, name):
    return np.array([r[name] for r in rows])


def test_ports_outputs_and_energy_balance():
    """The arm's one port (the hub moment, output the hub's angular velocity at the step midpoint): h u y
    is the step's supplied work, the balance H_{n+1} - H_n - h u y holds to round-off in the history."""
    sim = arm()
    assert sim.inputs == [(PORT, 1)]
    for n in range(5):
        out = sim.step({PORT: 0.5 + 0.1 * n}, H)
        assert out.t == pytest.approx((n + 1) * H, abs=1e-15)
        assert H * (0.5 + 0.1 * n) * out.y[PORT][0] == pytest.approx(
            sim.history.rows[-1]["supplied"] - sim.history.rows[-2]["supplied"], rel=1e-13)
    assert sim.history.max_balance_error <= 1e-13 * max(column(sim.history.rows, "H"))
    assert column(sim.history.rows, "u[beam.hub moment]")[-1] == 0.9
    assert out.vector().shape == (1,)


def test_open_loop_equals_the_time_loop():
    """A sampled PD loop (u_n from x_n and the last output, held over the step) through `step`; then the scene run by the
    built-in loop with a Load replaying the same u_n (read at the step midpoints): the same history."""
    kp, kd = 2.0, 0.01     # (sampled: the hub's own inertia over one step is small, an explicit kd = 5 is unstable)
    sim = arm()
    us, y = [], 0.0
    for _ in range(30):
        us.append(-kp * (sim.history.rows[-1]["hub_angle"] - 0.3) - kd * y)
        y = sim.step({PORT: us[-1]}, H).y[PORT][0]
    scene = load("robot-arm-control")
    system = scene.build(scene.values({"controller": "external", "n_elements": 4}), MPI.COMM_WORLD)
    (hub,) = system.body("beam").loads
    hub.value = lambda t: np.asarray(us[int(t / H)])        # t = (n + 1/2) h: the n-th input
    res = run(system, H, 30 * H)
    for c in ("H", "supplied", "tip_x", "tip_y", "hub_angle", "tip_deflection"):
        assert np.max(np.abs(column(sim.history.rows, c) - res.column(c))) <= 1e-12 * max(1.0, np.max(np.abs(res.column(c)))), c


def test_closed_loop_in_python_equals_the_built_in_controller():
    """The PD law u = -kp (phi(0) - r(t)) - kd omega(0) of robot-arm-control's built-in controller acts at
    the step midpoint (implicit).  The user's loop solves that relation per step through save/restore (a
    secant iteration on u: the step's output y = omega_m(0), phi_m = (phi_n + phi_{n+1})/2): the same
    motion as controller=law and controller=pd to Newton's tolerance."""
    kp, kd = 20.0, 5.0
    r = rest_to_rest(0.0, np.pi / 2, 0.0, 1.5)
    sim = arm()
    phi, us = 0.0, []
    for _ in range(30):
        t, start = sim.t, sim.save()

        def residual(u):
            sim.restore(start)
            out = sim.step({PORT: u}, H)
            phi_m = 0.5 * (phi + out.row["hub_angle"])
            return u + kp * (phi_m - r(t + 0.5 * H)) + kd * out.y[PORT][0], out
        u0 = us[-1] if us else 0.0
        f0, _ = residual(u0)
        u1 = u0 - f0
        for _ in range(20):
            f1, out = residual(u1)
            if abs(f1) <= 1e-12:
                break
            u0, u1, f0 = u1, u1 - f1 * (u1 - u0) / (f1 - f0), f1
        assert abs(f1) <= 1e-12
        us.append(u1)
        phi = out.row["hub_angle"]
    assert len(sim.history.rows) == 31     # the rolled-back attempts are not in the history
    scene = load("robot-arm-control")
    for controller in ("law", "pd"):
        p = scene.values({"controller": controller, "n_elements": 4})
        res = run(scene.build(p, MPI.COMM_WORLD), H, 30 * H)
        for c in ("tip_x", "tip_y", "hub_angle"):
            assert np.max(np.abs(column(sim.history.rows, c) - res.column(c))) <= 1e-9, (controller, c)
        if controller == "law":
            assert np.max(np.abs(np.array(us) - res.column("hub.u1")[1:])) <= 1e-8
            assert np.max(np.abs(column(sim.history.rows, "H") - res.column("H"))) <= 1e-10


def test_save_restore_and_reset_replay_exactly():
    """restore(save()) rolls back (state, time, history) and the same inputs then give the same rows to
    the bit; reset() goes back to t = 0; reset(params) rebuilds the scene with other values."""
    sim = arm()
    before = [sim.step({PORT: 1.0}, H).row for _ in range(3)]
    state = sim.save()
    first = [sim.step({PORT: -0.5 + 0.2 * k}, H).row for k in range(4)]
    sim.restore(state)
    assert len(sim.history.rows) == 4 and sim.t == pytest.approx(3 * H)
    again = [sim.step({PORT: -0.5 + 0.2 * k}, H).row for k in range(4)]
    assert again == first
    sim.reset()
    assert sim.t == 0.0 and len(sim.history.rows) == 1
    assert [sim.step({PORT: 1.0}, H).row for _ in range(3)] == before
    sim.reset({"EI": 10.0})            # rebuilt with a stiffer arm
    assert sim.values["EI"] == 10.0 and len(sim.history.rows) == 1
    assert sim.step({PORT: 1.0}, H).row["tip_y"] != before[0]["tip_y"]


def test_bad_inputs_are_one_line_errors():
    sim = arm()
    with pytest.raises(ParameterError, match="unknown input port"):
        sim.step({"hub": 1.0}, H)
    with pytest.raises(ParameterError, match="must have 1 number"):
        sim.step({PORT: [1.0, 2.0]}, H)
    with pytest.raises(ParameterError, match="must be finite"):
        sim.step({PORT: float("nan")}, H)
    with pytest.raises(ParameterError, match="dt must be a number > 0"):
        sim.step({PORT: 1.0}, -1.0)
    with pytest.raises(ParameterError, match="1 numbers"):
        sim.step([1.0, 2.0], H)
    with pytest.raises(ParameterError, match="need a scene"):
        Simulator(sim.system, EI=3.0)
    assert len(sim.history.rows) == 1


def test_a_failed_step_leaves_the_state_at_x_n():
    """A step Newton cannot take (a huge moment; no sub-steps allowed) raises NewtonFailure; the next step
    starts from x_n."""
    sim = arm(dt_min=H)
    sim.step({PORT: 1.0}, H)
    row = sim.history.rows[-1]
    with pytest.raises(NewtonFailure):
        sim.step({PORT: 1e9}, H)
    assert sim.t == pytest.approx(H) and sim.history.rows[-1] is row
    sim.step({PORT: 1.0}, H)
    assert sim.history.max_balance_error <= 1e-12


def test_a_step_newton_cannot_take_is_split_as_in_the_time_loop():
    """u = 50 over h = 0.1 from rest: Newton fails on the whole step (dt_min = h: refused); by default the step
    is split in two, and is then the same as two steps of h/2 with the same u (to round-off); the output is
    the sub-steps' mean, so h u y is still the step's supplied work."""
    with pytest.raises(NewtonFailure):
        arm(dt_min=0.1).step({PORT: 50.0}, 0.1)
    sim, halves = arm(), arm()
    out = sim.step({PORT: 50.0}, 0.1)
    assert sim._state.split_steps == 1 and sim._state.substeps == 2
    ys = [halves.step({PORT: 50.0}, 0.05).y[PORT][0] for _ in range(2)]
    for c in ("H", "supplied", "tip_x", "tip_y", "hub_angle"):
        assert out.row[c] == pytest.approx(halves.history.rows[-1][c], rel=1e-12, abs=1e-12), c
    assert out.y[PORT][0] == pytest.approx(np.mean(ys), rel=1e-12)
    assert 0.1 * 50.0 * out.y[PORT][0] == pytest.approx(out.row["supplied"], rel=1e-12)
    assert abs(out.row["balance_error"]) <= 1e-12 * out.row["H"]


SCRIPT = """
import json
import numpy as np
from mpi4py import MPI
from rodfem import Simulator
sim = Simulator("robot-arm-control", controller="external", n_elements=4)
out = None
for n in range(20):
    y = 0.0 if out is None else out.y["beam.hub moment"][0]
    u = -2.0 * (sim.history.rows[-1]["hub_angle"] - 0.3) - 0.01 * y
    out = sim.step({"beam.hub moment": u} if MPI.COMM_WORLD.rank == 0 else None, 0.01)
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps({k: v for k, v in out.row.items()}))
"""


@pytest.mark.mpi
def test_two_ranks_equal_serial():
    """The same user loop under mpirun -n 2 (rank 0 gives the inputs): the serial outputs."""
    serial, parallel = script_on_ranks(SCRIPT, timeout=300)
    assert_same_rows(serial, parallel)
