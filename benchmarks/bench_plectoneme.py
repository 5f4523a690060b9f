"""The plectoneme scene (demos/plectoneme.py): cost per step, the largest step that survives, and the link.

1. The default run (2 turns in 4 s, 12 elements, dt = 0.02, t_end = 5) and the step sweep dt = 0.01, 0.02, 0.04, 0.05, 0.1
   on it: a step "survives" when the run completes (Newton converges, splitting a failed step at most
   into sub-steps down to dt/16) AND the link holds (max |Lk - turns| < 1e-6: the rod did not pass through
   itself within a step).  Per run: wall time, steps, time per step, max |Lk - turns|, the largest per-step
   balance error, the largest penetration (over r), the final Tw, Wr.
2. The full case of PyElastica's PlectonemesCase: 10 turns (`--full`; 50 elements, 2 s per turn, dt = 0.02,
   t_end = 25: 20 s turning, 5 s held; Newton to |F| <= 1e-7: the residual's round-off floor under contact
   forces of 6e3 N is about 1.3e-8, where Newton to 1e-11 stalls at 6 turns and to 1e-8 in the held coil).  At 30 elements the twist slips between
   nodes (Lk drops by 1 at 6.1 turns); without the wall at the clamp (`wall=off`) the rod swings round
   behind the clamp at 9.3 turns (Lk drops by 2).  `rejected`: the steps refused (Newton failures and
   steps whose contact pairs might have passed through each other, rodfem/core/bodycontact.py) and split.

Writes bench_plectoneme.md and bench_plectoneme.csv next to this file (the sweep; --full adds its row).

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_plectoneme.py [--full] [--only-full]
"""
import os
import sys
import time

import numpy as np
from mpi4py import MPI
from report import table, write_csv

from rodfem import run
from rodfem.analysis.stepping import StepControl
from rodfem.demos.plectoneme import scene
from rodfem.errors import NewtonFailure

HERE = os.path.dirname(os.path.abspath(__file__))
FULL = {"turns": 10, "n_elements": 50, "turn_time": 2.0, "dt": 0.02, "t_end": 25.0, "newton_atol": 1e-7}


def one(label, overrides):
    p = scene.values(overrides)
    system = scene.build(p, MPI.COMM_WORLD)
    t0 = time.perf_counter()
    row = {"case": label, "n_elements": p["n_elements"], "turns": p["turns"], "dt": p["dt"], "t_end": p["t_end"]}
    try:
        res = run(system, p["dt"], p["t_end"], control=StepControl(dt_min=p["dt"] / 16))
    except NewtonFailure as e:
        row.update(wall=time.perf_counter() - t0, survives="no", note=f"Newton failed at t = {e.t:.3g}")
        return row
    wall = time.perf_counter() - t0
    col = {k: np.array([r[k] for r in res.rows]) for k in ("Lk_error", "balance_error", "self.penetration", "Tw", "Wr")}
    steps = len(res.rows) - 1
    lk = float(np.abs(col["Lk_error"]).max())
    row.update(wall=wall, steps=steps, substeps=res.stepping.get("substeps", steps), per_step=wall / steps,
               lk=lk, balance=float(np.abs(col["balance_error"]).max()),
               pen=float(col["self.penetration"].max()) / p["r"], Tw=float(col["Tw"][-1]), Wr=float(col["Wr"][-1]),
               wall_pen=max((r.get("rod.wall.penetration", 0.0) for r in res.rows), default=0.0) / p["r"],
               rejected=res.stepping.get("rejected", 0),
               survives="yes" if lk < 1e-6 else "no", note="" if lk < 1e-6 else "Lk jumped: the rod crossed itself")
    return row


COLUMNS = [("case", "{case}"), ("n_elements", "{n_elements}", "n"), ("turns", "{turns:g}"), ("dt", "{dt:g}"),
           ("steps", lambda r: str(r.get("steps", "-")), "steps"), ("substeps", lambda r: str(r.get("substeps", "-")), "solves"),
           ("rejected", lambda r: str(r.get("rejected", "-")), "rejected"),
           ("wall", "{wall:.1f}", "wall (s)"), ("per_step", lambda r: f"{r['per_step']:.3f}" if "per_step" in r else "-", "s / step"),
           ("lk", lambda r: f"{r['lk']:.1e}" if "lk" in r else "-", "max abs(Lk - turns)"),
           ("balance", lambda r: f"{r['balance']:.1e}" if "balance" in r else "-", "max abs(balance)"),
           ("pen", lambda r: f"{r['pen']:.3f}" if "pen" in r else "-", "max pen / r"),
           ("wall_pen", lambda r: f"{r['wall_pen']:.3f}" if "wall_pen" in r else "-", "wall pen / r"),
           ("Tw", lambda r: f"{r['Tw']:.3f}" if "Tw" in r else "-", "Tw end"),
           ("Wr", lambda r: f"{r['Wr']:.3f}" if "Wr" in r else "-", "Wr end"),
           ("survives", "{survives}"), ("note", "{note}")]


def main(argv):
    rows = []
    if "--only-full" not in argv:
        for dt in [float(x) for x in os.environ.get("DTS", "0.01 0.02 0.04 0.05 0.1").split()]:
            rows.append(one("default" if dt == 0.02 else "sweep", {"dt": dt}))
            print(rows[-1], flush=True)
    if "--full" in argv or "--only-full" in argv:
        rows.append(one("10 turns", FULL))
        print(rows[-1], flush=True)
    name = "bench_plectoneme_full" if "--only-full" in argv else "bench_plectoneme"
    lines = [f"# Plectoneme ({time.strftime('%Y-%m-%d')}, serial, OMP_NUM_THREADS=1, a shared 2-core machine)", "",
             *table(rows, COLUMNS), ""]
    with open(os.path.join(HERE, f"{name}.md"), "w") as f:
        f.write("\n".join(lines))
    write_csv(name, rows, [c[0] for c in COLUMNS])
    print("\n".join(lines))


if __name__ == "__main__":
    main(sys.argv[1:])
