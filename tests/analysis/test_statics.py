"""Static equilibrium of the discrete model (rodfem/analysis/statics.py): only the spatial error is left.

roll-up and helix against their exact solutions with different numbers of load steps, the
spatial order of the 3D rod, a multibody system, a static solution that starts a dynamic run
at rest, the command line and a failing continuation."""
import json

import numpy as np
import pytest
from mpi4py import MPI
from processes import rodfem_lines

from rodfem import Load, Support, System, ramp, run
from rodfem.analysis.statics import Statics, solve
from rodfem.app.cli import main
from rodfem.app.scene import load
from rodfem.core.joints import ground
from rodfem.forms import joints
from rodfem.forms.planar_beam import PlanarBeam, quadratic, straight


def static_error(name, n_elements, steps, adaptive=False, **overrides):
    """(tip error / L, StaticResult) of the static solve of a scene at its full load."""
    scene = load(name)
    p = scene.values({"n_elements": n_elements, **overrides})
    problem = scene.build(p, MPI.COMM_WORLD)
    result = Statics(problem).solve(p["t_end"], steps, adaptive)
    obs, ref = problem.observe(), scene.reference(p)
    return max(abs(obs[k] - v) for k, v in ref.items() if k != "scale") / ref["scale"], result


def test_roll_up_2d_exact_whatever_the_load_steps():
    """64 elements: the circle to 1e-6 L (in fact to round-off: the P1/DG0 beam is exact up to
    quadrature for pure bending) with 1, 3 or 8 load steps -- no load-step error."""
    errs = []
    for steps in (1, 3, 8):
        err, res = static_error("roll-up-2d", 64, steps)
        assert len(res.steps) == steps and res.failed == 0
        errs.append(err)
    assert max(errs) <= 1e-6, errs
    assert max(errs) - min(errs) <= 1e-10, errs


def test_roll_up_2d_ten_turns():
    err, res = static_error("roll-up-2d", 64, 1, turns=10.0)
    assert err <= 1e-6, err
    assert res.newton_its <= 10


@pytest.mark.parametrize("name", ["roll-up-3d", "helix-3d"])
def test_rod_statics_spatial_error_only(name):
    """3D rod: the same error with 2 or 6 fixed load steps (to 1e-9 L), and it falls with the mesh
    at the element's order (about 4: P2 centreline, DG1 stresses), measured 8 -> 16 elements."""
    e8 = [static_error(name, 8, s)[0] for s in (2, 6)]
    e16, _ = static_error(name, 16, 2)
    assert abs(e8[0] - e8[1]) <= 1e-9, e8
    order = np.log2(e8[0] / e16)
    assert 3.5 <= order <= 4.6, (e8, e16, order)


def test_statics_of_a_system_of_two_welded_beams():
    """A cantilever made of two beams welded by a planar rigid joint rolls up into the same exact
    circle; the joint carries the end moment (lambda3 = 2 pi EI / L)."""
    L, EI = 10.0, 500.0
    beam = PlanarBeam(0.0, 0.0, quadratic(EA=1e4, GA=1e4, EI=EI))
    system = System()
    a = system.add("a", beam, n_elements=8, supports=[Support("left", "clamped")], shape=straight((0, 0), (L / 2, 0)))
    b = system.add("b", beam, n_elements=8, loads=[Load("omega", ramp(2 * np.pi * EI / L, 1.0), "right")],
                   shape=straight((L / 2, 0), (L, 0)))
    system.join(joints.planar_rigid, a.end, b.start, name="weld")
    system.marker("tip", b.end)
    _, res = solve(system, t=1.0, steps=2, adaptive=False)
    obs = system.observe()
    assert len(res.steps) == 2
    assert np.hypot(obs["tip_x"], obs["tip_y"]) <= 1e-10 * L
    assert abs(obs["weld.lambda3"] - 2 * np.pi * EI / L) <= 1e-8 * EI
    assert obs["constraint_residual"] <= 1e-12


def test_static_solution_starts_a_dynamic_run_at_rest():
    """The hanging cable's equilibrium (gravity) from the generic solver equals the string's own
    helper and stays at rest when time stepping starts from it."""
    scene = load("hanging-cable")
    p = scene.values({"n_elements": 8, "angle": 0.0, "dt": 0.01, "t_end": 0.2})
    problem = scene.build(p, MPI.COMM_WORLD)       # the scene starts from static_equilibrium
    reference = problem.x0.x.array.copy()
    problem.x0.x.array[:] *= 1.01                  # disturb, then solve with the generic solver
    problem.x0.x.array[:] += 0.001
    S = problem.space
    S.assign(problem.x0, "v", lambda x: np.zeros((3, x.shape[1])))
    solve(problem, t=0.0)
    assert np.max(np.abs(problem.x0.x.array - reference)) <= 1e-9
    start = problem.x0.x.array.copy()
    result = run(problem, p["dt"], p["t_end"])
    assert np.max(np.abs(problem.x0.x.array - start)) <= 1e-10
    assert np.max(np.abs(result.column("H") - result.rows[0]["H"])) <= 1e-10


