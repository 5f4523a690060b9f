"""Many bodies on two ranks: the chain of bench_many_bodies.py serial and under `mpirun -n 2` (issue 26).

    .venv/bin/python benchmarks/bench_bodies_ranks.py [--runs 3] [--bodies 16 64 256] [--steps 20]
                                                    [--before CHECKOUT]
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

The machine is shared (2 cores, other developers' jobs beside these), so each run also gives each
rank's CPU seconds of those steps (time.process_time: the rank's own work, and its busy waits in MPI
calls, which Open MPI spends polling) and the load average before and after it.  Two ranks are run
twice: as Open MPI starts them by default (each rank bound to a core of its own, polling while it
waits), and with `--bind-to none` and `OMPI_MCA_mpi_yield_when_idle=1` (a rank runs on whichever core
is free, and one that waits gives its core away: on a loaded machine the other rank, or another job,
runs meanwhile).
`--before CHECKOUT`: the same runs of another checkout (e.g. `git archive main | tar -x -C /tmp/before`),
side by side.
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
t2, c2 = time.perf_counter(), time.process_time()
rest = run(s, 1e-3, steps * 1e-3)   # (steps 2 .. steps: continues from the first)
t3, c3 = time.perf_counter(), time.process_time()
cpu = MPI.COMM_WORLD.gather(1e3 * (c3 - c2) / (steps - 1), root=0)
if MPI.COMM_WORLD.rank == 0:
    rows = first.rows + rest.rows[1:]
    cols = {{k: [r[k] for r in rows] for k in rows[0] if isinstance(rows[0][k], float) and k != "wall_time"}}
    json.dump(dict(build_s=t1 - t0, first_step_s=t2 - t1, ms_per_step=1e3 * (t3 - t2) / (steps - 1),
                   cpu_ms_per_step=cpu, placed=bool(s.distributed), history=cols), open(out, "w"))
"""


def once(N, steps, ranks, root=ROOT, polite=False):
    """(whole-process wall seconds, the child's figures, load averages before and after) of one run of
    the checkout `root`; `polite`: Open MPI's ranks unbound, yielding their core while they wait."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out.json")
        here = os.path.join(root, "benchmarks") if os.path.exists(os.path.join(root, "benchmarks", "bench_many_bodies.py")) else HERE
        cmd = [sys.executable, "-c", CHILD.format(here=here, N=N, steps=steps, out=out)]
        if ranks > 1:
            cmd = ([shutil.which("mpirun"), "--allow-run-as-root", "--oversubscribe", "-n", str(ranks)]
                   + (["--bind-to", "none"] if polite else []) + cmd)
        env = dict(os.environ, PYTHONPATH=root, OMP_NUM_THREADS="1")
        env.pop("OMPI_MCA_mpi_yield_when_idle", None)
        if polite:
            env["OMPI_MCA_mpi_yield_when_idle"] = "1"
        load = os.getloadavg()[0]
        t = time.perf_counter()
        subprocess.run(cmd, env=env, cwd=root, check=True, capture_output=True, timeout=1800)
        wall = time.perf_counter() - t
        with open(out) as f:
            return wall, json.load(f), (load, os.getloadavg()[0])


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


VARIANTS = (("serial", 1, False), ("2 ranks", 2, False), ("2 ranks, unbound, yield", 2, True))


def section(rows, runs, steps):
    from report import table
    columns = [("bodies", "{}"), ("checkout", "{}"), ("run", "{}"),
               ("whole_s", "{:.2f}", "whole process s"), ("whole_speedup", "{:.2f}", "whole: serial / this"),
               ("ms", "{:.2f}", "ms/step (wall)"), ("ms_best", "{:.2f}", "best ms/step"),
               ("step_speedup", "{:.2f}", "per step: serial / this"),
               ("cpu", "{}", "CPU ms/step per rank"), ("build", "{:.2f}", "build s"),
               ("load", "{}", "load before / after"), ("diff", "{:.1e}", "histories differ from serial by")]
    return ["<!-- ranks: written by benchmarks/bench_bodies_ranks.py -->", "",
            "## Many bodies on two ranks (`System(distribute=True)`, `mpirun -n 2`)", "",
            f"The chain of N beams (128 elements in total), {steps} steps of h = 1 ms; each beam built whole on one "
            "rank (rodfem/core/placement.py).  Whole process: wall seconds from the command's start to its end "
            f"(imports, build, run), the median of {runs} runs, the variants in turn; ms/step: wall time of the "
            "steps after the first, in the process (median, and the best run); CPU ms/step per rank: "
            "time.process_time of those steps on each rank (median; Open MPI's busy waits count as CPU time); "
            "unbound, yield: `mpirun --bind-to none` with `OMPI_MCA_mpi_yield_when_idle=1`; load: the 1-minute load average before and after "
            "the run (medians) on this 2-core machine, shared with other developers' jobs.  before: main "
            "before this work; now: this checkout.", "",
            *table(rows, columns), "",
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
    ap.add_argument("--before", help="another checkout, run side by side (e.g. main before this work)")
    ap.add_argument("--no-write", action="store_true", help="print the table only")
    args = ap.parse_args()
    from report import write_csv
    checkouts = [("now", ROOT)] + ([("before", os.path.abspath(args.before))] if args.before else [])
    rows = []
    med = statistics.median
    for N in args.bodies:
        runs = {}
        for _ in range(args.runs):   # (in turn: the load drifts)
            for name, root in checkouts:
                for run, ranks, polite in VARIANTS:
                    runs.setdefault((name, run), []).append(once(N, args.steps, ranks, root, polite))
        for name, _ in checkouts:
            serial = runs[(name, "serial")]
            for run, ranks, _ in VARIANTS:
                got = runs[(name, run)]
                assert ranks == 1 or all(r[1]["placed"] for r in got)
                cpu = [med(r[1]["cpu_ms_per_step"][k] for r in got) for k in range(ranks)]
                row = dict(bodies=N, checkout=name, run=run, whole_s=med(r[0] for r in got),
                           ms=med(r[1]["ms_per_step"] for r in got), ms_best=min(r[1]["ms_per_step"] for r in got),
                           cpu=" / ".join(f"{c:.2f}" for c in cpu), build=med(r[1]["build_s"] for r in got),
                           load=f"{med(r[2][0] for r in got):.1f} / {med(r[2][1] for r in got):.1f}",
                           diff=max(difference(a[1]["history"], b[1]["history"]) for a, b in zip(serial, got)))
                row["whole_speedup"] = med(r[0] for r in serial) / row["whole_s"]
                row["step_speedup"] = med(r[1]["ms_per_step"] for r in serial) / row["ms"]
                print(row, flush=True)
                rows.append(row)
    lines = section(rows, args.runs, args.steps)
    if not args.no_write:
        write_csv("many_bodies_ranks", rows)
        write_section(lines)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
