"""Cost of a step of the multibody scenes of issue 8 (serial, direct LU).

    .venv/bin/python benchmarks/bench_multibody.py      # -> benchmarks/multibody.{csv,md}

flexible-robot-arm-2d (bare, and with the welded tip body), crane-payload and free-flying-3d
(both variants), each at its default number of elements and at 10x, over the first `steps`
steps of the scene at its default h (best of 3): wall time per step, split into residual
assembly (all bodies' blocks + the joints), Jacobian assembly and the rest (LU + SNES), Newton
iterations per step, the balance error and the largest joint gap.
"""
import csv
import os
import sys

import numpy as np
from mpi4py import MPI
from report import table, write_csv

from rodfem import run
from rodfem.app.scene import load

HERE = os.path.dirname(os.path.abspath(__file__))

CASES = [   # (label, scene, overrides, steps)
    ("robot arm", "flexible-robot-arm-2d", {}, 50),
    ("robot arm + tip body", "flexible-robot-arm-2d", {"tip_mass": 20.0, "tip_inertia": 1.0}, 50),
    ("crane + payload", "crane-payload", {}, 50),
    ("free-flying: 2 rods + ball", "free-flying-3d", {}, 30),
    ("free-flying: rod + welded box", "free-flying-3d", {"variant": "rod-body"}, 30),
]


def cost(label, name, overrides, factor, steps, repeats=3):
    scene = load(name)
    n = scene.values(overrides)["n_elements"] * factor
    best = None
    for _ in range(repeats):
        p = scene.values({**overrides, "n_elements": n})
        system = scene.build(p, MPI.COMM_WORLD)
        res = run(system, p["dt"], steps * p["dt"])
        t = system.newton.timings
        gaps = res.column("constraint_residual") if "constraint_residual" in res.rows[0] else np.zeros(1)
        row = {"case": label, "scene": name, "elements": f"{n} per body" if name == "free-flying-3d" else str(n),
               "dofs": system.dofs, "steps": steps, "dt": p["dt"],
               "ms_per_step": 1e3 * res.wall_time / steps, "residual_ms": 1e3 * t["F"] / steps,
               "jacobian_ms": 1e3 * t["J"] / steps, "solve_ms": 1e3 * (res.wall_time - t["F"] - t["J"]) / steps,
               "newton_its": float(np.mean(res.column("newton_its")[1:])),
               "max_balance_error_rel": res.max_balance_error / np.max(np.abs(res.column("H"))),
               "max_joint_gap": float(np.max(gaps)),
               "linear_solver": system.newton.linear_solver}
        if best is None or row["ms_per_step"] < best["ms_per_step"]:
            best = row
    return best


NOTES = [
    "",
    "Notes.",
    "* Times carry the noise of a shared 2-core machine (load average {load} while this ran):",
    "  +-50 % between runs is usual here.",
    "* The welded tip body adds 2-6 ms/step to the arm in these runs (between runs the spread is",
    "  as large): the Python side of a block system -- 3 blocks instead of 1, the joints' rows",
    "  gathered on rank 0, their Jacobian entries inserted joint by joint -- at 3 Newton iterations per step.",
    "* Free-flying, 2 rods: one SuperLU factorization of the 2 x 40-element system (5823 dofs) took",
    "  about 2x that of ONE 80-element rod of the same size (5790 dofs), measured with full Newton",
    "  (143 vs 72 ms); MUMPS does not show the gap (151 vs 127 ms/step with the chord Newton).  The",
    "  joint's 3 multiplier rows at the end of the block matrix, coupling the two rods' end dofs, are",
    "  the suspect (fill in SuperLU's ordering); not investigated further.",
]


def main(argv):
    repeats = 1 if "--quick" in argv else 3
    if "--md-only" in argv:      # rewrite the table from multibody.csv
        with open(os.path.join(HERE, "multibody.csv")) as f:
            rows = [{k: (v if k in ("case", "scene", "elements", "linear_solver") else float(v)) for k, v in r.items()}
                    for r in csv.DictReader(f)]
        load_avg = "(see the csv's run)"
    else:
        rows = [cost(label, name, o, factor, steps, repeats)
                for label, name, o, steps in CASES for factor in (1, 10)]
        load_avg = f"{os.getloadavg()[0]:.1f}"
        write_csv(os.path.join(HERE, "multibody.csv"), rows)
    lines = ["# Multibody scenes: cost per step (serial, OMP_NUM_THREADS=1)", "",
             "Default size and 10x the elements; the first `steps` steps of each scene at its default h,",
             "best of 3.  Residual/Jacobian: assembly of all bodies' blocks and the joints' rows;",
             "LU + rest: the linear solves and SNES.  Free-flying: the chord Newton of the 3D rod scenes",
             "(the Jacobian and its LU reused over up to 8 iterations, driven to |F| <= 1e-12).", "",
             *table(rows, [("case", "{}"), ("elements", "{}"), ("dofs", "{:.0f}"), ("steps", "{steps:.0f} x {dt:g}", "steps x h"),
                           ("ms_per_step", "{:.2f}", "ms/step"), ("residual_ms", "{:.2f}", "residual ms"),
                           ("jacobian_ms", "{:.2f}", "Jacobian ms"), ("solve_ms", "{:.2f}", "LU + rest ms"),
                           ("newton_its", "{:.2f}", "Newton its"), ("max_balance_error_rel", "{:.1e}", "balance / max H"),
                           ("max_joint_gap", "{:.1e}", "joint gap"), ("linear_solver", "{}", "LU")])]
    lines += [n.format(load=load_avg) for n in NOTES]
    with open(os.path.join(HERE, "multibody.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main(sys.argv[1:])
