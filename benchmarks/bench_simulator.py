"""The step interface (rodfem.Simulator, issue 29): the cost of one `step` call against the built-in
time loop on the same steps.

    .venv/bin/python benchmarks/bench_simulator.py     # -> benchmarks/simulator.{csv,md}

robot-arm-control with controller=external (the hub moment an input port), n_elements = 8 and 32,
dt = 0.01, 300 steps: (a) `run` with the hub moment as a time function u(t) = 0.5 sin(2 pi t);
(b) the same inputs through `Simulator.step` one step at a time (u computed in the Python loop);
(c) through `step` with a save() before every step (what an RL or co-simulation master that may
roll back pays).  The histories of (a) and (b) agree to round-off (checked); wall time per step,
best of 3.
"""
import time

import numpy as np
from mpi4py import MPI
from report import write_report

from rodfem import Simulator, run
from rodfem.app.scene import load

STEPS, DT = 300, 0.01
PORT = "beam.hub moment"


def u_of(t):
    return 0.5 * np.sin(2 * np.pi * t)


def loop(n_elements):
    scene = load("robot-arm-control")
    best = np.inf
    for _ in range(3):
        system = scene.build(scene.values({"controller": "external", "n_elements": n_elements}), MPI.COMM_WORLD).build()
        (hub,) = system.body("beam").loads
        hub.value = lambda t: np.asarray(u_of(t))
        res = run(system, DT, STEPS * DT)
        best = min(best, res.wall_time)
    return best / STEPS, res


def stepped(n_elements, save):
    best = np.inf
    for _ in range(3):
        sim = Simulator("robot-arm-control", controller="external", n_elements=n_elements)
        t0 = time.perf_counter()
        for n in range(STEPS):
            if save:
                sim.save()
            sim.step({PORT: u_of((n + 0.5) * DT)}, DT)
        best = min(best, time.perf_counter() - t0)
    return best / STEPS, sim


def main():
    rows = []
    for n_el in (8, 32):
        t_run, res = loop(n_el)
        t_step, sim = stepped(n_el, False)
        t_save, _ = stepped(n_el, True)
        diff = max(abs(a[c] - b[c]) for a, b in zip(sim.history.rows, res.rows) for c in ("H", "tip_x", "tip_y"))
        rows.append({"n_elements": n_el, "dofs": sim.system.dofs, "run_ms": 1e3 * t_run, "step_ms": 1e3 * t_step,
                     "save_step_ms": 1e3 * t_save, "overhead_ms": 1e3 * (t_step - t_run),
                     "overhead_pct": 100 * (t_step / t_run - 1), "max_difference": diff,
                     "balance": sim.history.max_balance_error})
    columns = [("n_elements", "{}"), ("dofs", "{}"), ("run_ms", "{:.3f}", "run ms/step"),
               ("step_ms", "{:.3f}", "step() ms/call"), ("save_step_ms", "{:.3f}", "save()+step() ms"),
               ("overhead_ms", "{:.3f}", "overhead ms/call"), ("overhead_pct", "{:.0f}", "overhead %"),
               ("max_difference", "{:.1e}", "max |step - run| (H, tip)"), ("balance", "{:.1e}", "max balance")]
    write_report("simulator", rows, columns,
                 title="Step interface: cost of Simulator.step against the built-in loop",
                 notes=[f"robot-arm-control, controller=external, dt = {DT}, {STEPS} steps, u = 0.5 sin(2 pi t) at "
                        "the hub; best of 3 on one core of the shared 2-core machine.  The overhead is the Python "
                        "of `step` (the inputs, the outputs' assembly y_j = <e_j, B^T z>, the history row)."])


if __name__ == "__main__":
    main()
