"""Step-size control (rodfem/analysis/stepping.py, issue 25): a fixed step whose Newton fails is split into
sub-steps (the robot arm at the authors' h = 0.5 runs to T = 15, its energy balance and L_z exact); adaptive
steps meet their tolerance against an exact solution, take fewer steps when it is looser, keep the balance
per step with variable h, land on the frames' times; a resumed adaptive run is the uninterrupted one; below
dt_min the run ends with exit 3 in one line; the line search keeps the easy scenes' Newton iterations."""
import json
import math
import signal

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc
from processes import rodfem_lines

from rodfem import System, run
from rodfem.analysis.stepping import StepControl
from rodfem.app.cli import main
from rodfem.app.driver import run_scene
from rodfem.app.scene import load
from rodfem.core.joints import ground
from rodfem.errors import Interrupted
from rodfem.forms.components import hookean, spring
from rodfem.forms.rigid_body import PointMass


def column(result, name):
    return np.array([row[name] for row in result.rows])


def arm(dt, integrator="midpoint", **extra):
    scene = load("flexible-robot-arm-2d")
    p = scene.values({"dt": dt, "integrator": integrator, **extra})
    return scene.build(p, MPI.COMM_WORLD).build(), p


@pytest.mark.parametrize("integrator", ["midpoint", "discrete-gradient"])
def test_the_robot_arm_at_the_authors_step_completes_in_sub_steps(integrator):
    """h = 0.5: Newton fails at t = 2 (and later) even with the line search; the failing steps are done in
    2, 4, ... sub-steps from x_n.  The history keeps the grid t_n = n h to T = 15, every row's balance
    H_{n+1} - H_n - h y.u (the sum over its sub-steps) and every sub-step's is <= 1e-12 max |H|, and L_z
    = M min(t, 5) (the midpoint rule's exact momentum map; the hub moment acts in steps 1-10)."""
    problem, p = arm(0.5, integrator)
    result = run(problem, 0.5, 15.0)
    t, H = column(result, "t"), column(result, "H")
    assert len(t) == 31 and np.array_equal(t, 0.5 * np.arange(31))
    assert result.stepping["split_steps"] > 0 and result.stepping["rejected"] > 0
    assert result.stepping["substeps"] > 30
    scale = np.max(np.abs(H))
    assert result.max_balance_error <= 1e-12 * scale
    assert result.stepping["max_substep_balance"] <= 1e-12 * scale
    Lz = column(result, "L_z")
    assert np.max(np.abs(Lz - p["M"] * np.minimum(t, p["t_load"]))) <= 1e-12 * 40


def test_the_line_search_carries_the_robot_arm_at_dt_01():
    """h = 0.1: Newton's full steps diverge at t = 7.7 (issue 25); the backtracking line search (the default)
    converges in every step, no sub-steps needed, L_z exact."""
    problem, p = arm(0.1)
    result = run(problem, 0.1, 15.0)
    assert result.stepping["rejected"] == 0 and result.stepping["substeps"] == 150
    assert abs(result.rows[-1]["L_z"] - 40.0) <= 1e-9


def oscillator():
    """A mass m = 2 on a Hookean spring k = 50 (rest length 1) to the ground, moving along the axis:
    x(t) = 1 + 0.3 cos 5t + 0.08 sin 5t, v = x'."""
    s = System()
    body = s.add("mass", PointMass(2.0, dim=3), initial=PointMass.initial((1.3, 0.0, 0.0), (0.4, 0.0, 0.0)))
    s.connect(spring(hookean(50.0, 1.0)), ground((0.0, 0.0, 0.0)), body.point())
    s.marker("mass", body.point())
    return s


def exact(t):
    return 1.0 + 0.3 * np.cos(5.0 * t) + 0.08 * np.sin(5.0 * t)


def test_adaptive_steps_meet_the_tolerance_of_an_exact_solution():
    """Step doubling with the midpoint rule on the linear oscillator, two periods: the position's error
    against the exact solution stays within rtol |x|_max over the run (the error controlled per unit
    step: measured 0.24 rtol |x|_max from rtol = 1e-2 to 1e-6; per step, the default, 2.7 to 68 rtol),
    the steps are variable (their h in the history), the balance holds per step with its own h, a looser
    rtol takes fewer steps (h ~ rtol^(1/2)), and the steps land on t_end and on the output times."""
    steps, times = {}, (0.0, 0.7, 2.5)
    for rtol in (1e-2, 1e-4):
        s = oscillator()
        result = run(s, 0.01, 2.5, control=StepControl(adaptive=True, rtol=rtol, atol=1e-9, output_times=times,
                                                       per_unit_step=True))
        t, x, h = column(result, "t"), column(result, "mass_x"), column(result, "h")
        error = np.max(np.abs(x - exact(t)))
        assert error <= rtol * 1.31, (rtol, error)
        assert error >= 0.05 * rtol * 1.31, (rtol, error)     # not a fixed fine step in disguise
        assert t[-1] == 2.5 and 0.7 in t and np.all(np.diff(t) > 0)
        assert np.allclose(np.diff(t), h[1:], rtol=1e-12, atol=0) and np.ptp(h[1:]) > 0
        assert result.max_balance_error <= 1e-12 * np.max(np.abs(column(result, "H")))
        assert np.all(column(result, "error_estimate")[1:] <= 1.0)
        steps[rtol] = result.steps
    assert steps[1e-2] < steps[1e-4] / 5     # (h ~ rtol^(1/2): 10 times fewer)
    s = oscillator()      # per step (the default): fewer steps, the error a few rtol
    result = run(s, 0.01, 2.5, control=StepControl(adaptive=True, rtol=1e-2, atol=1e-9, output_times=times))
    assert result.steps < steps[1e-2] / 2
    assert np.max(np.abs(column(result, "mass_x") - exact(column(result, "t")))) <= 5e-2 * 1.31


