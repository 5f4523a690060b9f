"""Checkpoint and restart (rodfem/io/checkpoint.py): a resumed run repeats the uninterrupted one bit by
bit (serial, chord Newton, a killed run, mpirun -n 2), every file of it for dissipating and actuated
scenes, a 2-rank checkpoint restarts on one process to round-off, and bad input is one line."""
import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from processes import REPO, command, environment, history, ok, popen, rodfem_lines

from rodfem import Support
from rodfem.app.cli import main
from rodfem.errors import Interrupted
from rodfem.io.output import clean_time
from rodfem.io.vtk import read_pvd, read_vtp


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
    p = popen([*command("run", "flying-spaghetti-2d", *sets, "--quiet", "--out", killed)], env=env,
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
        lines = rodfem_lines(capsys.readouterr().err)
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
    lines = rodfem_lines(capsys.readouterr().err)
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
    lines = rodfem_lines(capsys.readouterr().err)
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


# -- dissipating and actuated scenes: every file of a resumed run (issue 22) --------------------------
#
# A run of a scene is stopped after step `stop` and resumed; every file it leaves is compared with the
# uninterrupted run's (`same_run`), and the resumed run is checked on its own (`consistent`): the energy
# balance over the whole run with the column `dissipated`, the frames at the levels its parameters ask
# for, each written once, each at its time, the animation with every frame.  The stop is in process
# and deterministic: "killed" ends the run between two steps (or after its last step, before its
# summary and pictures) with nothing more written, as a SIGKILL does; "interrupted" with the
# Interrupted of a SIGINT (summary.json "interrupted", the pictures drawn).

class Killed(BaseException):
    """A SIGKILL, in process (not an Exception: nothing in rodfem catches it, nothing more is written)."""


def stop_after(monkeypatch, stop, how):
    """The run stops after step `stop` (its row, frame and checkpoint written): killed or interrupted
    before the next step, or killed before the summary and pictures ("killed-at-the-end")."""
    from types import SimpleNamespace

    from rodfem.analysis import timeloop
    from rodfem.io.output import RunWriter
    real = timeloop.interrupts

    def check(comm, n, t, where=None):
        if n == stop:
            raise Killed() if how == "killed" else Interrupted(signal.SIGINT, n, t)
        real.check(comm, n, t, where)

    def finish(self, summary, result):
        raise Killed()
    if how == "killed-at-the-end":
        monkeypatch.setattr(RunWriter, "finish", finish)
    else:
        monkeypatch.setattr(timeloop, "interrupts", SimpleNamespace(check=check))


def driven_hub_arm():
    """A multibody scene with a driven joint and dissipation: a viscoelastic planar beam (a Maxwell
    branch) pinned at the origin and turned there by a driven `angle` joint (theta(t) = w t^2/2), a
    point mass pinned at its free end."""
    from rodfem.app.scene import Parameter, Scene, common
    from rodfem.core.joints import ground
    from rodfem.core.system import System
    from rodfem.forms import joints, planar_beam
    from rodfem.forms.rigid_body import PointMass

    def build(p, comm):
        s = System(integrator=p["integrator"], comm=comm)
        beam = planar_beam.PlanarBeam(1.0, 0.01, planar_beam.quadratic(EA=1e3, GA=1e3, EI=10.0),
                                      branches=[planar_beam.maxwell(p["tau1"], EA=100.0, GA=100.0, EI=1.0)])
        arm = s.add("arm", beam, shape=planar_beam.straight((0.0, 0.0), (1.0, 0.0)), n_elements=p["n_elements"],
                    supports=[Support("left", "pinned")])
        tip = s.add("tip", PointMass(0.5, dim=2), initial=PointMass.initial((1.0, 0.0)))
        s.join(joints.angle, ground((0.0, 0.0)), arm.start, name="hub", drive=lambda t: [0.5 * p["w"] * t * t])
        s.join(joints.pin, arm.end, tip.point(), name="tip_pin")
        s.marker("tip", arm.end)
        return s
    return Scene("driven-hub-arm", "viscoelastic arm turned by a driven hub joint, a point mass at its end",
                 common(n_elements=4, dt=0.02, t_end=0.24) + [Parameter("w", 20.0, "1/s^2", "hub acceleration"),
                                                              Parameter("tau1", 0.05, "s", "relaxation time", low=0)],
                 build)


# scene, parameters: 12 steps, frames at the even steps 0, 2, ..., 12 (COMMON), checkpoints every 4 steps
RESUMED = {
    "viscoelastic-cantilever-2d": ("viscoelastic-cantilever-2d",   # Maxwell branch (Gamma_1, kappa_1), tip force
                                   dict(n_elements=4, dt=0.01, t_end=0.12, t_load=0.06, fy=-10)),
    "viscoelastic-string": ("viscoelastic-string",                 # Maxwell branch C_1, discrete gradient, gravity
                            dict(n_elements=4, dt=0.05, t_end=0.6)),
    "viscoelastic-cantilever-3d": ("viscoelastic-cantilever-3d",   # 3D rod, Maxwell branch on M, wrench pulse
                                   dict(n_elements=2, dt=0.005, t_end=0.06, t_load=0.03)),
    "soft-arm-swing": ("soft-arm-swing",                           # 3D rod, a chamber and a tendon in turn
                       dict(n_elements=3, dt=0.05, t_end=0.6, t_on=0.1)),
    "driven-hub-arm": (driven_hub_arm(), {}),                      # two bodies, a driven joint, dissipation
    "four-particle": ("four-particle", dict(dt=0.05, t_end=0.6)),  # springs, a damper, links; discrete gradient
    "robot-arm-control": ("robot-arm-control",                     # PID at the hub: a moving set point, an integral
                          dict(n_elements=4, dt=0.05, t_end=0.6, t_move=0.5, controller="pid")),
    "chain-13": ("chain-1000", dict(n_links=13, dt=0.01, t_end=0.12)),  # 13 links: one file per frame for all
}
COMMON = dict(checkpoint_every=4, frames=7)
# how a run stops: checkpoint_every, the step after which it stops, how, the step its summary.json names
STOPS = {
    "killed-two-steps-after-a-checkpoint": (4, 6, "killed", 4),     # rows and frame of steps 5, 6 written again
    "interrupted-at-a-checkpoint": (4, 8, "interrupted", 8),        # the frame at step 8 kept, not written twice
    "killed-at-the-end": (4, 12, "killed-at-the-end", 8),           # nothing left to run: summary and pictures
    "killed-after-a-checkpoint-between-two-frames": (3, 5, "killed", 3),   # frames 0-2 kept, 3 (step 6) written
}


def run_to_the_end(scene, params, out, resume=None):
    """Run `scene` with `params` (over COMMON) into `out`, or resume the run there (params: t_end only)."""
    from rodfem.app.driver import run_scene
    run_scene(scene, params if resume else {**COMMON, **params}, out=str(out), resume=resume)


# -- what a run leaves: compared file by file --

NOT_COMPARED = {
    ".rodfem.lock": "the pid of the last process that ran in the directory",
}
SUMMARY_NOT_COMPARED = {
    "wall_time_s": "the time of the last process only (a resumed run's from the restart)",
    "time_per_step_ms": "wall_time_s per step",
}
PICTURES = ("shapes.png", "energy.png", "animation.gif")   # the same bytes in serial, else there


def files(path):
    return sorted(os.path.relpath(os.path.join(d, f), path) for d, _, fs in os.walk(path) for f in fs
                  if f not in NOT_COMPARED)


def table(path):
    """history.csv as (header, {column: array})."""
    with open(os.path.join(path, "history.csv"), newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], {k: np.array([float(r[i]) for r in rows[1:]]) for i, k in enumerate(rows[0])}


def difference(a, b):
    """max |a - b| / max(max |a|, 1) of two arrays of the same shape (asserted)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape, (a.shape, b.shape)
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(a)), 1.0)) if a.size else 0.0


def same_numbers(a, b, rtol, where, diffs):
    """Nested JSON values a, b: the same keys, lengths, strings; numbers to rtol of max(|a|, 1)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), (where, a, b)
        for k in a:
            same_numbers(a[k], b[k], rtol, f"{where}.{k}", diffs)
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), (where, a, b)
        for i, (x, y) in enumerate(zip(a, b)):
            same_numbers(x, y, rtol, f"{where}[{i}]", diffs)
    elif isinstance(a, (int, float)) and not isinstance(a, bool):
        diffs[where] = d = difference(a, b)
        assert d <= rtol, (where, a, b)
    else:
        assert a == b, (where, a, b)


