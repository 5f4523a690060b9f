"""Planar beam cost per time step (flying spaghetti, serial, direct LU) and JIT reuse.

    .venv/bin/python benchmarks/bench_planar_beam.py      # -> benchmarks/planar_beam.{csv,md}

For 10, 100, 1000 elements: wall time per step (best of 3 runs of 150 steps),
split into residual assembly, Jacobian assembly and the rest of the Newton
solve (LU factorisation + triangular solves + SNES), Newton iterations per
step, and the balance error.  Then the set-up time of a scene with an empty
JIT cache (forms compiled) and again with the cache filled (forms reused).
"""
import csv
import os
import subprocess
import sys
import tempfile

import numpy as np

from rodfem import run
from rodfem.app.scene import load

HERE = os.path.dirname(os.path.abspath(__file__))


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
    with open(os.path.join(HERE, "planar_beam.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = ["# Planar beam: cost per time step (flying-spaghetti-2d, serial, h = 0.1, 150 steps)", "",
             "| elements | dofs | ms/step | residual ms | Jacobian ms | LU + rest ms | Newton its/step | max balance error / max H | LU |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['n_elements']} | {r['dofs']} | {r['ms_per_step']:.3f} | {r['residual_ms']:.3f} | "
                     f"{r['jacobian_ms']:.3f} | {r['solve_ms']:.3f} | {r['newton_its']:.2f} | "
                     f"{r['max_balance_error_rel']:.1e} | {r['linear_solver']} |")
    lines += ["", f"Scene set-up with an empty JIT cache (forms compiled): {cold:.2f} s; "
              f"second run, cache filled (forms reused, nothing recompiled): {warm:.2f} s.", ""]
    with open(os.path.join(HERE, "planar_beam.md"), "w") as f:
        f.write("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
