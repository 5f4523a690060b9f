"""`rodfem study`: a tiny sweep runs, writes the documented CSV, and the midpoint rule is second order in time."""
import csv
import json

import pytest
from processes import rodfem_lines

from rodfem.app.cli import main
from rodfem.app.study import run_study

# The documented header of study.csv, written out here (not imported from rodfem.app.study): a column
# dropped, renamed or moved breaks the readers of the file, and this test.
HEADER = ["path", "n_elements", "dt", "integrator", "steps", "status", "error", "error_max_t", "self_error",
          "wall_time_s", "newton_its_mean", "newton_its_max", "max_balance_error", "max_balance_error_relative",
          "failure"]
DTS, ELEMENTS = [0.025, 0.0125, 0.00625, 0.003125], [4, 8]


@pytest.fixture(scope="module")
def spaghetti(tmp_path_factory):
    """Flying spaghetti, coarse mesh, softened (EA = GA = 100) so that dt resolves its fastest
    mode (omega dt <= 0.2): the time steps are in the asymptotic range."""
    out = tmp_path_factory.mktemp("study-fs")
    study = run_study("flying-spaghetti-2d", {"t_end": "1.0", "n_elements": "4", "EA": "100", "GA": "100",
                                              "frames": "1"},
                      out=str(out), dts=DTS, elements=ELEMENTS, quiet=True)
    return out, study


def test_csv_has_the_documented_columns(spaghetti):
    """study.csv: the documented header, one row per run of each path (dt at n = 4, n at the scene's
    dt) with its step count, and every run's balance at round-off (measured 6.5e-16 of max|H|)."""
    out, study = spaghetti
    with open(out / "study.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == HEADER
    runs = [r for r in rows if r["path"] != "reference"]
    assert sorted((float(r["dt"]), int(r["n_elements"])) for r in runs if r["path"] == "dt") == \
        sorted((dt, 4) for dt in DTS)
    assert sorted(int(r["n_elements"]) for r in runs if r["path"] == "n") == ELEMENTS
    for r in runs:
        assert r["status"] == "completed" and r["integrator"] == "midpoint"
        assert int(r["steps"]) == round(1.0 / float(r["dt"]))
        assert float(r["error"]) > 0 and float(r["wall_time_s"]) > 0
        assert float(r["max_balance_error_relative"]) <= 1e-11
    assert (out / "study.png").stat().st_size > 1000
    meta = json.loads((out / "study.json").read_text())
    assert meta["reference_kind"] == "refined-run" and "relative error" in meta["error_measure"]


def test_midpoint_is_second_order_in_time(spaghetti):
    _, study = spaghetti
    # reference-free: successive differences at fixed n isolate the time error
    orders = study["orders"]["dt"]["self_orders"]
    assert len(orders) == 2 and all(p == pytest.approx(2.0, abs=0.2) for p in orders)


def test_roll_up_against_the_analytic_circle(tmp_path):
    """Analytic reference: the error of the dt path itself converges at order 2."""
    code = main(["study", "roll-up-2d", "--set", "n_elements=4", "--set", "frames=1", "--out", str(tmp_path),
                 "--dt", "0.1", "0.05", "0.025", "--elements", "4"])
    assert code == 0
    meta = json.loads((tmp_path / "study.json").read_text())
    assert meta["reference_kind"] == "analytic"
    assert meta["orders"]["dt"]["order"] == pytest.approx(2.0, abs=0.2)


def test_bad_dt_is_a_parameter_error(tmp_path):
    assert main(["study", "roll-up-2d", "--out", str(tmp_path), "--dt", "0.3", "0.1"]) == 2


RU = ["study", "roll-up-2d", "--set", "t_end=0.1", "--set", "dt=0.05", "--set", "frames=1"]


def test_one_element_count_is_the_dt_paths(tmp_path, capsys):
    """--elements 20 alone: the dt path runs at 20 elements, and says so (it ran at the scene's 10, silently)."""
    assert main([*RU, "--elements", "20", "--out", str(tmp_path)]) == 0
    assert "--elements 20: one value, the element count of the dt path" in capsys.readouterr().out
    with open(tmp_path / "study.csv") as f:
        rows = list(csv.DictReader(f))
    assert rows and {(r["path"], r["n_elements"]) for r in rows} == {("dt", "20")}


def test_every_run_is_checked_before_any_runs(tmp_path, capsys):
    """An element count that cannot fit is refused before the first run (the study ran four, then failed
    at the last one and kept nothing)."""
    assert main([*RU, "--elements", "4", "1000000000", "--out", str(tmp_path)]) == 2
    captured = capsys.readouterr()
    assert "run n_elements" not in captured.out
    lines = rodfem_lines(captured.err)
    assert len(lines) == 1 and lines[0].startswith("rodfem: error: --elements 1000000000: n_elements = 1000000000 "
                                                   "needs about"), lines
    assert not tmp_path.exists() or not list(tmp_path.iterdir())


def test_finished_runs_are_kept_when_a_later_one_fails(tmp_path, capsys, monkeypatch):
    """A run that ends the study (an output or input error, an interrupt) leaves study.csv with the runs
    finished before it; the others are marked not run."""
    from rodfem.app import study as study_module
    from rodfem.errors import InputError
    real = study_module._run

    def failing(scene, p, n, dt, repeats=1):
        if dt < 0.02:
            raise InputError("the disk is full (simulated)")
        return real(scene, p, n, dt, repeats)
    monkeypatch.setattr(study_module, "_run", failing)
    assert main([*RU, "--dt", "0.05", "0.025", "0.0125", "--elements", "4", "--out", str(tmp_path)]) == 2
    assert rodfem_lines(capsys.readouterr().err) == [
        f"rodfem: error: the disk is full (simulated); results so far kept in {tmp_path}/"]
    with open(tmp_path / "study.csv") as f:
        rows = {float(r["dt"]): r for r in csv.DictReader(f)}
    assert rows[0.05]["status"] == rows[0.025]["status"] == "completed" and float(rows[0.025]["error"]) > 0
    assert rows[0.0125]["status"] == "error" and "disk is full" in rows[0.0125]["failure"]
    assert json.loads((tmp_path / "study.json").read_text())["status"] == "error"


def test_a_scene_without_elements_is_studied_along_dt(tmp_path, capsys):
    """four-particle has no n_elements: study runs the dt path (second order: the springs' discrete
    gradient and the midpoint kinematics) and refuses --elements in one line."""
    from rodfem.errors import ParameterError
    study = run_study("four-particle", {"t_end": 0.5}, out=str(tmp_path / "s"), dts=[0.02, 0.01, 0.005],
                      plot=False, quiet=True)
    assert list(study["paths"]) == ["dt"]
    assert 1.8 <= study["orders"]["dt"]["order"] <= 2.6, study["orders"]
    with pytest.raises(ParameterError, match="--elements: this scene has no n_elements"):
        run_study("four-particle", {"t_end": 0.5}, out=str(tmp_path / "e"), elements=[2, 4], plot=False, quiet=True)
