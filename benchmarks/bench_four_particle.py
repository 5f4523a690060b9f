"""The four-particle PH-DAE of Kinon, Morandin & Schulze (arXiv 2505.18810): energy behaviour of the
discrete-gradient and midpoint rules, and their convergence at t = 0.1.

    .venv/bin/python benchmarks/bench_four_particle.py      # about a minute

Writes four_particle.md/.csv (the runs to T = 10) and four_particle_convergence.md/.csv.
Part 1: h = 0.01 and 0.25, with and without the damper: H(T), the largest per-step balance error
|H_{n+1} - H_n + h d_n| and the largest per-step energy GAIN max(H_{n+1} - H_n) (the damper can only
take energy out), with run time.  Part 2 (the authors' study): a discrete-gradient reference with
h = 1e-4 on [0, 0.1]; for h in {0.01, 0.005, 0.002, 0.001} and both rules, the relative errors
(2-norm) of particle 4's position and velocity and of the first link's multiplier lambda_1 at
t = 0.1, and the observed orders.
"""
import time

import numpy as np
from mpi4py import MPI
from report import write_report

from rodfem import run
from rodfem.app.scene import load

SCENE = load("four-particle")


def simulate(rule, h, t_end, eta0=1.0):
    p = SCENE.values({"integrator": rule, "dt": h, "t_end": t_end, "eta0": eta0})
    system = SCENE.build(p, MPI.COMM_WORLD)
    t0 = time.perf_counter()
    result = run(system, h, t_end)
    seconds = time.perf_counter() - t0
    body = system.body("p4")
    x4 = body.space.nodal(body.x0, "x")[1].reshape(-1)
    v4 = body.space.nodal(body.x0, "v")[1].reshape(-1)
    return result, x4, v4, result.rows[-1]["link_12.lambda1"], seconds


def energy_runs():
    rows = []
    for eta0 in (1.0, 0.0):
        for rule in ("discrete-gradient", "midpoint"):
            for h in (0.01, 0.25):
                result, *_, seconds = simulate(rule, h, 10.0, eta0)
                H = np.array([r["H"] for r in result.rows])
                rows.append({"damper": "on" if eta0 else "off", "rule": rule, "h": h, "H0": H[0], "H_T": H[-1],
                             "max_balance_error": max(abs(r["balance_error"]) for r in result.rows),
                             "max_gain": float(np.max(np.diff(H))), "seconds": seconds})
    columns = [("damper", "{}"), ("rule", "{}"), ("h", "{}"), ("H_T", "{:.10f}", "H(T = 10)"),
               ("max_balance_error", "{:.2e}", "max per-step balance error"),
               ("max_gain", "{:+.2e}", "max H_{n+1} - H_n"), ("seconds", "{:.2f}", "run time (s)")]
    write_report("four_particle", rows, columns, title="Four particles (Kinon, Morandin & Schulze): energy to T = 10",
                 intro=[f"H(0) = {rows[0]['H0']:.10f}; rodfem's `four-particle` scene, Newton atol 1e-10."],
                 notes=["Discrete gradient: the balance holds to Newton's tolerance at any h and H decreases at every "
                        "step with the damper; midpoint: O(h^2) balance errors and energy gains at h = 0.25."])


def convergence():
    reference = simulate("discrete-gradient", 1e-4, 0.1)
    _, x_ref, v_ref, lam_ref, _ = reference
    rows = []
    for rule in ("discrete-gradient", "midpoint"):
        previous = None
        for h in (0.01, 0.005, 0.002, 0.001):
            _, x, v, lam, seconds = simulate(rule, h, 0.1)
            row = {"rule": rule, "h": h, "e_x": np.linalg.norm(x - x_ref) / np.linalg.norm(x_ref),
                   "e_v": np.linalg.norm(v - v_ref) / np.linalg.norm(v_ref),
                   "e_lambda": abs(lam - lam_ref) / abs(lam_ref), "seconds": seconds}
            for key in ("e_x", "e_v", "e_lambda"):
                row[f"order_{key[2:]}"] = (None if previous is None else
                                           float(np.log(previous[key] / row[key]) / np.log(previous["h"] / h)))
            rows.append(row)
            previous = row

    def order(key):
        return lambda r: "" if r[key] is None else f"{r[key]:.2f}"
    columns = [("rule", "{}"), ("h", "{}"), ("e_x", "{:.3e}", "err x_4"), ("order_x", order("order_x"), "order"),
               ("e_v", "{:.3e}", "err v_4"), ("order_v", order("order_v"), "order"),
               ("e_lambda", "{:.3e}", "err lambda_1"), ("order_lambda", order("order_lambda"), "order"),
               ("seconds", "{:.3f}", "run time (s)")]
    write_report("four_particle_convergence", rows, columns,
                 title="Four particles: convergence at t = 0.1 (reference: discrete gradient, h = 1e-4)",
                 intro=["Relative 2-norm errors of particle 4's position and velocity and of the link 1-2 "
                        "multiplier (rodfem's link is |d|^2 - 1: half the authors' lambda_1), against run time."])


if __name__ == "__main__":
    energy_runs()
    convergence()
