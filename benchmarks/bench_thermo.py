"""Thermoelastic string: the cost of the thermal field per step, energy and entropy per step,
the heat equation's order in space and time.

    .venv/bin/python benchmarks/bench_thermo.py      # -> benchmarks/thermo.{csv,md}  (~1 min, serial)

1. Cost: wall time per step (best of 3) and Newton iterations per step of the same swinging,
   pinned string pre-stretched by 5 % (logarithmic, EA = 100, 100 steps of 0.01) as a plain String and as a
   ThermoelasticString (a hot spot of +40 K, kappa = 0.5, alpha = 5e-4: the thermal stress -2 N stays
   below the tension 4.9 N; a hot spot in compression buckles at the grid scale and Newton needs
   10-100 times the iterations), at 10, 100, 1000 elements.
2. Energy and entropy: max_n |H_{n+1} - H_n| / (c theta0 L) of the isolated thermoelastic run,
   min_n (S_{n+1} - S_n), max_n |S_{n+1} - S_n - h int kappa (theta'/theta)^2| / max production;
   discrete gradient vs midpoint.
3. Heat equation (scene heat-conduction): end temperatures at t_end against the exact solution,
   n = 8 ... 128 (dt = 2.5e-4) and dt = 1e-2 ... 2.5e-3 (n = 512): observed orders.  The flux start
   switches Q on at t = 0 against theta = theta0 (incompatible data): the midpoint rule's order in
   dt drops to 1 there (its stiff, undamped high modes), the cosine start keeps order 2.
"""
import os
import time

import numpy as np
from mpi4py import MPI
from report import table, write_csv

from rodfem import Problem, Support, run
from rodfem.app.driver import run_scene
from rodfem.demos.heat_conduction import exact
from rodfem.demos.heat_conduction import scene as conduction
from rodfem.forms.string import String
from rodfem.forms.string_materials import logarithmic
from rodfem.forms.thermoelastic_string import ThermoelasticString

HERE = os.path.dirname(os.path.abspath(__file__))
COMM = MPI.COMM_SELF
THETA0, C = 300.0, 2.0


def swinging(thermal, n, integrator="discrete-gradient"):
    material = logarithmic(EA=100.0)
    r0 = lambda x: np.vstack([1.05 * x[0], 0.05 * np.sin(np.pi * x[0]), 0.02 * np.sin(2 * np.pi * x[0])])  # noqa: E731
    supports = [Support("left", "pinned"), Support("right", "pinned")]
    if not thermal:
        return Problem(String(material, 1.0), 1.0, n, initial={"r": r0}, supports=supports, integrator=integrator,
                       comm=COMM)
    model = ThermoelasticString(material, 1.0, alpha=5e-4, c=C, kappa=0.5, theta0=THETA0)
    initial = {"r": r0, "theta": lambda x: THETA0 + 40 * np.exp(-((x[0] - 0.3) / 0.15) ** 2)}
    return Problem(model, 1.0, n, initial=initial, supports=supports, integrator=integrator, comm=COMM)


def its(res):
    return float(np.mean(res.column("newton_its")[1:]))


def cost_table():
    rows = []
    for n in (10, 100, 1000):
        row = {"n_elements": n}
        for label, thermal in (("string", False), ("thermo", True)):
            best = None
            for _ in range(3):
                pr = swinging(thermal, n)
                res = run(pr, 0.01, 1.0)
                ms = 1e3 * res.wall_time / res.steps
                best = ms if best is None else min(best, ms)
            row.update({f"{label}_dofs": pr.dofs, f"{label}_ms_per_step": best, f"{label}_newton_its": its(res)})
        row["cost_ratio"] = row["thermo_ms_per_step"] / row["string_ms_per_step"]
        rows.append(row)
    return rows


def balance_table():
    rows = []
    for rule in ("discrete-gradient", "midpoint"):
        res = run(swinging(True, 20, rule), 0.01, 1.0)
        dS = np.diff(res.column("entropy"))
        prod = 0.01 * res.column("entropy_production")[1:]
        rows.append({"integrator": rule, "steps": res.steps,
                     "max_energy_error_rel": float(np.max(np.abs(res.column("balance_error")))) / (C * THETA0),
                     "min_entropy_increment": float(dS.min()),
                     "entropy_identity_rel": float(np.max(np.abs(dS - prod)) / np.max(prod)),
                     "mean_temperature_change": float(np.ptp(res.column("mean_temperature")))})
    return rows


def end_error(over):
    res, _ = run_scene(conduction, over)
    p = conduction.values(over)
    return max(abs(res.column("temperature_left")[-1] - float(exact(p, 0.0, p["t_end"]))),
               abs(res.column("temperature_right")[-1] - float(exact(p, p["L"], p["t_end"])))), res


def order_table():
    rows = []
    for start in ("cosine", "flux"):
        prev = None
        for n in (8, 16, 32, 64, 128):
            err, res = end_error({"start": start, "n_elements": n, "dt": 2.5e-4})
            rows.append({"start": start, "refined": "n", "n_elements": n, "dt": 2.5e-4, "error_K": err,
                         "order": None if prev is None else float(np.log2(prev / err)),
                         "max_energy_error_abs": res.max_balance_error})
            prev = err
        prev = None
        for dt in (1e-2, 5e-3, 2.5e-3):
            err, res = end_error({"start": start, "n_elements": 512, "dt": dt})
            rows.append({"start": start, "refined": "dt", "n_elements": 512, "dt": dt, "error_K": err,
                         "order": None if prev is None else float(np.log2(prev / err)),
                         "max_energy_error_abs": res.max_balance_error})
            prev = err
    return rows


def md(rows):
    cells = [{k: ("" if v is None else f"{v:.3g}" if isinstance(v, float) else str(v)) for k, v in r.items()}
             for r in rows]
    return table(cells, [(k, "{}") for k in rows[0]])


def main():
    t0 = time.perf_counter()
    sections = [("Cost per step: plain string vs thermoelastic string (logarithmic, DG, dt = 0.01, serial LU)",
                 cost_table()),
                ("Energy and entropy per step (isolated thermoelastic string, 20 elements, 100 steps)",
                 balance_table()),
                ("Heat equation (heat-conduction, alpha = 0): end temperatures at t_end = 0.05 vs the exact solution",
                 order_table())]
    with open(os.path.join(HERE, "thermo.csv"), "w", newline="") as f:
        for title, rows in sections:
            write_csv(f, rows, title=title)
    lines = ["# Thermoelastic string: benchmark", "",
             "Generated by `benchmarks/bench_thermo.py` (serial, DOLFINx 0.5.2, 2 shared cores; "
             f"total {time.perf_counter() - t0:.0f} s).  Energy errors relative to c theta0 L = {C * THETA0:g} J.", ""]
    for title, rows in sections:
        lines += [f"## {title}", "", *md(rows), ""]
    with open(os.path.join(HERE, "thermo.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
