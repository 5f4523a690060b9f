"""Cost per step of friction between rods, with the friction at the tubes' contact point (the section
couples, forms/rod_contact.py) against the code before it (friction at the centrelines' closest points).

The rod-collision scene with friction (mu = 0.3, the rods sliding across each other at 0.1 m/s, E = 1e10,
gap 1e-5: the rods touch during the 6 steps of dt = 1e-3), discrete gradient, serial.  The friction's
Newton blocks grow from 12 x 12 (the nodes' positions and velocities) to 48 x 48 (also the directors and
their rates), by central differences over 96 instead of 24 columns.

    PYTHONPATH=$PWD .venv/bin/python benchmarks/bench_rod_friction.py            # this tree
    PYTHONPATH=/path/to/before .venv/bin/python benchmarks/bench_rod_friction.py --label before

prints one JSON line per size (CPU ms per step, the contact's own CPU ms per step, Newton iterations,
the angular momentum's drift and the balance error); the table is benchmarks/bench_rod_friction.md.
"""
import argparse
import json
import os
import time

import numpy as np
from mpi4py import MPI

from rodfem import run
from rodfem.demos.rod_collision import scene


def step(n_elements):
    p = scene.values({"n_elements": n_elements, "E": 1e10, "gap": 1e-5, "dt": 1e-3, "t_end": 6e-3,
                      "mu": 0.3, "slide": 0.1, "offset_a": 0.1, "offset_b": 0.05})
    system = scene.build(p, MPI.COMM_WORLD)
    cpu = time.process_time()
    result = run(system, p["dt"], p["t_end"])
    cpu = time.process_time() - cpu
    spent = system.body_contacts.seconds
    L = np.array([[r.get(f"L_{c}", 0.0) for c in "xyz"] for r in result.rows])
    return {"elements": n_elements, "steps": result.steps, "cpu_ms_per_step": 1e3 * cpu / result.steps,
            "contact_ms_per_step": 1e3 * sum(spent.values()) / result.steps,
            "matrix_ms_per_step": 1e3 * spent["matrix"] / result.steps,
            "newton_its": sum(r["newton_its"] for r in result.rows[1:]),
            "active": max(r.get("touch.active", 0.0) for r in result.rows),
            "L_drift": float(np.abs(L - L[0]).max()), "balance": result.max_balance_error,
            "dissipated": result.rows[-1]["dissipated"], "load": os.getloadavg()[0]}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--label", default="after")
    parser.add_argument("--sizes", type=int, nargs="+", default=[50, 500])
    args = parser.parse_args()
    for n in args.sizes:
        print(json.dumps({"label": args.label, **step(n)}), flush=True)


if __name__ == "__main__":
    main()