def largest(diffs, key, d, rtol, where):
    diffs[key] = max(diffs.get(key, 0.0), d)
    assert d <= rtol, (where, key, d)


def same_run(full, resumed, rtol):
    """Every file of the run in `resumed` is that of the run in `full`: history.csv column by column,
    every .pvd collection entry by entry and every frame file it names array by array (and no other
    frame file), summary.json (but SUMMARY_NOT_COMPARED), fields.json, checkpoint.npz key by key:
    numbers to rtol of their scale (rtol = 0: the same bits, and then the pictures the same bytes).
    Returns {what: largest relative difference}."""
    diffs = {}
    names = files(full)
    assert files(resumed) == names
    header, a = table(full)
    header_b, b = table(resumed)
    assert header == header_b and len(a["t"]) == len(b["t"])
    for k in header:
        largest(diffs, f"history.csv:{k}", difference(a[k], b[k]), rtol, k)
    frames = set()
    pvds = [pvd for pvd in ("centreline.pvd", "surface.pvd", "joints.pvd") if pvd in names]
    for pvd in pvds:
        entries = read_pvd(os.path.join(full, pvd))
        assert read_pvd(os.path.join(resumed, pvd)) == entries, pvd   # times (repr), parts, files, bodies
        for *_, name, _ in entries:
            x, y = read_vtp(os.path.join(full, name)), read_vtp(os.path.join(resumed, name))
            frames.add(name)
            largest(diffs, "frames:points", difference(x.points, y.points), rtol, name)
            for cells in ("verts", "lines", "polys"):
                p, q = getattr(x, cells), getattr(y, cells)
                assert len(p) == len(q) and all(np.array_equal(u, v) for u, v in zip(p, q)), (name, cells)
            for data in ("point_data", "cell_data"):
                u, v = getattr(x, data), getattr(y, data)
                assert list(u) == list(v), (name, data)
                for k in u:
                    assert u[k].components == v[k].components, (name, k)
                    largest(diffs, f"frames:{data}:{k}", difference(u[k].values, v[k].values), rtol, name)
    assert {n for n in names if os.path.dirname(n) in ("centreline", "surface", "joints")} == frames   # none unnamed
    with open(os.path.join(full, "summary.json")) as f, open(os.path.join(resumed, "summary.json")) as g:
        s, r = json.load(f), json.load(g)
    for k in SUMMARY_NOT_COMPARED:
        del s[k], r[k]
    same_numbers(s, r, rtol, "summary.json", diffs)
    with open(os.path.join(full, "fields.json")) as f, open(os.path.join(resumed, "fields.json")) as g:
        same_numbers(json.load(f), json.load(g), rtol, "fields.json", diffs)
    with np.load(os.path.join(full, "checkpoint.npz")) as z, np.load(os.path.join(resumed, "checkpoint.npz")) as w:
        assert sorted(z.files) == sorted(w.files)
        same_numbers(json.loads(z["meta"].tobytes().decode()), json.loads(w["meta"].tobytes().decode()), rtol,
                     "checkpoint.npz:meta", diffs)
        for k in z.files:
            if k != "meta":
                largest(diffs, "checkpoint.npz:arrays", difference(z[k], w[k]), rtol, k)
    for name in PICTURES:
        with open(os.path.join(full, name), "rb") as f, open(os.path.join(resumed, name), "rb") as g:
            same, written = f.read() == g.read(), os.path.getsize(os.path.join(resumed, name)) > 0
        assert written and (same or rtol > 0), f"{name}: {'other bytes' if written else 'empty'}"
    views = [name for name in ("view.py",) if name in names]     # ParaView script: its ranges from the frames
    for name in views:
        with open(os.path.join(full, name)) as f, open(os.path.join(resumed, name)) as g:
            assert f.read() == g.read() or rtol > 0, name
    compared = {"history.csv", *pvds, "summary.json", "fields.json", "checkpoint.npz", *frames, *PICTURES, *views}
    assert set(names) == compared, set(names) - compared          # every file looked at
    return diffs


