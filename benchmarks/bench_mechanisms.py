"""Cost of a step of the mechanisms, this checkout against another (e.g. before a change).

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_mechanisms.py [--against DIR]
        # -> benchmarks/mechanisms.{csv,md}

The four-bar at 100/60/60 elements and the crane with its payload at 10 and 100 elements, 50
steps at the scene's h, serial, best of 3 processes: wall time per step, residual and Jacobian
assembly per step (all bodies' blocks and the joints), Newton iterations and the balance error.
`--against DIR` runs the same measurement on the checkout in DIR (a `git worktree` of the
commit to compare) with its own JIT cache and reports both and their ratio.
"""
import json
import os
import subprocess
import sys
import tempfile

from report import write_report

HERE = os.path.dirname(os.path.abspath(__file__))
CASES = [("four-bar", "four-bar-2d", 60), ("crane + payload", "crane-payload", 10), ("crane + payload", "crane-payload", 100)]
STEPS, REPEATS = 50, 3

MEASURE = r"""
import importlib, json, sys
import numpy as np
from mpi4py import MPI
from rodfem import run
name, n, steps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
try:
    demo = importlib.import_module("rodfem.demos." + name.replace("-", "_"))
except ImportError:          # a checkout from before rodfem.demos (its demos/ on the path)
    demo = importlib.import_module("demos." + name.replace("-", "_"))
scene = demo.scene
p = scene.values({"n_elements": n})
system = scene.build(p, MPI.COMM_WORLD)
res = run(system, p["dt"], steps * p["dt"])
t = system.newton.timings
print(json.dumps({"dofs": system.dofs, "ms_per_step": 1e3 * res.wall_time / steps,
                  "residual_ms": 1e3 * t["F"] / steps, "jacobian_ms": 1e3 * t["J"] / steps,
                  "newton_its": float(np.mean(res.column("newton_its")[1:])),
                  "balance_rel": res.max_balance_error / np.max(np.abs(res.column("H")))}), flush=True)
import os
os._exit(0)   # (PETSc's finalization after the serial Schur PC can crash a plain script: not measured here)
"""


def measure(checkout, name, n):
    """Best of REPEATS processes (the first, which may compile, is run once before)."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    if checkout:
        env["PYTHONPATH"] = checkout
        env["XDG_CACHE_HOME"] = os.path.join(tempfile.gettempdir(), "rodfem-bench-against")
    args = [sys.executable, "-c", MEASURE, name, str(n), str(STEPS)]
    subprocess.run(args, env=env, check=True, capture_output=True, cwd=checkout or os.path.dirname(HERE))
    runs = [json.loads(subprocess.run(args, env=env, check=True, capture_output=True, text=True,
                                      cwd=checkout or os.path.dirname(HERE)).stdout.splitlines()[-1])
            for _ in range(REPEATS)]
    return min(runs, key=lambda r: r["ms_per_step"])


def main(argv):
    against = argv[argv.index("--against") + 1] if "--against" in argv else None
    rows = []
    for label, name, n in CASES:
        elements = "100/60/60" if name == "four-bar-2d" else str(n)
        now = measure(None, name, n)
        row = {"case": label, "elements": elements, **now}
        if against:
            old = measure(against, name, n)
            row.update({f"before_{k}": v for k, v in old.items()})
            row["speed_up"] = old["ms_per_step"] / now["ms_per_step"]
        rows.append(row)
    columns = [("case", "{}"), ("elements", "{}"), ("dofs", "{}")]
    if against:
        columns += [("before_ms_per_step", "{:.2f}", "ms/step before"), ("ms_per_step", "{:.2f}", "ms/step now"),
                    ("speed_up", "{:.2f}", "speed-up"), ("before_jacobian_ms", "{:.2f}", "Jacobian ms before"),
                    ("jacobian_ms", "{:.2f}", "Jacobian ms now"), ("before_residual_ms", "{:.2f}", "residual ms before"),
                    ("residual_ms", "{:.2f}", "residual ms now")]
    else:
        columns += [("ms_per_step", "{:.2f}", "ms/step"), ("jacobian_ms", "{:.2f}", "Jacobian ms"),
                    ("residual_ms", "{:.2f}", "residual ms")]
    columns += [("newton_its", "{:.2f}", "Newton its"), ("balance_rel", "{:.1e}", "balance / max H")]
    write_report("mechanisms", rows, columns, "Mechanisms: cost per step (serial, OMP_NUM_THREADS=1)",
                 intro=[f"{STEPS} steps at the scene's h, best of {REPEATS} processes."
                        + (f" Before: the checkout in `{os.path.basename(os.path.abspath(against))}`." if against else "")])


if __name__ == "__main__":
    main(sys.argv[1:])