def test_a_resumed_adaptive_run_equals_the_uninterrupted_one(tmp_path, monkeypatch):
    """An adaptive run with checkpoints, interrupted after its step 30 and resumed: history.csv is the same
    file as that of the uninterrupted run (the controller's next step, its predictor's last step and its
    counts are in the checkpoint), and so are the counts of summary.json."""
    from types import SimpleNamespace

    from rodfem.analysis import timeloop
    sets = {"adaptive": "true", "rtol": "1e-4", "t_end": "1", "frames": "3", "checkpoint_every": "10", "dt": "0.01"}
    full, part = tmp_path / "full", tmp_path / "part"
    run_scene("flexible-robot-arm-2d", sets, out=str(full))
    real = timeloop.interrupts

    def check(comm, n, t, where=None):
        if n >= 30:
            raise Interrupted(signal.SIGINT, n, t)
        real.check(comm, n, t, where)
    with monkeypatch.context() as m:
        m.setattr(timeloop, "interrupts", SimpleNamespace(check=check))
        with pytest.raises(Interrupted):
            run_scene("flexible-robot-arm-2d", sets, out=str(part))
    with np.load(part / "checkpoint.npz") as z:
        meta = json.loads(z["meta"].tobytes().decode())
    assert meta["step"] == 30 and 0 < meta["t"] < 1 and meta["stepping"]["h"] > 0
    run_scene(None, {}, out=str(part), resume=str(part))
    assert (full / "history.csv").read_bytes() == (part / "history.csv").read_bytes()
    a, b = (json.loads((d / "summary.json").read_text())["step_control"] for d in (full, part))
    assert a == b and a["adaptive"]


@pytest.mark.parametrize("sets, words", [
    (["dt=0.5", "dt_min=0.5"], ["Newton failed at step", "dt_min = 0.5 allows no sub-steps"]),
    (["dt=0.5", "dt_min=0.2"], ["Newton failed", "split into 2 sub-steps of 0.25, dt_min = 0.2"]),
    (["dt=0.5", "adaptive=true", "dt_min=0.3", "frames=2"], ["dt_min = 0.3"]),
])
def test_below_the_smallest_step_the_run_ends_with_exit_3_in_one_line(sets, words, capsys, tmp_path):
    args = [x for a in sets for x in ("--set", a)]
    assert main(["run", "flexible-robot-arm-2d", *args, "--quiet", "--out", str(tmp_path)]) == 3
    lines = rodfem_lines(capsys.readouterr().err)
    assert len(lines) == 1 and all(w in lines[0] for w in words), lines
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "newton-failure"


@pytest.mark.parametrize("scene, sets", [
    ("flying-spaghetti-2d", {"t_end": 2.0}),
    ("four-bar-2d", {"t_end": 1.0}),
    ("flexible-robot-arm-2d", {"t_end": 5.0}),
])
def test_the_line_search_keeps_the_easy_scenes_newton_iterations(scene, sets):
    """The default Newton (backtracking line search) takes exactly the iterations of the former full steps
    (basic) on scenes it converges on anyway (measured on ten scenes: benchmarks/stepping.md)."""
    its = {}
    options = PETSc.Options()
    for search in ("basic", None):
        if search:
            options["rodfem_snes_linesearch_type"] = search
        try:
            result, _ = run_scene(scene, sets)
        finally:
            options.delValue("rodfem_snes_linesearch_type")
        its[search] = column(result, "newton_its")
    assert np.array_equal(its["basic"], its[None]) and math.isclose(its[None].mean(), its["basic"].mean())


def test_a_sub_step_that_fails_partway_through_a_split_restarts_from_x_n():
    """The oscillator at h = 0.01, its step 1 forced to fail in Newton whole and again in the second of its
    two sub-steps (the first sub-step accepted): the four sub-steps then start from x_0 at t = 0, not from
    the first sub-step's state.  The run meets the exact solution to the midpoint rule's error (measured
    3.8e-5 over t <= 0.2; starting the split from the failed state would shift it by v h / 2 = 2e-3), two
    attempts rejected, steps 1 and 2 done in 4 sub-steps, step 3 in 2 (the split halves after a success)."""
    from rodfem.errors import NewtonFailure
    dt = 0.01
    s = oscillator()
    real = s.solve

    def solve(step, t):
        if step == 1 and s.dt > 0.3 * dt and t > 0.51 * dt:   # the whole step and its second half
            raise NewtonFailure(step, t, 1.0, 0, "forced")
        return real(step, t)
    s.solve = solve
    result = run(s, dt, 0.2)
    t, x = column(result, "t"), column(result, "mass_x")
    assert result.stepping["rejected"] == 2      # the step whole, then in two sub-steps
    assert result.stepping["split_steps"] == 3 and result.stepping["substeps"] == 20 + 3 + 3 + 1
    assert np.max(np.abs(x - exact(t))) <= 1e-4, np.max(np.abs(x - exact(t)))
