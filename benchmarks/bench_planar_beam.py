"""Planar beam cost per time step (flying spaghetti, serial, direct LU) and JIT reuse.

    .venv/bin/python benchmarks/bench_planar_beam.py      # -> benchmarks/planar_beam.{csv,md}

For 10, 100, 1000 elements: wall time per step (best of 3 runs of 150 steps),
split into residual assembly, Jacobian assembly and the rest of the Newton
solve (LU factorisation + triangular solves + SNES), Newton iterations per
step, and the balance error.  Then the set-up time of a scene with an empty
JIT cache (forms compiled) and again with the cache filled (forms reused).
"""
import os
import subprocess
import sys
import tempfile

import numpy as np
from report import write_report

from rodfem import run
from rodfem.app.scene import load


def cost(n, steps=150, repeats=3):
    scene = load("flying-spaghetti-2d")
    best = None
    for _ in range(repeats):
        p = scene.values({"n_elements": n})
        problem = scene.build(p, comm=__import__("mpi4py").MPI.COMM_WORLD)
        res = run(problem, p["dt"], steps * p["dt"])
        t = problem.newton.timings
        row = {"n_elements": n, "dofs": problem.dofs, "ms_per_step": 1e3 * res.wall_time / steps,
               "residual_ms": 1e3 * t["F"] / steps, "jacobian_ms": 1e3 * t["J"] / steps,
               "solve_ms": 1e3 * (res.wall_time - t["F"] - t["J"]) / steps,
               "newton_its": float(np.mean(res.column("newton_its")[1:])),
               "max_balance_error_rel": res.max_balance_error / np.max(np.abs(res.column("H"))),
               "linear_solver": problem.newton.linear_solver}
        if best is None or row["ms_per_step"] < best["ms_per_step"]:
            best = row
    return best


def setup_time(cache):
    code = ("import time; t=time.perf_counter(); from rodfem.app.scene import load; from mpi4py import MPI; "
            "s=load('flying-spaghetti-2d'); s.build(s.values(), MPI.COMM_WORLD); print(time.perf_counter()-t)")
    env = dict(os.environ, XDG_CACHE_HOME=cache)
    return float(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                                check=True).stdout.split()[-1])


def main():
    rows = [cost(n) for n in (10, 100, 1000)]
    with tempfile.TemporaryDirectory() as cache:
        cold, warm = setup_time(cache), setup_time(cache)
    write_report("planar_beam", rows, [
        ("n_elements", "{}", "elements"), ("dofs", "{}"), ("ms_per_step", "{:.3f}", "ms/step"),
        ("residual_ms", "{:.3f}", "residual ms"), ("jacobian_ms", "{:.3f}", "Jacobian ms"),
        ("solve_ms", "{:.3f}", "LU + rest ms"), ("newton_its", "{:.2f}", "Newton its/step"),
        ("max_balance_error_rel", "{:.1e}", "max balance error / max H"), ("linear_solver", "{}", "LU")],
        "Planar beam: cost per time step (flying-spaghetti-2d, serial, h = 0.1, 150 steps)",
        notes=[f"Scene set-up with an empty JIT cache (forms compiled): {cold:.2f} s; "
               f"second run, cache filled (forms reused, nothing recompiled): {warm:.2f} s."])


if __name__ == "__main__":
    main()
