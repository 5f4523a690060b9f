"""Checkpoint and restart (rodfem/io/checkpoint.py): a resumed run repeats the uninterrupted one bit by
bit (serial, chord Newton, a killed run, mpirun -n 2), a 2-rank checkpoint restarts on one
process to round-off, and bad input is one line."""
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from processes import REPO, command, environment, history, ok

from rodfem.app.cli import main


def same_file(a, b):
    with open(os.path.join(a, "history.csv"), "rb") as fa, open(os.path.join(b, "history.csv"), "rb") as fb:
        return fa.read() == fb.read()


@pytest.mark.parametrize("scene, args", [
    ("flying-spaghetti-2d", ["dt=0.1"]),
    ("flying-spaghetti-3d", ["dt=0.1"]),     # chord Newton: the lagged Jacobian restarts at checkpoints
])
def test_resumed_run_equals_the_uninterrupted_one(tmp_path, scene, args):
    """Run to t = 1 with checkpoints every 5 steps; run to t = 0.7 (its last checkpoint is step 5:
    rows 6, 7 are dropped on resume) and resume it to t = 1: history.csv is the same file."""
    sets = [x for a in args + ["checkpoint_every=5"] for x in ("--set", a)]
    full, part = str(tmp_path / "full"), str(tmp_path / "part")
    assert main(["run", scene, *sets, "--set", "t_end=1", "--quiet", "--out", full]) == 0
    assert main(["run", scene, *sets, "--set", "t_end=0.7", "--quiet", "--out", part]) == 0
    with np.load(os.path.join(part, "checkpoint.npz")) as z:
        assert json.loads(z["meta"].tobytes().decode())["step"] == 5
    assert main(["run", "--resume", part, "--set", "t_end=1", "--quiet"]) == 0
    assert same_file(full, part)
    s = json.loads(open(os.path.join(part, "summary.json")).read())
    assert s["steps"] == 10 and s["status"] == "completed"


