"""Running rodfem as a user does, in a child process: the console script, serial or under
`mpirun -n np` (always inside `timeout`, so that a rank left waiting cannot hang the suite), and
reading back what a run wrote (history.csv, summary.json)."""
import csv
import fcntl
import json
import os
import shutil
import signal
import subprocess
import sys

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.dirname(sys.executable)
RODFEM = os.path.join(BIN, "rodfem")


def environment(**extra):
    """The children's environment: one thread per rank, mpirun allowed as root and oversubscribed, and
    quiet (Open MPI 4's `-q`: no help text after a rank's non-zero exit; Open MPI 5, Debian 13, has
    neither the option nor the setting and prints its help text), and without the TCP transport (the
    ranks are on one machine; Open MPI 5 printed "Unable to find reachable pairing between local and
    remote interfaces" on this machine's interfaces, a second line after the one-line errors)."""
    return dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
                OMPI_MCA_rmaps_base_oversubscribe="1", OMPI_MCA_orte_execute_quiet="1",
                OMPI_MCA_btl="^tcp", **extra)


def signals_as_a_terminal():
    """A child's `preexec_fn`: SIGINT and SIGTERM at their default actions, as when started from a
    terminal (a background job of a script inherits SIGINT ignored, and rodfem keeps an ignored
    signal ignored: the interrupt tests would then see no interrupt)."""
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_DFL)


def popen(args, **kwargs):
    """subprocess.Popen(args, **kwargs) with SIGINT and SIGTERM as from a terminal."""
    return subprocess.Popen(args, preexec_fn=signals_as_a_terminal, **kwargs)


def command(*args, np=None, timeout=600):
    """The argument list of `rodfem ARGS`, under `timeout T mpirun -n np` if np."""
    cmd = [RODFEM, *map(str, args)]
    if np:
        cmd = ["timeout", str(timeout), shutil.which("mpirun"), "--allow-run-as-root", "--oversubscribe", "-n",
               str(np), *cmd]
    return cmd


def rodfem(*args, np=None, env=None, timeout=600):
    """Run `rodfem ARGS` (under mpirun -n np if np) from the repository; the CompletedProcess."""
    return subprocess.run(command(*args, np=np, timeout=timeout), capture_output=True, text=True,
                          env=environment(**(env or {})), cwd=REPO, timeout=timeout + 30)


JIT_LOCK_NOTICE = "rodfem: waiting for the JIT cache lock"


def rodfem_lines(stderr):
    """The lines of stderr that are rodfem's message: without the launcher's framed help text (a block
    between two lines of dashes), which Open MPI 5 (Debian 13) prints after a rank's non-zero exit and has
    no setting to silence (Open MPI 4's `-q`), its launcher's "[host:pid] PMIX ERROR: PMIX_ERR_UNREACH"
    when both ranks exit at once, and rodfem's notice that it waits for the JIT cache lock (another test
    process compiling the same forms: the suite runs on two workers)."""
    lines, inside = [], False
    for line in stderr.strip().splitlines():
        if line.startswith("-" * 20) and not line.strip("-"):
            inside = not inside
        elif not inside:
            lines.append(line)
    return [ln for ln in lines if ln.strip() and not (ln.startswith("[") and "] PMIX ERROR: " in ln)
            and not ln.startswith(JIT_LOCK_NOTICE)]


def ok(p):
    """p, after checking that it succeeded (else fail with the end of its stderr)."""
    assert p.returncode == 0, p.stderr[-2000:]
    return p


def history(out):
    """history.csv of the run in `out`: {column: array over the time levels}."""
    with open(os.path.join(out, "history.csv")) as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def summary(out):
    with open(os.path.join(out, "summary.json")) as f:
        return json.load(f)


def serial_and_parallel(tmp_path, args, np=2, timeout=600):
    """Run `rodfem ARGS` in serial and on np ranks (both must succeed); both histories and the
    parallel run's summary (which must report np ranks)."""
    serial, par = tmp_path / "np1", tmp_path / f"np{np}"
    ok(rodfem(*args, "--out", serial, timeout=timeout))
    ok(rodfem(*args, "--out", par, np=np, timeout=timeout))
    s = summary(par)
    assert s["mpi_ranks"] == np
    return history(serial), history(par), s


def assert_same_history(a, b, rtol, skip=()):
    """Histories a and b have the same columns and rows, and every column (but `skip`) agrees to
    rtol of its scale max(max|a|, 1)."""
    assert list(a) == list(b) and len(a["t"]) == len(b["t"])
    for col in a:
        if col not in skip:
            scale = max(np.max(np.abs(a[col])), 1.0)
            assert np.max(np.abs(a[col] - b[col])) <= rtol * scale, col


def script_on_ranks(script, ranks=(1, 2), timeout=600):
    """Run the Python `script` under `mpirun -n N` for each N in `ranks` (inside `timeout`); each run
    must succeed and print a JSON row as its last line: the rows, in the order of `ranks`."""
    rows = []
    for n in ranks:
        cmd = [shutil.which("mpirun"), "--allow-run-as-root", "--oversubscribe", "-n", str(n),
               sys.executable, "-c", script]
        env = environment(PYTHONPATH=os.pathsep.join([REPO, os.environ.get("PYTHONPATH", "")]))
        p = subprocess.run(["timeout", str(timeout), *cmd], capture_output=True, text=True, env=env, cwd=REPO,
                           timeout=timeout + 30)
        assert p.returncode == 0, p.stderr[-2000:]
        rows.append(json.loads(p.stdout.strip().splitlines()[-1]))
    return rows


def assert_same_rows(serial, parallel):
    """Two JSON rows (script_on_ranks) with the same keys and values to 1e-9 (absolute 1e-12)."""
    import pytest
    assert serial.keys() == parallel.keys()
    for key, value in serial.items():
        assert parallel[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key


class tight_newton:
    """Newton to |F| <= atol (PETSc options of the rodfem_ SNES): the balance error left is
    round-off, not the solver tolerance."""

    def __init__(self, atol=1e-13):
        self.atol = atol

    def __enter__(self):
        from petsc4py import PETSc
        self.opts = PETSc.Options()
        self.opts["rodfem_snes_atol"], self.opts["rodfem_snes_rtol"] = self.atol, 1e-15

    def __exit__(self, *exc):
        self.opts.delValue("rodfem_snes_atol")
        self.opts.delValue("rodfem_snes_rtol")


def holding_the_lock(cache):
    """Hold CACHE/fenics/rodfem-jit.lock as a compiling run would (its pid written in); the open file."""
    os.makedirs(cache / "fenics", exist_ok=True)
    lock = open(cache / "fenics" / "rodfem-jit.lock", "w")
    fcntl.flock(lock, fcntl.LOCK_EX)
    lock.write(f"{os.getpid()}\n")
    lock.flush()
    return lock
