"""The nonlinear reduced model (rodfem/analysis/galerkin.py): its energy balance exact per step (the structure
kept) with the midpoint rule and a quadratic energy and with the discrete gradient and a non-quadratic one; the
error against the full model falling with the POD rank on the training input and on another input; no energy
created without input; the full rank reproduces the full model; bad input refused."""
import numpy as np
import pytest
from mpi4py import MPI
from processes import rodfem_lines

from rodfem.analysis.galerkin import ReducedSystem, layout, pod_basis
from rodfem.analysis.timeloop import run
from rodfem.app.analyses import resolve
from rodfem.app.driver import build
from rodfem.app.nonlinear_reduction import errors, full_run, reduced_run
from rodfem.errors import ParameterError

# a steel strip, 1 m, tip load ramped over 0.1 s to a tip deflection of 0.2 m (20 % of the length)
BASE = {"degree": 2, "n_elements": 4, "fy": -80.0, "t_ramp": 0.1, "t_load": 1.0, "t_end": 0.1, "dt": 2e-3}


def trained(overrides=None, test=None):
    scene, p = resolve("cantilever-2d", {**BASE, **(overrides or {})})
    problem = build(scene, p, MPI.COMM_WORLD)
    res, X = full_run(problem, p["dt"], p["t_end"])
    out = {"train": (problem, res, X, p)}
    if test:
        _, q = resolve("cantilever-2d", {**BASE, **(overrides or {}), **test})
        other = build(scene, q, MPI.COMM_WORLD)
        r2, X2 = full_run(other, q["dt"], q["t_end"])
        out["test"] = (other, r2, X2, q)
    return out, layout(problem)


@pytest.fixture(scope="module")
def hooke():
    return trained(test={"fy": -50.0, "fx": 10.0})


@pytest.mark.parametrize("rule", ["midpoint", "discrete-gradient"])
def test_reduced_energy_balance_is_exact(rule, hooke):
    """H_r(xi_{n+1}) - H_r(xi_n) = h y.u per step to 1e-12 of max H (Hooke's law, midpoint rule; the log-axial
    law, non-quadratic, with the discrete gradient), although the reduced trajectory is 1e-2 off the full one."""
    if rule == "midpoint":
        cases, lay = hooke
    else:
        cases, lay = trained({"material": "log-axial", "integrator": "discrete-gradient"})
    problem, res, X, p = cases["train"]
    basis = pod_basis(X, 3, lay, problem)
    red, S, _ = reduced_run(problem, basis, p["dt"], p["t_end"], X[:, 0])
    e = errors(res, X, red, S, lay)
    assert e["balance_relative"] <= 1e-12
    assert abs(red.rows[-1]["supplied"]) > 0.1 * e["H_max"]    # the port did work
    assert e["configuration"] > 1e-4                           # a reduced model, not the full one


def test_error_falls_with_rank_on_training_and_test_inputs(hooke):
    """The configuration and tip errors against the full model fall with the POD rank r = 2, 4, 8, on the training
    input and on another one (another amplitude, and a horizontal component the training never had)."""
    cases, lay = hooke
    X = cases["train"][2]
    found = {}
    for r in (2, 4, 8):
        basis = pod_basis(X, r, lay, cases["train"][0])
        for name, (problem, res, Xc, p) in cases.items():
            red, S, _ = reduced_run(problem, basis, p["dt"], p["t_end"], Xc[:, 0])
            found[(name, r)] = errors(res, Xc, red, S, lay)
    for name in cases:
        c = [found[(name, r)]["configuration"] for r in (2, 4, 8)]
        tip = [found[(name, r)]["tip_y"] for r in (2, 4, 8)]
        assert c[0] > c[1] > c[2] and tip[0] > tip[2], (name, c, tip)
        assert all(found[(name, r)]["balance_relative"] <= 1e-12 for r in (2, 4, 8))
    assert found[("train", 8)]["configuration"] < 5e-3
    assert found[("test", 8)]["configuration"] < 1e-2


def test_no_configuration_mode_without_stiffness(hooke):
    """With fewer energy POD modes (2) than configuration modes (6, 8), the strain images of the configuration
    modes in the energy basis keep every mode stiff: the error stays below 0.2 (without them a mode whose strains
    the basis misses has no stiffness, and the load drives it: errors of 5 and 10 times the motion)."""
    cases, lay = hooke
    problem, res, X, p = cases["train"]
    for r in (6, 8):
        basis = pod_basis(X, r, lay, problem, energy_rank=2)
        assert basis.ranks["energy"] == r + 2
        red, S, _ = reduced_run(problem, basis, p["dt"], p["t_end"], X[:, 0])
        assert errors(res, X, red, S, lay)["configuration"] < 0.2


