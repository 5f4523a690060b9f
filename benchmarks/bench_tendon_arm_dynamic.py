"""tendon-arm-dynamic: the tip at t = 1, 2, 3 s over dt, n_elements and adaptive steps (writes
benchmarks/tendon_arm_dynamic.{csv,md}; summarized in docs/guide/tendon-arm-dynamic.md).

    python benchmarks/bench_tendon_arm_dynamic.py
"""
import time

import numpy as np
from mpi4py import MPI
from report import write_report

from rodfem import run
from rodfem.analysis.stepping import StepControl
from rodfem.demos import tendon_arm_dynamic as arm

RUNS = [dict(n_elements=n, dt=dt) for n in (6, 12, 24) for dt in (0.02, 0.01, 0.005)] + \
       [dict(n_elements=n, dt=0.0025) for n in (12, 24, 48)] + \
       [dict(n_elements=12, dt=0.01, adaptive="true", rtol=rtol) for rtol in (1e-3, 1e-4, 1e-5)]


def tip_at(res, t):
    ts = res.column("t")
    i = int(np.argmin(np.abs(ts - t)))
    assert abs(ts[i] - t) < 1e-9, (ts[i], t)
    return [res.rows[i][f"tip_{c}"] for c in "xyz"]


def main():
    rows = []
    for over in RUNS:
        p = arm.scene.values(over)
        P = arm.scene.build(p, MPI.COMM_WORLD)
        control = (StepControl(adaptive=True, rtol=p["rtol"], atol=p["atol"], output_times=(1.0, 2.0, 3.0))
                   if p["adaptive"] == "true" else None)
        t0 = time.perf_counter()
        res = run(P, p["dt"], p["t_end"], control=control)
        wall = time.perf_counter() - t0
        H = res.column("H")
        row = dict(n_elements=p["n_elements"], dt=p["dt"], mode="adaptive" if control else "fixed",
                   rtol=p["rtol"] if control else "", steps=res.stepping["substeps"],
                   rejected=res.stepping["rejected"], time_s=wall,
                   balance=np.max(np.abs(res.column("balance_error"))) / np.max(np.abs(H)))
        for t in (1.0, 2.0, 3.0):
            row.update({f"{c}{int(t)}": v for c, v in zip("xyz", tip_at(res, t))})
        rows.append(row)
        print(row, flush=True)
    tips = [(f"{c}{t}", "{:.6f}") for t in (1, 2, 3) for c in "xz"]
    write_report("tendon_arm_dynamic", rows, [
        ("n_elements", "{}", "elements"), ("mode", "{}"), ("dt", "{:g}", "dt (adaptive: first)"), ("rtol", "{}"),
        ("steps", "{}"), ("rejected", "{}"), ("time_s", "{:.2f}", "time s"), *tips,
        ("balance", "{:.1e}", "max balance / max \\|H\\|")],
        title="tendon-arm-dynamic: the tip at t = 1, 2, 3 s",
        intro=["The soromox tendon benchmark (L = 0.6, r = 0.03, E = 1 MPa, nu = 0.5, rho = 1000, tau_kv = eta/G = "
               "0.03 s, two tendons at 0.02 m with 1 N, gravity -9.81 e_z; discrete gradient).  x = y by symmetry "
               "(only x shown).  Adaptive: step doubling from dt = 0.01, atol = 1e-6, landing on t = 1, 2, 3."])


if __name__ == "__main__":
    main()