def consistent(path, resumed_at):
    """The run in `path` on its own: H(T) - H(0) + dissipated(T) - supplied(T) is the sum of the steps'
    balance errors (each at solver tolerance), dissipated grows at every step (a dissipating run); the
    frames are at the times frame_plan(n, frames) of its parameters (a level's time, or interpolated
    between two levels), each time and body once, each in its own file, the one at the restart
    `resumed_at` too (if a level), the first body's end at a level at history.csv's `tip`;
    animation.gif has a picture per frame."""
    from PIL import Image

    from rodfem.io.output import frame_plan
    with open(os.path.join(path, "summary.json")) as f:
        params = json.load(f)["parameters"]
    _, h = table(path)
    n_steps, dt = len(h["t"]) - 1, params["dt"]
    assert np.array_equal(h["t"], np.arange(n_steps + 1) * dt)    # t_n = n dt, every level once
    scale = np.max(np.abs(h["H"]))
    balance = h["H"][-1] - h["H"][0] + h.get("dissipated", np.zeros(1))[-1] - h["supplied"][-1]
    assert np.max(np.abs(h["balance_error"])) <= 1e-10 * scale
    assert abs(balance - np.sum(h["balance_error"])) <= 1e-12 * scale, (balance, np.sum(h["balance_error"]))
    if "dissipated" in h:
        assert h["dissipated"][0] == 0 and np.all(np.diff(h["dissipated"]) > 0), h["dissipated"]
    plan = frame_plan(n_steps, params["frames"])
    levels = [n for n, theta in plan if theta == 0]
    times = [clean_time(h["t"][n] + theta * (h["t"][n + 1] - h["t"][n]) if theta else h["t"][n]) for n, theta in plan]
    for pvd in ("centreline.pvd", "surface.pvd"):
        entries = read_pvd(os.path.join(path, pvd))
        parts = sorted({(part, name) for _, part, _, name in entries})
        assert [(t, part, name) for t, part, _, name in entries] == \
            [(t, part, name) for t in times for part, name in parts]
        assert len({f for _, _, f, _ in entries}) == len(entries)        # no file shared by two entries
        assert sum(t == clean_time(resumed_at * dt) for t, *_ in entries) == (len(parts) if resumed_at in levels else 0)
        for t, part, file, name in entries:
            assert os.path.isfile(os.path.join(path, file)), file
            n = int(round(t / dt))
            poly = read_vtp(os.path.join(path, file))
            if pvd == "centreline.pvd" and "tip_x" in h and part == 0 and clean_time(n * dt) == t \
                    and "bodies" not in poly.field_data:   # `tip` (not a file of many bodies' centres)
                end = poly.points[-1]
                tip = [h[f"tip_{c}"][n] for c in "xyz" if f"tip_{c}" in h]
                assert np.allclose(end[:len(tip)], tip, rtol=0, atol=1e-12 * max(np.max(np.abs(tip)), 1.0)), (t, file)
    with Image.open(os.path.join(path, "animation.gif")) as gif:
        assert gif.n_frames == len(plan)