def test_full_rank_reproduces_the_full_model(hooke):
    """With every POD mode the reduced model is the full model on the training run (to Newton's tolerance)."""
    cases, lay = hooke
    problem, res, X, p = cases["train"]
    basis = pod_basis(X, 10_000, lay, problem)
    red, S, _ = reduced_run(problem, basis, p["dt"], p["t_end"], X[:, 0])
    assert errors(res, X, red, S, lay)["configuration"] < 1e-8


def test_no_energy_created_without_input(hooke):
    """Started from the deflected state at the end of the training run with the tip load off (u = 0), the reduced
    model keeps H_r constant to 1e-12 of H (and supplies nothing): it creates no energy (passive)."""
    cases, lay = hooke
    _, _, X, p = cases["train"]
    scene, q = resolve("cantilever-2d", {**BASE, "t_load": 0.0})
    problem = build(scene, q, MPI.COMM_WORLD)
    rom = ReducedSystem(problem, pod_basis(X, 4, lay, problem), start=X[:, -1])
    res = run(rom, p["dt"], 0.05)
    H = res.column("H")
    assert H[0] > 1.0 and np.max(np.abs(H - H[0])) <= 1e-12 * H[0]
    assert np.max(np.abs(res.column("supplied"))) == 0.0
    assert np.ptp(res.column("tip_y")) > 1e-3       # it moves: the elastic energy turns into kinetic energy


def test_bad_input():
    """Rank < 1, a model without effort fields (degree 1), a scene with Maxwell branches and another mesh are refused."""
    cases, lay = trained()
    X = cases["train"][2]
    with pytest.raises(ParameterError, match="--order"):
        pod_basis(X, 0, lay)
    scene, p = resolve("cantilever-2d", {**BASE, "degree": 1})
    with pytest.raises(ParameterError, match="efforts as fields"):
        layout(build(scene, p, MPI.COMM_WORLD))
    scene, p = resolve("viscoelastic-cantilever-2d", {"degree": 2, "n_elements": 4, "t_end": 0.01})
    with pytest.raises(ParameterError, match="Maxwell branches|neither configuration"):
        layout(build(scene, p, MPI.COMM_WORLD))
    scene, p = resolve("cantilever-2d", {**BASE, "n_elements": 5})
    with pytest.raises(ParameterError, match="rows"):
        ReducedSystem(build(scene, p, MPI.COMM_WORLD), pod_basis(X, 2, lay))


def test_cli_trains_and_checks(tmp_path, rodfem):
    """`rodfem reduce --nonlinear` prints and writes, per order and input, the errors, the balance and the
    timings; they are those of the Python API (the same runs)."""
    out = tmp_path / "nl"
    sets = [a for k, v in BASE.items() for a in ("--set", f"{k}={v}")]
    p = rodfem("reduce", "cantilever-2d", "--nonlinear", "--order", "2", "4", *sets, "--test", "fy=-50",
               "--out", out)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "train" in p.stdout and "test" in p.stdout
    import json
    info = json.loads((out / "nonlinear_reduce.json").read_text())
    assert set(info["orders"]) == {"2", "4"} and info["test_parameters"] == {"fy": -50.0}
    for r in ("2", "4"):
        for name in ("train", "test"):
            e = info["orders"][r][name]
            assert e["errors"]["balance_relative"] <= 1e-12 and e["speed_up"] > 0
    assert info["orders"]["4"]["train"]["errors"]["configuration"] < info["orders"]["2"]["train"]["errors"]["configuration"]


@pytest.mark.parametrize("args, message", [
    (["--nonlinear", "--order", "0"], "--order must be integers >= 1"),
    (["--nonlinear", "--set", "degree=1"], "efforts as fields"),
    (["--test", "fy=-50"], "--test goes with --nonlinear"),
])
def test_cli_bad_input_is_one_line(tmp_path, rodfem, args, message):
    p = rodfem("reduce", "cantilever-2d", "--set", "n_elements=4", "--set", "t_end=0.01", "--set", "degree=2", *args,
               "--out", tmp_path / "x")
    assert p.returncode == 2 and message in p.stderr and len(rodfem_lines(p.stderr)) == 1, p.stderr
