"""Issue 13: every failure ends with one line on stderr and its exit code (2 bad input or
environment, 3 numerical failure, 130/143 interrupted), under mpirun too, and leaves a
recognisable output directory.  Small sizes: a few steps, a few elements."""
import csv
import fcntl
import glob
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from processes import REPO, RODFEM, command, environment, holding_the_lock, popen, rodfem, rodfem_lines, summary

from rodfem.app.cli import main

RU = ["roll-up-2d", "--set", "t_end=0.05", "--set", "dt=0.01", "--set", "n_elements=4", "--quiet"]
LONG = ["flying-spaghetti-2d", "--set", "n_elements=4", "--set", "t_end=1000", "--set", "dt=0.01", "--quiet"]


def one_line(stderr, start="rodfem: error:"):
    """The single line on stderr (asserted), starting with `start`."""
    lines = rodfem_lines(stderr)
    assert len(lines) == 1 and lines[0].startswith(start), stderr[-3000:]
    return lines[0]


def rows(out, name="history.csv"):
    """The rows of history.csv (or another CSV file of the run)."""
    with open(os.path.join(out, name)) as f:
        return list(csv.DictReader(f))


def leftovers(out):
    """Half-written files: temporaries and empty files."""
    files = glob.glob(os.path.join(out, "**", "*"), recursive=True) + glob.glob(os.path.join(out, "**", ".*.tmp"),
                                                                               recursive=True)
    return [f for f in files if f.endswith(".tmp") or (os.path.isfile(f) and os.path.getsize(f) == 0
                                                       and not f.endswith(".rodfem.lock"))]


# -- bad input: refused before anything runs ----------------------------

@pytest.mark.parametrize("args, words", [
    pytest.param(["run", *RU, "--set", "dt=1e-300"], ["'dt'", "steps", "limit of 1e+07"], id="too-many-steps"),
    pytest.param(["run", *RU, "--set", "t_end=1e12", "--set", "dt=1"], ["'dt'", "1e+12 steps"], id="t_end-too-long"),
    pytest.param(["run", "flying-spaghetti-2d", "--set", "t_end=1e-9", "--set", "dt=7e-10"], ["'dt'", "whole number"],
                 id="dt-not-a-divisor"),
    pytest.param(["run", *RU, "--set", "t_end=10.000001", "--set", "dt=1e-6"],
                 ["t_end/dt = 10000001 steps, more than the limit of 1e+07"], id="just-above-the-limit"),
    pytest.param(["run", *RU, "--set", "t_end=1.0000001", "--set", "dt=0.1"], ["(t_end/dt = 10.000001)"],
                 id="almost-whole"),
    pytest.param(["run", *RU, "--set", "n_elements=1e20"], ["n_elements", "GB", "elements fit"], id="mesh-too-large"),
    pytest.param(["run", *RU, "--set", "n_elements=2.5"], ["'n_elements'", "integer"], id="elements-not-integer"),
    pytest.param(["run", *RU, "--set", "t_end=1e308", "--set", "dt=1e-308"], ["'dt'", "limit"], id="float-overflow"),
    pytest.param(["study", "roll-up-2d", "--dt", "0", "--elements", "4"], ["--dt 0", "> 0"], id="study-dt-zero"),
    pytest.param(["static", "roll-up-2d", "--load-steps", "1000000000"],
                 ["--load-steps 1e+09: more than the limit of 1e+07 load steps"], id="static-too-many-load-steps"),
])
def test_bad_input_is_refused_in_one_line(args, words, capsys, tmp_path):
    out = tmp_path / "out"
    assert main([*args, "--out", str(out)]) == 2
    line = one_line(capsys.readouterr().err)
    for w in words:
        assert w in line
    # refused before the output directory is touched, or (found while building) recorded there
    assert not out.exists() or summary(out)["status"] == "error"