@pytest.mark.parametrize("case, stop", [(c, s) for c in RESUMED for s in list(STOPS)[:3]]
                         + [("viscoelastic-cantilever-2d", "killed-after-a-checkpoint-between-two-frames")])
def test_every_file_of_a_resumed_dissipating_or_actuated_run(case, stop, monkeypatch, tmp_path):
    """A dissipating or actuated run stopped (STOPS) and resumed leaves the files of the uninterrupted
    run to the bit: history.csv with `dissipated` and `supplied`, the frames, summary.json but its wall
    times, fields.json, the last checkpoint, the pictures; its energy balance holds over the restart
    and its frames are those its parameters ask for, each once.  (Measured: no difference at all.)"""
    scene, params = RESUMED[case]
    every, after, how, noted = STOPS[stop]
    params = {**params, "checkpoint_every": every}
    full, part = tmp_path / "full", tmp_path / "part"
    run_to_the_end(scene, params, full)
    with monkeypatch.context() as m:
        stop_after(m, after, how)
        with pytest.raises(Interrupted if how == "interrupted" else Killed):
            run_to_the_end(scene, params, part)
    status = json.loads((part / "summary.json").read_text())
    assert status["status"] == ("interrupted" if how == "interrupted" else "running") and status["steps"] == noted
    _, h = table(part)
    assert len(h["t"]) == after + 1 and read_pvd(part / "centreline.pvd")[-1][0] == clean_time(h["t"][after // 2 * 2])
    # rows and frames (at even steps) up to the stop
    run_to_the_end(scene, {}, part, resume=str(part))
    diffs = same_run(full, part, rtol=0.0)
    consistent(part, after // every * every)
    print(case, stop, {k: v for k, v in diffs.items() if v})


def test_a_frame_between_two_levels_across_a_checkpoint(monkeypatch, tmp_path):
    """Frames between time levels (frames = 6 over 12 steps: t_j at levels 0, 2.4, 4.8, ...): a run killed
    one step after its checkpoint at level 2 and resumed writes the frame at level 2.4 (interpolated
    between the checkpoint's state and the next) as the uninterrupted run does, to the bit."""
    scene, params = RESUMED["viscoelastic-cantilever-2d"]
    params = {**params, "checkpoint_every": 2, "frames": 6}
    full, part = tmp_path / "full", tmp_path / "part"
    run_to_the_end(scene, params, full)
    with monkeypatch.context() as m:
        stop_after(m, 3, "killed")
        with pytest.raises(Killed):
            run_to_the_end(scene, params, part)
    run_to_the_end(scene, {}, part, resume=str(part))
    same_run(full, part, rtol=0.0)
    consistent(part, 2)
    assert [t for t, *_ in read_pvd(part / "centreline.pvd")] == [0.0, 0.024, 0.048, 0.072, 0.096, 0.12]


@pytest.mark.mpi
def test_mpi_a_dissipating_run_resumed_on_one_process(rodfem, tmp_path):
    """viscoelastic-cantilever-2d run by mpirun -n 2 to t = 0.06 (its last checkpoint at step 4) and
    resumed by one process to t = 0.12 leaves every file of the serial uninterrupted run to 1e-12 of
    each array's scale (the two ranks' assembly sums in another order; measured 1e-14), `dissipated`
    carried over: the energy balance holds over the restart."""
    scene, params = RESUMED["viscoelastic-cantilever-2d"]
    params = {**params, "frames": 100}        # every level a frame, whatever t_end
    full, part = tmp_path / "full", tmp_path / "part"
    run_to_the_end(scene, params, full)
    sets = [x for k, v in {**COMMON, **params, "t_end": 0.06}.items() for x in ("--set", f"{k}={v}")]
    ok(rodfem("run", scene, *sets, "--quiet", "--out", part, np=2, timeout=300))
    with open(part / "summary.json") as f:
        assert json.load(f)["mpi_ranks"] == 2
    run_to_the_end(scene, {"t_end": 0.12}, part, resume=str(part))
    diffs = same_run(full, part, rtol=1e-12)
    consistent(part, 4)
    print({k: v for k, v in diffs.items() if v})


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__]))
