"""Static roll-up and helix (rodfem/analysis/statics.py): the error against the exact circle/helix over the mesh,
with two load-step schedules, and the observed spatial order -> statics.md.

    .venv/bin/python benchmarks/bench_statics.py [--out benchmarks]     (about 3 minutes)
"""
import argparse
import os
import time

import numpy as np
from mpi4py import MPI
from report import table

from rodfem.analysis.statics import Statics
from rodfem.app.scene import load

CASES = [("roll-up-2d", {}, (8, 16, 32, 64)), ("roll-up-2d", {"turns": 10.0}, (64,)),
         ("roll-up-3d", {}, (8, 16, 32, 64, 128)), ("helix-3d", {}, (8, 16, 32, 64, 128))]


def solve(name, extra, n, steps, adaptive):
    scene = load(name)
    p = scene.values({"n_elements": n, **extra})
    problem = scene.build(p, MPI.COMM_WORLD)
    t0 = time.perf_counter()
    res = Statics(problem).solve(p["t_end"], steps, adaptive)
    wall = time.perf_counter() - t0
    obs, ref = problem.observe(), scene.reference(p)
    err = max(abs(obs[k] - v) for k, v in ref.items() if k != "scale") / ref["scale"]
    return err, len(res.steps), res.failed, res.newton_its, wall


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.dirname(os.path.abspath(__file__)))
    args = ap.parse_args()
    # a, b: (error / L, load steps, halved, Newton its) with 1 adaptive and 10 fixed load steps
    columns = [("scene", "{}"), ("elements", "{}"), ("a", "{a[0]:.3e}", "error / L (1 adaptive)"),
               ("a", "{a[1]} ({a[2]}), {a[3]}", "load steps (halved), Newton its"),
               ("b", "{b[0]:.3e}", "error / L (10 fixed)"), ("b", "{b[1]} ({b[2]}), {b[3]}", "load steps (halved), Newton its"),
               ("order", "{}")]
    rows = []
    for name, extra, meshes in CASES:
        prev = None
        for n in meshes:
            a = solve(name, extra, n, 1, True)
            b = solve(name, extra, n, 10, False)
            order = f"{np.log2(prev / a[0]):.2f}" if prev and a[0] > 1e-12 else ""
            prev = a[0]
            label = name + ("" if not extra else " " + " ".join(f"{k}={v:g}" for k, v in extra.items()))
            rows.append({"scene": label, "elements": n, "a": a, "b": b, "order": order})
            print(table(rows[-1:], columns)[-1], flush=True)
    with open(os.path.join(args.out, "statics.md"), "w") as f:
        f.write("\n".join(table(rows, columns)) + "\n")


if __name__ == "__main__":
    main()