@pytest.mark.parametrize("where", ["file", "/proc/x", "long", "/sys/rodfem"])
def test_bad_out_is_one_line(where, capsys, tmp_path):
    (tmp_path / "file").write_text("not a directory")
    out = {"file": str(tmp_path / "file"), "long": str(tmp_path / ("a" * 300))}.get(where, where)
    assert main(["run", *RU, "--out", out]) == 2
    line = one_line(capsys.readouterr().err)
    assert line.startswith(f"rodfem: error: --out {out!r}: cannot create the directory")


def test_memory_estimate_refuses_what_cannot_fit(monkeypatch):
    from mpi4py import MPI

    from rodfem.common import limits
    from rodfem.errors import InputError
    monkeypatch.setattr(limits, "available_memory", lambda ranks=1: 1e9)
    assert limits.check_elements(10**5, 9, MPI.COMM_WORLD) == 10**5  # 0.95 GB
    with pytest.raises(InputError, match=r"n_elements = 1000000 needs about 9.45 GB .* at most about 105820"):
        limits.check_elements(10**6, 9, MPI.COMM_WORLD)


# -- the output directory and its frames ------------------------------------------------------

def test_a_directory_in_use_is_refused(capsys, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    with open(out / ".rodfem.lock", "w") as lock:
        lock.write("4242\n")
        lock.flush()
        fcntl.flock(lock, fcntl.LOCK_EX)  # another run holds it
        assert main(["run", *RU, "--out", str(out)]) == 2
        line = one_line(capsys.readouterr().err)
        assert "is in use by another rodfem run (pid 4242)" in line
        assert sorted(os.listdir(out)) == [".rodfem.lock", "centreline"]
    assert main(["run", *RU, "--out", str(out)]) == 0  # free again


def test_a_new_run_replaces_the_previous_runs_files(tmp_path):
    out = tmp_path / "out"
    fs = ["run", "flying-spaghetti-2d", "--set", "n_elements=4", "--quiet", "--out", str(out)]
    assert main([*fs, "--set", "t_end=3"]) == 0
    assert len(list((out / "centreline").glob("*.vtp"))) == 31
    (out / "notes.txt").write_text("mine")
    assert main([*fs, "--set", "t_end=2", "--set", "frames=4"]) == 0
    vtus = sorted((out / "centreline").glob("*.vtp"))
    times = [float(t) for t in re.findall(r'timestep="([^"]+)"', (out / "centreline.pvd").read_text())]
    assert len(vtus) == 4 and len(times) == 4 and times[0] == 0.0 and times[-1] == pytest.approx(2.0)
    assert len(rows(out)) == 21 and summary(out)["parameters"]["t_end"] == 2.0
    assert summary(out)["status"] == "completed"
    assert (out / "notes.txt").read_text() == "mine" and not leftovers(out)


def test_frames_one_is_the_end_state(tmp_path):
    assert main(["run", *RU, "--set", "frames=1", "--out", str(tmp_path)]) == 0
    assert re.findall(r'timestep="([^"]+)"', (tmp_path / "centreline.pvd").read_text()) == ["0.05"]


def test_a_full_disk_is_one_line_and_keeps_a_summary(tmp_path):
    out = tmp_path / "out"
    code = ("import resource, sys\nfrom rodfem.app.cli import main\n"
            "resource.setrlimit(resource.RLIMIT_FSIZE, (12000, 12000))\n"  # after MPI_Init: files of at most
            # 12 kB (history.csv reaches it first; a frame of 4 elements is 4 to 6 kB)
            f"sys.exit(main({['run', *LONG, '--set', 't_end=10', '--out', str(out)]!r}))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=environment(), timeout=120)
    assert p.returncode == 2
    assert "cannot write history.csv (File too large)" in one_line(p.stderr)
    assert summary(out)["status"] == "error" and not leftovers(out)


# -- numerical failure and PETSc options -----------------------------------------------

def test_a_nan_residual_is_not_recorded_as_zero(capsys, tmp_path):
    args = ["run", "flying-spaghetti-2d", "--set", "n_elements=4", "--set", "Fx=1e300", "--set", "t_end=1"]
    assert main([*args, "--quiet", "--out", str(tmp_path)]) == 3
    assert "residual nan" in one_line(capsys.readouterr().err)
    s = summary(tmp_path)
    assert s["status"] == "newton-failure" and s["failure"]["residual"] == "nan"


@pytest.mark.parametrize("option, words", [
    ("-rodfem_snes_max_it abc", "PETSc refused an option"),                    # when the solver is set up
    ("-rodfem_pc_type nonexistent", "Unable to find requested PC type"),
    ("-rodfem_pc_factor_mat_solver_type nonexistent", "PETSc stopped at step 1"),  # when it first solves
])
def test_a_bad_petsc_option_is_one_line(option, words, tmp_path):
    p = rodfem("run", *RU, "--out", str(tmp_path), timeout=120, env={"PETSC_OPTIONS": option})
    assert p.returncode == 2
    line = one_line(p.stderr)
    assert words in line and option in line


# -- the API ------------------------------------------------------------------------------

def _roll_up(n=4):
    from rodfem import Load, Problem, Support, ramp
    from rodfem.forms.planar_beam import PlanarBeam, quadratic
    beam = PlanarBeam(rhoA=0.0, rhoI=0.0, energy=quadratic(EA=1e4, GA=1e4, EI=500.0))
    return Problem(beam, 10.0, n, loads=[Load("omega", ramp(2 * np.pi * 500 / 10, 1.0), "right")],
                   supports=[Support("left", "clamped")], initial={"r": lambda x: np.vstack([x[0], 0 * x[0]])})


def test_api_names_the_parameter():
    from rodfem import InputError, Problem
    from rodfem.app.driver import run_scene
    from rodfem.errors import ParameterError
    from rodfem.forms.planar_beam import PlanarBeam, quadratic
    with pytest.raises(ParameterError, match="'n_elements' must be an integer"):
        run_scene("roll-up-2d", {"n_elements": 2.5})
    with pytest.raises(ValueError, match="rhoA must be a number >= 0"):
        PlanarBeam(rhoA=-1, rhoI=1.0, energy=quadratic(EA=1.0, GA=1.0, EI=1.0))
    beam = PlanarBeam(rhoA=1.0, rhoI=1.0, energy=quadratic(EA=1.0, GA=1.0, EI=1.0))
    with pytest.raises(InputError, match="n_elements must be a whole number >= 1"):
        Problem(beam, 1.0, 0)
    with pytest.raises(InputError, match=r"initial value of field 'r'.* shape \(2, npoints\)"):
        Problem(beam, 1.0, 2, initial={"r": lambda x: x[0]})


def test_a_second_run_continues_in_time():
    from rodfem import run
    p, q = _roll_up(), _roll_up()
    run(p, 0.1, 0.5)
    second = run(p, 0.1, 1.0)
    whole = run(q, 0.1, 1.0)
    assert second.rows[0]["t"] == 0.5 and second.rows[-1]["t"] == pytest.approx(1.0) and p.t == q.t
    for k in ("tip_x", "tip_y"):
        assert second.rows[-1][k] == pytest.approx(whole.rows[-1][k], abs=1e-12)
    with pytest.raises(ValueError, match="not after the problem's time t = 1"):
        run(p, 0.1, 1.0)


# -- interrupts and the standard streams -------------------------------------------------

def wait_for_rows(out, count=20, timeout=60, name="history.csv"):
    t0 = time.time()
    while time.time() - t0 < timeout:
        try:
            if len(rows(out, name)) >= count:
                return
        except (OSError, ValueError):
            pass
        time.sleep(0.05)
    raise AssertionError(f"the run wrote no rows into {name}")


def wait_for_status(out, status="running", timeout=60):
    t0 = time.time()
    while time.time() - t0 < timeout:
        try:
            if summary(out)["status"] == status:
                return
        except (OSError, ValueError, KeyError):
            pass
        time.sleep(0.05)
    raise AssertionError(f"no summary.json with status {status!r} in {out}")


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_stops_between_steps_and_keeps_the_results(sig, code, tmp_path):
    out = str(tmp_path)
    p = popen(command("run", *LONG, "--out", out), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=environment(), cwd=REPO)
    wait_for_rows(out)
    assert summary(out)["status"] == "running"
    p.send_signal(sig)
    _, err = p.communicate(timeout=60)
    assert p.returncode == code
    line = one_line(err, "rodfem: interrupted by " + sig.name)
    s = summary(out)
    assert s["status"] == "interrupted" and s["failure"]["signal"] == sig.name
    assert len(rows(out)) == s["steps"] + 1 and f"after step {s['steps']} " in line
    assert os.path.getsize(os.path.join(out, "shapes.png")) > 1000 and not leftovers(out)


STATIC = ["static", "roll-up-2d", "--set", "n_elements=4", "--load-steps", "100000", "--fixed-steps"]


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_static_stops_between_load_steps(sig, code, tmp_path):
    """`rodfem static` stops between two load steps like `run` between time steps (it ran on to the
    end, exit 0, and a second signal did not stop it either)."""
    out = str(tmp_path)
    p = popen(command(*STATIC, "--out", out), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=environment(), cwd=REPO)
    wait_for_rows(out, name="loadsteps.csv")
    p.send_signal(sig)
    _, err = p.communicate(timeout=60)
    assert p.returncode == code, err[-3000:]
    line = one_line(err, f"rodfem: interrupted by {sig.name} after load step ")
    assert f"results so far kept in {out}/" in line
    s = summary(out)
    assert s["status"] == "interrupted" and s["failure"]["signal"] == sig.name and s["mode"] == "static"
    assert 20 <= len(rows(out, "loadsteps.csv")) < 100000 and not leftovers(out)


def test_modes_stop_before_the_eigenvalue_solve(tmp_path):
    """`rodfem modes` stops on a signal before its eigenvalue solve; its summary.json says so."""
    out = str(tmp_path)
    p = popen(command("modes", "cantilever-2d", "--set", "n_elements=100", "--out", out),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environment(), cwd=REPO)
    wait_for_status(out)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err[-3000:]
    one_line(err, "rodfem: interrupted by SIGINT")
    s = summary(out)
    assert s["status"] == "interrupted" and s["mode"] == "modes" and not os.path.exists(os.path.join(out, "modes.csv"))


def test_a_full_or_closed_stdout(tmp_path):
    full = subprocess.run(f'"{RODFEM}" run {" ".join(RU)} --out {tmp_path}/a > /dev/full', shell=True,
                          capture_output=True, text=True, env=environment())
    assert full.returncode == 2
    assert one_line(full.stderr) == "rodfem: error: cannot write to standard output (No space left on device)"
    closed = subprocess.run(f'"{RODFEM}" run {" ".join(RU)} --out {tmp_path}/b >&-', shell=True,
                            capture_output=True, text=True, env=environment())
    assert closed.returncode == 0 and closed.stderr == ""
    assert summary(tmp_path / "b")["status"] == "completed"


# -- the JIT cache, in a cache of its own -------------------------------------------------

def stale(cache):
    return [f for f in glob.glob(f"{cache}/fenics/*.c") if not os.path.exists(f + ".cached")]


def test_the_jit_cache_survives_interrupts_and_reports_damage(tmp_path):
    cache, out = tmp_path / "cache", str(tmp_path / "out")
    xdg = {"XDG_CACHE_HOME": str(cache)}
    # Ctrl-C during the first compilation (to the process group: the C compiler gets it too)
    p = popen(command("run", *RU, "--set", "t_end=100", "--out", out), stderr=subprocess.PIPE,
                         text=True, env=environment(**xdg), cwd=REPO, start_new_session=True)  # the forms of RU
    t0 = time.time()
    while not stale(cache) and time.time() - t0 < 60:
        time.sleep(0.02)
    os.killpg(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 130, err[-3000:]
    one_line(err, "rodfem: interrupted by SIGINT after step 0")
    assert summary(out)["status"] == "interrupted"
    assert rodfem("run", *RU, "--out", out, timeout=120, env=xdg).returncode == 0
    # a compilation killed outright leaves NAME.c without NAME.c.cached (and the lock file of a dead
    # process): the run removes and recompiles them; ffcx would wait 10 s for them, then fail
    markers = glob.glob(f"{cache}/fenics/libffcx_forms_*.c.cached")
    for f in markers:
        os.unlink(f)
    p = rodfem("run", *RU, "--out", out, timeout=120, env=xdg)
    assert p.returncode == 0 and "waiting" not in p.stderr, p.stderr[-3000:]
    assert not stale(cache) and all(os.path.exists(f) for f in markers)   # compiled afresh
    # the next run reuses every compiled module: none is written again, no file is added
    modules = {f: os.stat(f).st_mtime_ns for f in glob.glob(f"{cache}/fenics/*")}
    assert rodfem("run", *RU, "--out", out, timeout=120, env=xdg).returncode == 0
    assert {f: os.stat(f).st_mtime_ns for f in glob.glob(f"{cache}/fenics/*")} == modules
    # a damaged module: one line with the remedy
    for so in glob.glob(f"{cache}/fenics/libffcx_forms_*.so"):
        os.truncate(so, 100)
    p = rodfem("run", *RU, "--out", out, timeout=120, env=xdg)
    assert p.returncode == 2
    assert f"the JIT cache {cache}/fenics is damaged" in one_line(p.stderr) and "rm -rf" in p.stderr
    # a cache that cannot be created
    p = rodfem("run", *RU, "--out", out, timeout=120, env={"XDG_CACHE_HOME": os.path.join(out, "summary.json")})
    assert p.returncode == 2 and "set XDG_CACHE_HOME to a writable directory" in one_line(p.stderr)


def test_a_held_jit_cache_lock(tmp_path):
    """Another process holds the cache lock (a run compiling, stopped or stuck): a run with nothing to
    compile does not wait; one that must compile says who holds it, stops on a signal, and gives up
    after RODFEM_JIT_LOCK_TIMEOUT seconds in one line (it waited for ever, silently, deaf to signals)."""
    warm, cold, out = tmp_path / "warm", tmp_path / "cold", str(tmp_path / "out")
    assert rodfem("run", *RU, "--out", out, timeout=120, env={"XDG_CACHE_HOME": str(warm)}).returncode == 0
    with holding_the_lock(warm), holding_the_lock(cold):
        p = rodfem("run", *RU, "--out", out, timeout=60, env={"XDG_CACHE_HOME": str(warm)})
        assert p.returncode == 0 and "waiting" not in p.stderr, p.stderr[-3000:]   # all compiled: no lock needed
        lock = cold / "fenics" / "rodfem-jit.lock"
        p = rodfem("run", *RU, "--out", out, timeout=60,
                   env={"XDG_CACHE_HOME": str(cold), "RODFEM_JIT_LOCK_TIMEOUT": "1"})
        assert p.returncode == 2, p.stderr[-3000:]
        waiting, error = p.stderr.strip().splitlines()
        assert waiting.startswith(f"rodfem: waiting for the JIT cache lock {lock}, held by pid {os.getpid()}")
        assert error.startswith(f"rodfem: error: the JIT cache lock {lock} is still held by pid {os.getpid()} "
                                "after 1 s") and "RODFEM_JIT_LOCK_TIMEOUT" in error
        assert summary(out)["status"] == "error"
        p = rodfem("run", *RU, "--out", out, timeout=60, env={"XDG_CACHE_HOME": str(cold),
                                                             "RODFEM_JIT_LOCK_TIMEOUT": "soon"})
        assert one_line(p.stderr) == "rodfem: error: RODFEM_JIT_LOCK_TIMEOUT must be a number of seconds >= 0 " \
                                     "(got 'soon')"
        p = popen(command("run", *RU, "--out", out), stderr=subprocess.PIPE, text=True, cwd=REPO,
                             env=environment(XDG_CACHE_HOME=str(cold)))
        assert p.stderr.readline().startswith("rodfem: waiting for the JIT cache lock")
        p.send_signal(signal.SIGTERM)
        _, err = p.communicate(timeout=60)
        assert p.returncode == 143
        one_line(err, "rodfem: interrupted by SIGTERM while waiting for the JIT cache lock")
        assert summary(out)["status"] == "interrupted"
        assert not [f for f in os.listdir(cold / "fenics") if f.startswith("libffcx")]   # it compiled nothing
    assert rodfem("run", *RU, "--out", out, timeout=120, env={"XDG_CACHE_HOME": str(cold)}).returncode == 0


# -- under mpirun -n 2: the ranks agree, none is left waiting ----------------------

@pytest.mark.mpi
@pytest.mark.parametrize("case, words", [
    ("out-is-a-file", "cannot create the directory"),
    ("one-element", "n_elements = 1 is fewer than the 2 MPI ranks"),
    ("petsc-option", "Unable to find requested PC type"),
])
def test_mpi_errors_are_agreed(case, words, tmp_path):
    (tmp_path / "file").write_text("")
    args = {"out-is-a-file": ["--out", str(tmp_path / "file")],
            "one-element": ["--set", "n_elements=1", "--out", str(tmp_path / "o")],
            "petsc-option": ["--out", str(tmp_path / "o")]}[case]
    extra = {"PETSC_OPTIONS": "-rodfem_pc_type nonexistent"} if case == "petsc-option" else None
    p = rodfem("run", *RU, *args, np=2, env=extra, timeout=120)
    assert p.returncode == 2, p.stderr[-3000:]  # 124: timeout, a rank was left waiting
    assert words in one_line(p.stderr)


def children(pid):
    """Pids of the processes whose parent is `pid` (from /proc)."""
    found = []
    for stat in glob.glob("/proc/[0-9]*/stat"):
        try:
            with open(stat) as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            found.append(int(stat.split("/")[2]))
    return found


@pytest.mark.mpi
def test_mpi_a_held_jit_cache_lock(tmp_path):
    """Rank 0 gives up waiting for the cache lock; both ranks end with its one line."""
    cache = tmp_path / "cache"
    with holding_the_lock(cache):
        p = rodfem("run", *RU, "--out", tmp_path / "o", np=2, timeout=120,
                   env={"XDG_CACHE_HOME": str(cache), "RODFEM_JIT_LOCK_TIMEOUT": "1"})
    assert p.returncode == 2, p.stderr[-3000:]   # 124: timeout, a rank was left waiting
    assert rodfem_lines(p.stderr)[-1].startswith("rodfem: error: the JIT cache lock")


@pytest.mark.mpi
def test_mpi_interrupt_of_one_rank_stops_both(tmp_path):
    out = str(tmp_path)
    p = popen(command("run", *LONG, "--out", out, np=2, timeout=300), stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env=environment(), cwd=REPO)
    wait_for_rows(out)
    ranks = [rank for mpirun in children(p.pid) for rank in children(mpirun)]   # timeout -> mpirun -> ranks
    assert len(ranks) == 2
    os.kill(min(ranks), signal.SIGTERM)  # one rank only (as a batch system's kill of one task would)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 143
    one_line(err, "rodfem: interrupted by SIGTERM")
    s = summary(out)
    assert s["status"] == "interrupted" and s["mpi_ranks"] == 2 and len(rows(out)) == s["steps"] + 1
    assert os.path.getsize(os.path.join(out, "energy.png")) > 1000
