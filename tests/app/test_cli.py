"""The command line contract: list/show/run, output files, bad input, Newton failure, MPI."""
import json

import numpy as np
import pytest
from processes import history, rodfem_lines, serial_and_parallel

from rodfem.app.cli import main


def test_list_and_show(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in ("flying-spaghetti-2d", "roll-up-2d", "cantilever-2d"):
        assert name in out
    assert main(["show", "cantilever-2d"]) == 0
    out = capsys.readouterr().out
    for name in ("n_elements", "dt", "t_end", "integrator", "EA", "GA", "EI", "rhoA", "rhoI", "g", "fx", "fy", "t_load"):
        assert f"\n{name} " in out


def test_run_writes_results(tmp_path):
    out = tmp_path / "fs"
    assert main(["run", "flying-spaghetti-2d", "--set", "t_end=3", "--quiet", "--out", str(out)]) == 0
    h = history(out)
    for col in ("t", "H", "supplied", "newton_its", "tip_x", "tip_y", "p_x", "p_y", "L_z"):
        assert col in h
    assert len(h["t"]) == 31 and h["t"][0] == 0.0
    s = json.loads((out / "summary.json").read_text())
    assert s["parameters"]["t_end"] == 3.0 and s["parameters"]["EA"] == 1e4
    assert s["steps"] == 30 and s["dofs"] == 11 * 6 + 10 * 3
    assert s["dolfinx_version"].startswith("0.")
    assert s["max_balance_error_relative"] <= 1e-11   # measured 1.1e-15
    assert (out / "centreline.pvd").exists() and len(list((out / "centreline").glob("*.vtp"))) == 31
    assert (out / "shapes.png").stat().st_size > 1000 and (out / "energy.png").stat().st_size > 1000


def test_clamped_scene_has_no_momentum_columns(tmp_path):
    assert main(["run", "roll-up-2d", "--set", "dt=0.1", "--quiet", "--out", str(tmp_path)]) == 0
    h = history(tmp_path)
    assert "tip_x" in h and "p_x" not in h and "L_z" not in h


BAD_INPUT = [
    (["run", "no-such-scene"], ["unknown scene", "flying-spaghetti-2d"]),
    (["show", "no-such-scene"], ["unknown scene"]),
    (["run", "roll-up-2d", "--set", "nope=1"], ["unknown parameter 'nope'", "n_elements"]),
    (["run", "roll-up-2d", "--set", "dt=abc"], ["'dt'", "a number > 0"]),
    (["run", "roll-up-2d", "--set", "dt=0"], ["'dt'", "> 0"]),
    (["run", "roll-up-2d", "--set", "dt=-1"], ["'dt'", "> 0"]),
    (["run", "roll-up-2d", "--set", "n_elements=0"], ["'n_elements'", "integer >= 1"]),
    (["run", "roll-up-2d", "--set", "n_elements=2.5"], ["'n_elements'", "integer"]),
    (["run", "roll-up-2d", "--set", "EI=-5"], ["'EI'", "> 0"]),
    (["run", "cantilever-2d", "--set", "rhoA=-1"], ["'rhoA'", ">= 0"]),
    (["run", "roll-up-2d", "--set", "integrator=euler"], ["'integrator'", "midpoint, discrete-gradient"]),
    (["run", "roll-up-2d", "--set", "dt=0.3"], ["'dt'", "whole number of steps"]),
    (["run", "roll-up-2d", "--set", "EA=nan"], ["'EA'"]),
    # integer parameters: all alike (10.0 is 10; 10.5, inf, nan are refused)
    (["run", "roll-up-2d", "--set", "n_elements=inf"], ["'n_elements'", "integer >= 1", "(got 'inf')"]),
    (["run", "roll-up-2d", "--set", "checkpoint_every=10.5"], ["'checkpoint_every'", "integer >= 0", "'10.5'"]),
    (["run", "roll-up-2d", "--set", "checkpoint_every=inf"], ["'checkpoint_every'", "integer >= 0"]),
    (["run", "roll-up-2d", "--set", "checkpoint_every=-1"], ["'checkpoint_every'", "integer >= 0"]),
    # upper bounds of a range
    (["run", "roll-up-2d", "--set", "degree=4"], ["'degree'", "[1, 3]", "(got 4)"]),
    (["run", "hanging-cable", "--set", "angle=181"], ["'angle'", "[-180, 180]", "(got 181)"]),
    (["run", "taut-string-wave", "--set", "stretch=11"], ["'stretch'", "(1, 10]", "(got 11)"]),
    # --set without '='
    (["run", "roll-up-2d", "--set", "dt"], ["--set expects NAME=VALUE", "'dt'"]),
    (["study", "roll-up-2d", "--set", "dt"], ["--set expects NAME=VALUE", "'dt'"]),
    (["reduce", "cantilever-2d", "--nonlinear", "--test", "fy"], ["--test expects NAME=VALUE", "'fy'"]),
]


@pytest.mark.parametrize("args, words", BAD_INPUT, ids=[":".join(a).replace(":--set:", ":") for a, _ in BAD_INPUT])
def test_bad_input_is_one_line(args, words, capsys, tmp_path):
    """Every kind of bad input ends with exit code 2 and one line naming the parameter and what is allowed."""
    extra = {"run": ["--quiet", "--out", str(tmp_path / "x")], "study": ["--out", str(tmp_path / "x")]}
    assert main(args + extra.get(args[0], [])) == 2
    err = capsys.readouterr().err.strip()
    lines = rodfem_lines(err)
    assert len(lines) == 1 and lines[0].startswith("rodfem: error:")
    for w in words:
        assert w in err


def test_integer_options_are_read_like_integer_parameters():
    from rodfem.app.cli import parser
    args = parser().parse_args(["static", "roll-up-2d", "--load-steps", "2.0"])
    assert args.load_steps == 2 and type(args.load_steps) is int
    for bad in ("2.5", "inf", "nan", "two"):
        with pytest.raises(SystemExit):
            parser().parse_args(["static", "roll-up-2d", "--load-steps", bad])


def test_integer_parameters_take_a_whole_float(tmp_path):
    """checkpoint_every=5.0 is 5, as n_elements=4.0 is 4."""
    args = ["run", "roll-up-2d", "--set", "t_end=0.05", "--set", "dt=0.01", "--quiet", "--out", str(tmp_path)]
    assert main([*args, "--set", "n_elements=4.0", "--set", "checkpoint_every=5.0"]) == 0
    assert (tmp_path / "checkpoint.npz").exists()
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["parameters"]["n_elements"] == 4 and s["n_elements"] == 4


@pytest.mark.parametrize("command", ["run", "static", "linearize", "modes", "study", "resume"])
def test_an_empty_out_is_refused(command, capsys, tmp_path, monkeypatch):
    """--out '' (or --resume '') is refused, not taken for the default results/SCENE (which it cleared)."""
    monkeypatch.chdir(tmp_path)
    default = tmp_path / "results" / "roll-up-2d"
    default.mkdir(parents=True)
    (default / "summary.json").write_text("mine")
    args = {"resume": ["run", "--resume", "", "--quiet"]}.get(command, [command, "roll-up-2d", "--out", ""])
    assert main(args) == 2
    option = "--resume" if command == "resume" else "--out"
    assert rodfem_lines(capsys.readouterr().err) == [f"rodfem: error: {option} must name a directory (got '')"]
    assert (default / "summary.json").read_text() == "mine" and len(list((tmp_path / "results").iterdir())) == 1


@pytest.mark.parametrize("setting, message", [
    ("EA=-1", "rodfem: error: parameter 'EA' must be a number > 0 (got -1)"),
    ("EA", "rodfem: error: --set expects NAME=VALUE (got 'EA')"),
], ids=["negative", "no-equals-sign"])
def test_bad_input_from_the_shell_has_no_traceback(rodfem, tmp_path, setting, message):
    """From the shell: exit code 2 and exactly the one line on stderr, no traceback."""
    p = rodfem("run", "cantilever-2d", "--set", setting, "--out", str(tmp_path))
    assert p.returncode == 2
    assert rodfem_lines(p.stderr) == [message]


def test_newton_failure_is_reported_and_keeps_results(rodfem, tmp_path):
    out = tmp_path / "fail"
    p = rodfem("run", "flying-spaghetti-2d", "--set", "t_end=1", "--quiet", "--out", str(out),
               env={"PETSC_OPTIONS": "-rodfem_snes_max_it 1"})
    assert p.returncode == 3
    last = rodfem_lines(p.stderr)[-1]
    assert "Newton failed at step 1" in last and "residual" in last and "Traceback" not in p.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "newton-failure" and s["failure"]["step"] == 1
    assert len(history(out)["t"]) == 1  # the t = 0 row written before the failure


@pytest.mark.mpi
def test_mpi_two_ranks_match_serial(tmp_path):
    """mpirun -n 2 gives the serial history: every column at every time level (measured <= 1e-14 of
    its scale; bound 1e-11) and the same Newton iterations."""
    args = ["run", "flying-spaghetti-2d", "--set", "n_elements=20", "--set", "t_end=5", "--quiet"]
    a, b, _ = serial_and_parallel(tmp_path, args)
    for col in ("H", "supplied", "tip_x", "tip_y", "p_x", "p_y", "L_z"):
        scale = max(np.max(np.abs(a[col])), 1.0)
        assert np.max(np.abs(a[col] - b[col])) <= 1e-11 * scale, col
    assert np.array_equal(a["newton_its"], b["newton_its"])
