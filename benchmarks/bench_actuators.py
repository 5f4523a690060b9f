"""Extra cost of the actuator ports (forms/actuators.py) on the 3D rod, serial.

The rod: the hanging silicone arm of soft-arm-swing (dynamic, gravity) at 16,
64 and 256 elements.  Two measures:

* assembly: ms per assembly of the residual F and the Jacobian J at one
  deformed state, for the rod alone and with one tendon, one chamber or
  both (the same state and space: the difference is the actuators' work per
  Newton iteration); the least of 7 round-robin batches (the machine is
  shared).
* per step (context): ms per step, Newton iterations per step and ms per
  Newton iteration over 40 steps (dt = 0.005), released from the straight
  unstressed shape, for the arm with (a) an end moment instead of actuators
  (a comparable bending motion), (b) one tendon, (c) one chamber, (d) both,
  all switched on over 0.05 s.  The iteration counts follow the motion.

Writes bench_actuators.md and bench_actuators.csv next to this file.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_actuators.py
"""
import os
import time

import numpy as np
import ufl
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI
from report import table, write_csv

from rodfem import Load, Problem, Support, run
from rodfem.demos import soft_arm_swing
from rodfem.demos._actuated import smoothstep, soft_arm_stiffness, soft_rod
from rodfem.demos._rod3d import NEWTON, end_moment, straight
from rodfem.fem.jit import compile_forms

HERE = os.path.dirname(os.path.abspath(__file__))
VARIANTS = {"end moment (no actuator)": dict(p_max=0.0, tau_max=0.0), "tendon": dict(p_max=0.0),
            "chamber": dict(tau_max=0.0), "tendon + chamber": {}}
TAU, PRESSURE, MOMENT = 0.3, 20e3, 2e-3     # N, Pa, N m (the moment bends the arm about as far)


def build(n, variant):
    """The scene's arm, released from the straight unstressed shape, actuators on over 0.05 s."""
    p = soft_arm_swing.scene.values({"n_elements": n, "dt": 0.005, "t_end": 0.2, **VARIANTS[variant]})
    hanging = soft_arm_swing.hanging
    soft_arm_swing.hanging = lambda p: straight((0.0, 0.0, 0.0), soft_arm_swing.DIRECTORS)
    try:
        if variant.startswith("end moment"):
            _, _, rhoA, _ = soft_arm_stiffness(p)
            loads = [end_moment(lambda t: np.array([0.0, 0.0, MOMENT * smoothstep(t, 0.0, 0.05)]), "body"),
                     Load("v", [0.0, 0.0, -rhoA * p["g"]], "domain", "gravity")]
            P = Problem(soft_rod(p, statics=False), p["L"], n, loads=loads, supports=[Support("left", "clamped")],
                        initial=soft_arm_swing.hanging(p), newton_options=NEWTON)
        else:
            P = soft_arm_swing.scene.build(p, MPI.COMM_WORLD)
    finally:
        soft_arm_swing.hanging = hanging
    for load in P.loads:
        if load.name == "tendon":
            load.history = lambda t: TAU * smoothstep(t, 0.0, 0.05)
        if load.name == "chamber":
            load.history = lambda t: PRESSURE * smoothstep(t, 0.0, 0.05)
    return P, p


def assembly_costs(P, repeats, batches=7):
    """ms per assembly of F and J at the state of P for the rod with gravity and (a) no actuator,
    (b) its tendon, (c) its chamber, (d) both: the same state, the same mixed space, the same
    element tensors; the variants are timed round-robin, the least of the batches kept."""
    test = P.space.split(ufl.TestFunction(P.space.V))
    acts = {ld.name: ld for ld in P.loads if ld.name in ("tendon", "chamber")}
    others = [ld for ld in P.loads if ld.name not in acts]
    sets = {"none": [], "tendon": ["tendon"], "chamber": ["chamber"], "tendon + chamber": ["tendon", "chamber"]}
    b = fpetsc.create_vector(P.F)
    A = fpetsc.create_matrix(P.J)
    jobs = {}
    for name, used in sets.items():
        F = P.model.residual(P.step, test, P.dx, P.ds)
        for ld in others + [acts[u] for u in used]:
            F += ld.input_map(P.step, test, P.dx, P.ds)
        c = compile_forms({"F": F, "J": ufl.derivative(F, P.x1)})

        def vec(form=c["F"]):
            with b.localForm() as bl:
                bl.set(0.0)
            fpetsc.assemble_vector(b, form)

        def mat(form=c["J"]):
            A.zeroEntries()
            fpetsc.assemble_matrix(A, form, bcs=P.bcs)
            A.assemble()
        jobs[name] = {"F": vec, "J": mat}
    best = {(n, k): np.inf for n in jobs for k in ("F", "J")}
    for _ in range(batches):
        for n, fns in jobs.items():
            for k, fn in fns.items():
                fn()
                t0 = time.perf_counter()
                for _ in range(repeats):
                    fn()
                best[n, k] = min(best[n, k], 1e3 * (time.perf_counter() - t0) / repeats)
    return {f"{n} {k}": v for (n, k), v in best.items()}


