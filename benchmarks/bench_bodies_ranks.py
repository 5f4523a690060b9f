"""Many bodies on two ranks: the chain of bench_many_bodies.py serial and under `mpirun -n 2` (issue 26).

    .venv/bin/python benchmarks/bench_bodies_ranks.py [--runs 3] [--bodies 16 64 256] [--steps 20]
                                                    # -> the "ranks" section of benchmarks/many_bodies.md
                                                    #    and benchmarks/many_bodies_ranks.csv

The hanging chain of N planar beams, 128 elements in total (N = 256: one element per beam), h = 1 ms,
built and run for `steps` steps in a process of its own: serially, and with `mpirun -n 2` and
`System(distribute=True)` (rodfem/core/placement.py: each beam whole on one rank, the ranks' beams
batched, the joints between ranks coupling them).  Whole process: the wall time from the start of
the command to its end (mpirun, imports, the build, the run), the median of `runs` runs, serial and
two ranks in turn (A B A B ...: a shared machine's load drifts); per step: the wall time of the steps
after the first (the first sets up the solver), measured in the process; the last column, the largest
difference of the two runs' histories (every column, relative to the largest value of its kind: the
multipliers to the largest multiplier; the joints' position residual |g| to the chain's length).
"""
import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

CHILD = """
import json, sys, time
sys.path.insert(0, {here!r})
from mpi4py import MPI
from bench_many_bodies import chain
from rodfem import run
N, steps, out = {N}, {steps}, {out!r}
t0 = time.perf_counter()
s = chain(N, distribute=True)
s.build()
t1 = time.perf_counter()
first = run(s, 1e-3, 1e-3)
t2 = time.perf_counter()
rest = run(s, 1e-3, steps * 1e-3)   # (steps 2 .. steps: continues from the first)
t3 = time.perf_counter()
if MPI.COMM_WORLD.rank == 0:
    rows = first.rows + rest.rows[1:]
    cols = {{k: [r[k] for r in rows] for k in rows[0] if isinstance(rows[0][k], float) and k != "wall_time"}}
    json.dump(dict(build_s=t1 - t0, first_step_s=t2 - t1, ms_per_step=1e3 * (t3 - t2) / (steps - 1),
                   placed=bool(s.distributed), history=cols), open(out, "w"))
"""


def once(N, steps, ranks):
    """(whole-process wall seconds, the child's figures) of one run."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out.json")
        cmd = [sys.executable, "-c", CHILD.format(here=HERE, N=N, steps=steps, out=out)]
        if ranks > 1:
            cmd = [shutil.which("mpirun"), "--allow-run-as-root", "--oversubscribe", "-n", str(ranks)] + cmd
        env = dict(os.environ, PYTHONPATH=ROOT, OMP_NUM_THREADS="1")
        t = time.perf_counter()
        subprocess.run(cmd, env=env, cwd=ROOT, check=True, capture_output=True, timeout=1800)
        wall = time.perf_counter() - t
        with open(out) as f:
            return wall, json.load(f)


def difference(a, b):
    """The largest difference of two histories, each column relative to the largest value of its kind
    (every joint's multipliers: the largest multiplier; the balance error: the largest H)."""
    import re

    def kind(k):
        return "H" if k == "balance_error" else re.sub(r"\d+", "", k.split(".")[-1])
    scale = {"constraint_residual": 1.0}   # (|g|, a length: the chain is 1 m long)
    for k, x in a.items():
        scale[kind(k)] = max(scale.get(kind(k), 0.0), max(abs(v) for v in x))
    return max(max(abs(u - v) for u, v in zip(x, b[k])) / max(scale[kind(k)], 1e-300) for k, x in a.items())


def section(rows, runs, steps):
    from report import table
    load = os.getloadavg()[0]
    columns = [("bodies", "{}"),
               ("serial_s", "{:.2f}", "serial: whole process s"), ("ranks_s", "{:.2f}", "2 ranks: whole process s"),
               ("speedup", "{:.2f}", "whole process: serial / 2 ranks"),
               ("serial_ms", "{:.2f}", "serial ms/step"), ("ranks_ms", "{:.2f}", "2 ranks ms/step"),
               ("step_speedup", "{:.2f}", "per step: serial / 2 ranks"),
               ("serial_build", "{:.2f}", "serial build s"), ("ranks_build", "{:.2f}", "2 ranks build s"),
               ("diff", "{:.1e}", "histories differ by")]
    return ["<!-- ranks: written by benchmarks/bench_bodies_ranks.py -->", "",
            "## Many bodies on two ranks (`System(distribute=True)`, `mpirun -n 2`)", "",
            f"The chain of N beams (128 elements in total), {steps} steps of h = 1 ms; each beam built whole on one "
            "rank (rodfem/core/placement.py).  Whole process: wall seconds from the command's start to its end "
            f"(imports, build, run), the median of {runs} runs, serial and two ranks in turn; ms/step: wall time "
            "of the steps after the first, in the process; build: wall seconds of the build in the process.", "",
            *table(rows, columns), "",
            f"Load average while this ran: {load:.1f} on 2 cores (a shared machine: other developers' jobs run "
            "beside these; two ranks need both cores at once, so their figures suffer more from the load).", "",
            "<!-- /ranks -->"]


def write_section(lines):
    """Replace (or append) the ranks section of many_bodies.md."""
    path = os.path.join(HERE, "many_bodies.md")
    text = open(path).read() if os.path.exists(path) else ""
    start, end = "<!-- ranks:", "<!-- /ranks -->"
    if start in text:
        head, rest = text.split(start, 1)
        text = head.rstrip("\n") + rest.split(end, 1)[1]
    with open(path, "w") as f:
        f.write(text.rstrip("\n") + "\n\n" + "\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--bodies", type=int, nargs="+", default=[16, 64, 256])
    args = ap.parse_args()
    from report import write_csv
    rows = []
    for N in args.bodies:
        serial, ranks = [], []
        for _ in range(args.runs):   # (in turn: the load drifts)
            serial.append(once(N, args.steps, 1))
            ranks.append(once(N, args.steps, 2))
        assert all(r[1]["placed"] for r in ranks)
        med = lambda runs, k: statistics.median(r[1][k] for r in runs)   # noqa: E731
        row = dict(bodies=N, serial_s=statistics.median(r[0] for r in serial),
                   ranks_s=statistics.median(r[0] for r in ranks),
                   serial_ms=med(serial, "ms_per_step"), ranks_ms=med(ranks, "ms_per_step"),
                   serial_build=med(serial, "build_s"), ranks_build=med(ranks, "build_s"),
                   diff=max(difference(a[1]["history"], b[1]["history"]) for a, b in zip(serial, ranks)))
        row["speedup"] = row["serial_s"] / row["ranks_s"]
        row["step_speedup"] = row["serial_ms"] / row["ranks_ms"]
        print(row, flush=True)
        rows.append(row)
    write_csv("many_bodies_ranks", rows)
    lines = section(rows, args.runs, args.steps)
    write_section(lines)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