def test_a_killed_run_resumes_from_its_last_checkpoint(rodfem, tmp_path):
    """SIGKILL at some moment after the first checkpoint: summary.json says how far it got,
    history.csv has whole rows up to the kill, and --resume reproduces the full run."""
    env = environment()
    sets = ["--set", "dt=0.002", "--set", "t_end=10", "--set", "checkpoint_every=250", "--set", "frames=20"]
    full, killed = str(tmp_path / "full"), str(tmp_path / "killed")
    ok(rodfem("run", "flying-spaghetti-2d", *sets, "--quiet", "--out", full))
    p = subprocess.Popen([*command("run", "flying-spaghetti-2d", *sets, "--quiet", "--out", killed)], env=env,
                         cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t0 = time.time()
    while not os.path.exists(os.path.join(killed, "checkpoint.npz")) and time.time() - t0 < 300:
        time.sleep(0.05)
    time.sleep(0.5)
    p.send_signal(signal.SIGKILL)
    p.wait()
    status = json.loads(open(os.path.join(killed, "summary.json")).read())
    assert status["status"] == "running", status          # killed before the end (5000 steps take ~3 s)
    assert status["steps"] % 250 == 0 and 0 < status["checkpoint"]["step"] == status["steps"] < 5000
    ok(rodfem("run", "--resume", killed, "--quiet"))
    assert same_file(full, killed)


@pytest.mark.mpi
def test_mpi_resume_and_two_ranks_to_one(rodfem, tmp_path):
    """mpirun -n 2: a resumed run equals the uninterrupted one bit by bit (a mechanism: the joints'
    rows come from rank 0), with the parallel solver of a run without checkpoints (reported in
    summary.json); the 2-rank checkpoint continued on 1 process agrees to 1e-12."""
    sets = ["--set", "checkpoint_every=4", "--set", "n_elements=4"]
    full, part = str(tmp_path / "full"), str(tmp_path / "part")
    ok(rodfem("run", "four-bar-2d", *sets, "--set", "t_end=0.4", "--quiet", "--out", full, np=2))
    ok(rodfem("run", "four-bar-2d", *sets, "--set", "t_end=0.24", "--quiet", "--out", part, np=2))
    serial = str(tmp_path / "serial")
    shutil.copytree(part, serial)
    ok(rodfem("run", "--resume", part, "--set", "t_end=0.4", "--quiet", np=2))
    assert same_file(full, part)
    with open(os.path.join(part, "summary.json")) as f:
        assert json.load(f)["linear_solver"].startswith("schur")
    ok(rodfem("run", "--resume", serial, "--set", "t_end=0.4", "--quiet"))
    a, b = history(full), history(serial)
    for k in a:
        scale = max(np.max(np.abs(a[k])), 1.0)
        assert np.max(np.abs(a[k] - b[k])) <= 1e-12 * scale, k


def test_bad_resume_input(capsys, tmp_path):
    def one_line_error(args, *words):
        capsys.readouterr()
        assert main(args) == 2
        lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
        assert len(lines) == 1 and all(w in lines[0] for w in words), lines
    empty = tmp_path / "empty"
    empty.mkdir()
    one_line_error(["run", "--resume", str(empty)], "no checkpoint", "checkpoint_every")
    one_line_error(["run", "--resume", str(tmp_path / "missing")], "no checkpoint")
    good = str(tmp_path / "good")
    assert main(["run", "flying-spaghetti-2d", "--set", "t_end=0.3", "--set", "checkpoint_every=1", "--quiet",
                 "--out", good]) == 0
    one_line_error(["run", "roll-up-2d", "--resume", good], "scene flying-spaghetti-2d", "not roll-up-2d")
    one_line_error(["run", "--resume", good, "--set", "EA=5"], "only t_end")
    one_line_error(["run", "flying-spaghetti-2d", "--set", "checkpoint_every=x", "--out", good],
                   "'checkpoint_every'")
    # a checkpoint of another rodfem version
    path = os.path.join(good, "checkpoint.npz")
    with np.load(path) as z:
        data = {k: z[k] for k in z.files}
    meta = json.loads(data["meta"].tobytes().decode())
    meta["rodfem_version"] = "0.0.1"
    data["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    with open(path, "wb") as f:
        np.savez(f, **data)
    one_line_error(["run", "--resume", good], "rodfem 0.0.1", "cannot continue")
    with open(path, "wb") as f:
        f.write(b"not a checkpoint")
    one_line_error(["run", "--resume", good], "unreadable")


FS = ["flying-spaghetti-2d", "--set", "n_elements=4", "--set", "checkpoint_every=2", "--quiet"]


def finished(path, *sets):
    """A finished run of FS to t = 0.5 (5 steps, checkpoint at step 4) in `path`; (summary.json, history.csv) texts."""
    assert main(["run", *FS, "--set", "t_end=0.5", *sets, "--out", str(path)]) == 0
    return record(path)


def record(path):
    return tuple((path / name).read_text() for name in ("summary.json", "history.csv"))


def swap_arrays(path, other):
    """The checkpoint in `path` with its own meta but the fields of the checkpoint in `other`."""
    with np.load(path / "checkpoint.npz") as z, np.load(other / "checkpoint.npz") as w:
        data = {k: w[k] for k in w.files}
        data["meta"] = z["meta"]
    with open(path / "checkpoint.npz", "wb") as f:
        np.savez(f, **data)


@pytest.mark.parametrize("case", ["t_end-before-the-checkpoint", "wrong-shape"])
def test_a_refused_resume_keeps_the_record(case, capsys, tmp_path):
    """A --resume refused for its t_end or a checkpoint that does not fit the mesh leaves the finished
    run's summary.json and history.csv as they were (summary.json said "running", with the rejected
    t_end and the pid of the refused process)."""
    run = tmp_path / "run"
    kept = finished(run)
    if case == "wrong-shape":
        finished(tmp_path / "other", "--set", "n_elements=6")
        swap_arrays(run, tmp_path / "other")
    capsys.readouterr()
    assert main(["run", "--resume", str(run), *(["--set", "t_end=0.1"] if case != "wrong-shape" else [])]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and ("is before the checkpoint's time" in lines[0] or "does not fit" in lines[0]), lines
    assert record(run) == kept


@pytest.mark.parametrize("other", ["another-scene", "another-run-of-the-scene"])
def test_a_checkpoint_copied_from_another_run_is_refused(other, capsys, tmp_path):
    """A checkpoint copied in from another run (another scene, or the same scene with other parameters)
    is refused in one line instead of resuming it on top of this directory's history."""
    run, source = tmp_path / "run", tmp_path / "source"
    kept = finished(run)
    if other == "another-scene":
        assert main(["run", "roll-up-2d", "--set", "n_elements=4", "--set", "t_end=0.5", "--set", "dt=0.1",
                     "--set", "checkpoint_every=2", "--quiet", "--out", str(source)]) == 0
    else:
        finished(source, "--set", "EA=5000")
    shutil.copy(source / "checkpoint.npz", run / "checkpoint.npz")
    capsys.readouterr()
    assert main(["run", "--resume", str(run), "--set", "t_end=1"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "copied from another run?" in lines[0], lines
    assert ("scene roll-up-2d" if other == "another-scene" else "EA = 5000.0") in lines[0]
    assert record(run) == kept
    # without summary.json, history.csv tells: its row at the checkpoint's step is not the checkpoint's state
    os.unlink(run / "summary.json")
    assert main(["run", "--resume", str(run), "--set", "t_end=1"]) == 2
    assert "is not of the run in" in capsys.readouterr().err
    assert (run / "history.csv").read_text() == kept[1]


@pytest.mark.mpi
def test_mpi_a_refused_resume_keeps_the_record(rodfem, tmp_path):
    run = tmp_path / "run"
    ok(rodfem("run", *FS, "--set", "t_end=0.5", "--out", run, np=2, timeout=300))
    kept = record(run)
    p = rodfem("run", "--resume", run, "--set", "t_end=0.1", "--quiet", np=2, timeout=300)
    assert p.returncode == 2 and "is before the checkpoint's time" in p.stderr, p.stderr[-3000:]
    other = tmp_path / "other"
    ok(rodfem("run", *FS, "--set", "t_end=0.5", "--set", "n_elements=6", "--out", other, np=2, timeout=300))
    swap_arrays(run, other)
    p = rodfem("run", "--resume", run, "--quiet", np=2, timeout=300)
    assert p.returncode == 2 and "does not fit" in p.stderr, p.stderr[-3000:]   # 124: a rank left waiting
    assert record(run) == kept


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__]))