def main():
    rows, asm = [], []
    for n in (16, 64, 256):
        for variant in VARIANTS:
            P, p = build(n, variant)
            res = run(P, p["dt"], p["t_end"])
            its = res.column("newton_its")[1:]
            rows.append({"n_elements": n, "dofs": P.dofs, "variant": variant,
                         "ms_per_step": round(1e3 * res.wall_time / res.steps, 2),
                         "newton_its": round(float(its.mean()), 2),
                         "ms_per_newton_it": round(1e3 * res.wall_time / max(its.sum(), 1), 3),
                         "tip_deflection": float(np.hypot(res.rows[-1]["tip_x"], res.rows[-1]["tip_y"])),
                         "max_balance_rel": res.max_balance_error / np.max(np.abs(res.column("H")))})
            print(rows[-1], flush=True)
            if variant == "tendon + chamber":
                a = assembly_costs(P, repeats=max(10, 640 // n))
                asm.append({"n_elements": n, "dofs": P.dofs, **{k: round(v, 4) for k, v in a.items()}})
                print(asm[-1], flush=True)
    with open(os.path.join(HERE, "bench_actuators.csv"), "w", newline="") as f:
        write_csv(f, rows)
        write_csv(f, asm)

    def extra(r, k, spec):      # the difference to the rod alone, and in per cent
        return f"{r[k] - r['none ' + k]:{spec}} ({100 * (r[k] / r['none ' + k] - 1):+.0f} %)"
    each = [{**a, "actuators": v, "F": a[v + " F"], "J": a[v + " J"]}
            for a in asm for v in ("none", "tendon", "chamber", "tendon + chamber")]
    lines = ["# Actuator ports: extra cost on the 3D rod (serial, the soft-arm-swing arm)", "",
             "## Assembly: the same state with and without the actuators", "",
             "ms per assembly of the residual F and of the Jacobian J (with the Dirichlet rows) of the rod "
             "under gravity, alone and with one tendon, one chamber, or both, at the same deformed state "
             "(after the 40 steps below); the variants timed in turn, the least of 7 batches kept (the "
             "machine is shared).  Extra = the difference to the rod alone.  The scenes' chord Newton "
             "assembles F every iteration and J at most every 8 iterations.", "",
             *table(each, [("n_elements", "{}", "elements"), ("dofs", "{}"), ("actuators", "{}"),
                           ("F", "{:.3f}", "F ms"), ("extra F", lambda r: extra(r, "F", "+.3f")),
                           ("J", "{:.2f}", "J ms"), ("extra J", lambda r: extra(r, "J", "+.2f"))]), "",
             "## Per step (context): 40 steps, dt = 0.005, released straight under gravity", "",
             f"Tendon {TAU} N, chamber {PRESSURE / 1e3:g} kPa, or (no actuator) a body-fixed end moment "
             f"{MOMENT * 1e3:g} mN m, each on over 0.05 s.  The chord Newton of the 3D scenes; ms per step "
             "follows the iteration count, which follows the motion; ms per Newton iteration includes the "
             "LU solves and the amortised Jacobians.  2-core shared machine: +-20 % noise.", "",
             *table(rows, [("n_elements", "{}", "elements"), ("dofs", "{}"), ("variant", "{}", "load"),
                           ("ms_per_step", "{}", "ms/step"), ("newton_its", "{}", "Newton its/step"),
                           ("ms_per_newton_it", "{}", "ms/Newton it"), ("tip_deflection", "{:.4f}", "tip deflection"),
                           ("max_balance_rel", "{:.1e}", "max balance / max H")])]
    with open(os.path.join(HERE, "bench_actuators.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