def test_cli_static_writes_results(tmp_path):
    out = tmp_path / "st"
    assert main(["static", "roll-up-2d", "--set", "n_elements=16", "--load-steps", "2", "--out", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["mode"] == "static" and s["load_steps"] >= 1 and s["error_relative"] <= 1e-9
    assert (out / "loadsteps.csv").read_text().count("\n") == s["load_steps"] + 1
    assert (out / "shapes.png").stat().st_size > 1000 and (out / "centreline.pvd").exists()


def test_a_free_beam_has_no_equilibrium_one_line_error(rodfem):
    """flying-spaghetti-2d is free and loaded: no equilibrium -> exit 3, one line."""
    p = rodfem("static", "flying-spaghetti-2d", "--time", "1", "--out", "/tmp/rodfem-no-equilibrium")
    assert p.returncode == 3, p.stderr
    lines = rodfem_lines(p.stderr)
    assert len(lines) == 1 and "static solve failed" in lines[0], p.stderr


def test_cli_static_then_run_from_the_equilibrium(tmp_path):
    """`rodfem static` leaves the equilibrium as a step-0 checkpoint; `rodfem run --resume` starts a
    dynamic run from it: the cantilever sagging under gravity stays at rest (pre-stressed start)."""
    st, dyn = tmp_path / "static", tmp_path / "dynamic"
    sets = ["--set", "g=9.81", "--set", "fy=0", "--set", "n_elements=8", "--set", "t_end=0.02"]
    assert main(["static", "cantilever-2d", *sets, "--time", "0", "--out", str(st)]) == 0
    assert main(["run", "--resume", str(st), "--out", str(dyn), "--quiet"]) == 0
    import csv
    with open(dyn / "history.csv") as f:
        rows = list(csv.DictReader(f))
    tip = np.array([float(r["tip_y"]) for r in rows])
    H = np.array([float(r["H"]) for r in rows])
    assert len(rows) == 21 and tip[0] < -1e-4                      # it sags ...
    assert np.max(np.abs(tip - tip[0])) <= 1e-12 and np.max(np.abs(H - H[0])) <= 1e-9 * H[0]   # ... at rest


@pytest.mark.mpi
def test_no_equilibrium_fails_the_same_way_on_two_ranks(rodfem, tmp_path):
    """The free, loaded flying spaghetti has no static equilibrium: serial and `mpirun -n 2` both end
    with exit 3 and one line (two ranks used to report MUMPS's INFOG(1) = -3 as a PETSc error, exit
    2, blaming the user's options, then scipy's warnings about the singular interface matrix).
    (The reason differs: the serial LU factors the singular matrix with round-off pivots and Newton
    diverges; the parallel solver finds no finite solution.)"""
    for np_ in (None, 2):
        p = rodfem("static", "flying-spaghetti-2d", "--time", "1", "--out", tmp_path / f"np{np_}", np=np_,
                   timeout=300)
        lines = rodfem_lines(p.stderr)
        assert p.returncode == 3 and len(lines) == 1, p.stderr[-2000:]
        assert lines[0].startswith("rodfem: error: static solve failed at load factor 0: "), lines


@pytest.mark.parametrize("angle, force", [(0.3, 0.0), (0.3, 0.005), (-1.2, 0.005)], ids=["rigid", "loaded", "turned"])
def test_a_driven_joint_holds_its_drive_in_statics(angle, force):
    """A beam whose start is driven to the angle theta(t) = angle t by a hub joint, at t = 1 under a
    tip force (0, -F) fixed in space: the hub angle is theta(1) (constraint_residual at round-off; it
    read |theta(1)| = 0.3 with the time-stepping clock), and the tip is where Timoshenko's linear
    cantilever puts it in the turned frame: rotated (L + F_a L/EA, F_t (L^3/3EI + L/GA)), F_a, F_t
    the axial and transverse components (measured with 64 elements: 8.5e-5 of the deflection, 7.9e-4
    with 16: the discretization error; bound 1e-3)."""
    EA, GA, EI, L = 1e3, 1e3, 10.0, 1.0
    s = System()
    arm = s.add("arm", PlanarBeam(1.0, 0.01, quadratic(EA=EA, GA=GA, EI=EI)), shape=straight((0.0, 0.0), (L, 0.0)),
                n_elements=64, supports=[Support("left", "pinned")],
                loads=[Load("v", [0.0, -force], "right", "tip force")])
    s.join(joints.angle, ground((0.0, 0.0)), arm.start, name="hub", drive=lambda t: [angle * t])
    s.marker("tip", arm.end)
    solve(s, t=1.0)
    obs = s.observe()
    assert obs["constraint_residual"] <= 1e-12
    c, sn = np.cos(angle), np.sin(angle)
    f_axial, f_transverse = -force * sn, -force * c          # (0, -F) in the turned frame (d1, d2)
    u = L + f_axial * L / EA
    w = f_transverse * (L**3 / (3 * EI) + L / GA)
    expected = np.array([c * u - sn * w, sn * u + c * w])
    tip = np.array([obs["tip_x"], obs["tip_y"]])
    scale = force * (L**3 / (3 * EI) + L / GA)               # the deflection under the whole force
    assert np.max(np.abs(tip - expected)) <= (1e-3 * scale if force else 1e-12), (tip, expected)


def test_a_static_result_far_from_the_exact_solution_is_flagged(tmp_path, capsys):
    """roll-up-2d with 1e6 turns on 10 elements: 'completed', but 138 % of the scale away from the
    exact circle, which the summary and the terminal now say (it was a plain exit 0); the default
    roll-up (2.7e-13) is not flagged, and the slider crank's reference (its exact motion at t_end,
    not an equilibrium) is not compared with."""
    assert main(["static", "roll-up-2d", "--set", "turns=1e6", "--out", str(tmp_path / "a")]) == 0
    s = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert s["error_relative"] > 1.0 and "refine it" in s["warning"]
    assert "warning: the equilibrium is 1.38 of the scale away" in capsys.readouterr().out
    assert main(["static", "roll-up-2d", "--out", str(tmp_path / "b")]) == 0
    assert "warning" not in json.loads((tmp_path / "b" / "summary.json").read_text())
    assert load("slider-crank-3d").reference_is_static is False
