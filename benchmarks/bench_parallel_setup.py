"""The 20-step run at 1e5 planar elements, serial and on two ranks, whole process (issue 26).

    .venv/bin/python benchmarks/bench_parallel_setup.py [--before CHECKOUT] [--runs 2] [--elements 100000]
                                                       # -> benchmarks/parallel_setup.{csv,md}

`rodfem run flying-spaghetti-2d --set n_elements=1e5 --set t_end=2.0` (h = 0.1: 20 steps, its frames and
pictures written as by default), serially and with `mpirun -n 2`, for this checkout and another
(`--before`, e.g. a worktree of main), in turn (A B A B ...: a shared machine's load drifts).  Per
configuration, the medians of `runs` runs: the whole process's wall time (the command's start to its
end), its CPU time (all ranks: user + system of the finished children), and the time loop's wall time
from summary.json (`wall_time_s`); set-up and output = whole process - time loop.
"""
import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def once(checkout, ranks, elements):
    """(wall s, CPU s, time loop s) of one run."""
    with tempfile.TemporaryDirectory() as out:
        cmd = [sys.executable, "-m", "rodfem", "run", "flying-spaghetti-2d", "--set", f"n_elements={elements}",
               "--set", "t_end=2.0", "--out", out, "--quiet"]
        if ranks > 1:
            cmd = [shutil.which("mpirun"), "--allow-run-as-root", "--oversubscribe", "-n", str(ranks)] + cmd
        env = dict(os.environ, PYTHONPATH=checkout, OMP_NUM_THREADS="1")
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t = time.perf_counter()
        subprocess.run(cmd, env=env, cwd=checkout, check=True, capture_output=True, timeout=3600)
        wall = time.perf_counter() - t
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        with open(os.path.join(out, "summary.json")) as f:
            loop = json.load(f)["wall_time_s"]
        return wall, cpu, loop


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", help="another checkout, measured in turn with this one")
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--elements", type=int, default=100_000)
    args = ap.parse_args()
    from report import write_report
    codes = [("this checkout", ROOT)] + ([("before", os.path.abspath(args.before))] if args.before else [])
    configs = [(label, path, ranks) for label, path in codes for ranks in (1, 2)]
    runs = {c: [] for c in configs}
    for _ in range(args.runs):
        for c in configs:
            runs[c].append(once(c[1], c[2], args.elements))
            print(c[0], c[2], runs[c][-1], flush=True)
    rows = []
    for label, path, ranks in configs:
        med = [statistics.median(r[k] for r in runs[(label, path, ranks)]) for k in range(3)]
        rows.append(dict(code=label, ranks=ranks, wall_s=med[0], cpu_s=med[1], loop_s=med[2], rest_s=med[0] - med[2]))
    for r in rows:
        serial = next(s for s in rows if s["code"] == r["code"] and s["ranks"] == 1)
        r["speedup"] = serial["wall_s"] / r["wall_s"]
    load = os.getloadavg()[0]
    write_report("parallel_setup", rows,
                 [("code", "{}"), ("ranks", "{}"), ("wall_s", "{:.1f}", "whole process s"),
                  ("speedup", "{:.2f}", "serial / this"), ("cpu_s", "{:.1f}", "CPU s (all ranks)"),
                  ("loop_s", "{:.1f}", "time loop s"), ("rest_s", "{:.1f}", "set-up and output s")],
                 f"flying-spaghetti-2d, {args.elements} elements, 20 steps: serial and two ranks, whole process",
                 intro=[f"Medians of {args.runs} runs, the configurations in turn; the run writes its frames and "
                        "pictures as by default."],
                 notes=[f"Load average while this ran: {load:.1f} on 2 cores (a shared machine)."])


if __name__ == "__main__":
    main()
