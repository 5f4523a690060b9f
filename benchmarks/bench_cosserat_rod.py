"""Cost of a time step of the 3D Cosserat rod (flying-spaghetti-3d, torsional variant), serial.

For 16, 128 and 1024 elements: dofs, ms per step, Newton iterations per step,
and the split into Jacobian assembly (J), residual assembly (F) and the rest
(LU factorisation + solve, energy and observables), for the default full
Newton and for a chord-Newton that reuses the Jacobian over 8 iterations
and lets PETSc's LU reorder for a nonzero diagonal (see FAST; the
converged step is the same, only the iteration differs).  Then the largest
dt at which flying-spaghetti-3d (10 elements, t_end = 15) still converges.

Writes bench_cosserat_rod.md and bench_cosserat_rod.csv next to this file.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_cosserat_rod.py
"""
import csv
import os
import time

from mpi4py import MPI
from petsc4py import PETSc

from rodfem import run
from rodfem.newton import NewtonFailure

from demos import flying_spaghetti_3d

HERE = os.path.dirname(os.path.abspath(__file__))
# "fast": reuse the Jacobian (and its LU) over 8 Newton iterations, across
# steps, and let PETSc's native LU reorder for a nonzero diagonal instead of
# falling back to MUMPS.  NOT the default: that reordering crashed PETSc 3.18
# (SEGV in MatLUFactorNumeric) on the inextensible rod (C_N1 = 0).
FAST = {"snes_lag_jacobian": 8, "snes_lag_jacobian_persists": True, "pc_factor_nonzeros_along_diagonal": 1e-12}


def set_options(opts):
    db = PETSc.Options()
    for key in FAST:
        if db.hasName("rodfem_" + key):
            db.delValue("rodfem_" + key)
    for key in ("pc_factor_mat_solver_type",):   # Newton sets it; the fallback may have switched it
        if db.hasName("rodfem_" + key):
            db.delValue("rodfem_" + key)
    for key, value in opts.items():
        db["rodfem_" + key] = value


def timed_run(n_elements, steps, dt=0.1, newton=None):
    set_options(newton or {})
    scene = flying_spaghetti_3d.scene
    p = scene.values({"n_elements": n_elements, "variant": "spatial", "dt": dt, "t_end": steps * dt})
    P = scene.build(p, MPI.COMM_WORLD)
    nw = P.newton
    T = {"J": 0.0, "F": 0.0}
    fJ, fF = nw._jacobian, nw._residual

    def J(*a):
        t = time.perf_counter()
        fJ(*a)
        T["J"] += time.perf_counter() - t

    def F(*a):
        t = time.perf_counter()
        fF(*a)
        T["F"] += time.perf_counter() - t
    nw.snes.setFunction(F, nw.b)
    nw.snes.setJacobian(J, nw.A)
    res = run(P, p["dt"], p["t_end"])
    n = res.steps
    total = 1e3 * res.wall_time / n
    J_ms, F_ms = 1e3 * T["J"] / n, 1e3 * T["F"] / n
    return {"n_elements": n_elements, "dofs": P.dofs, "steps": n, "newton": "fast (chord lag 8, reordered LU)" if newton else "full (default)",
            "ms_per_step": round(total, 2), "newton_its": round(float(res.column("newton_its")[1:].mean()), 2),
            "J_ms": round(J_ms, 2), "F_ms": round(F_ms, 2), "solve_and_rest_ms": round(total - J_ms - F_ms, 2),
            "linear_solver": nw.linear_solver}


def largest_dt(dts=(0.1, 0.25, 0.5, 1.25, 2.5)):
    set_options({})
    out = []
    for dt in dts:
        p = flying_spaghetti_3d.scene.values({"dt": dt})
        P = flying_spaghetti_3d.scene.build(p, MPI.COMM_WORLD)
        try:
            res = run(P, dt, p["t_end"])
            out.append((dt, "converged", float(res.column("newton_its")[1:].mean())))
        except NewtonFailure as e:
            out.append((dt, f"failed at t = {e.t:g}", float("nan")))
    return out


def main():
    rows = []
    for n, steps in ((16, 20), (128, 10), (1024, 3)):
        for newton in (None, FAST):
            rows.append(timed_run(n, steps, newton=newton))
            print(rows[-1], flush=True)
    dts = largest_dt()
    print(dts, flush=True)
    with open(os.path.join(HERE, "bench_cosserat_rod.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    with open(os.path.join(HERE, "bench_cosserat_rod.md"), "w") as f:
        f.write("# 3D Cosserat rod: cost per time step (serial, flying-spaghetti-3d spatial, dt = 0.1)\n\n")
        f.write("Machine: 2 shared cores (other jobs running). full = default Newton; the native LU meets zero pivots "
                "(multiplier rows) and the engine falls back to MUMPS (column solver). fast: see FAST in the script.\n"
                "J = Jacobian assembly, F = residual assembly, rest = LU factorisation/solve + energy + observables.\n\n")
        f.write("| elements | dofs | Newton | ms/step | Newton its/step | J ms | F ms | LU + rest ms | solver |\n")
        f.write("|---|---|---|---|---|---|---|---|---|\n")
        for r in rows:
            f.write(f"| {r['n_elements']} | {r['dofs']} | {r['newton']} | {r['ms_per_step']} | {r['newton_its']} | "
                    f"{r['J_ms']} | {r['F_ms']} | {r['solve_and_rest_ms']} | {r['linear_solver']} |\n")
        f.write("\n## Largest dt (flying-spaghetti-3d, planar variant, 10 elements, t_end = 15, full Newton)\n\n")
        f.write("| dt | result | Newton its/step |\n|---|---|---|\n")
        for dt, status, its in dts:
            f.write(f"| {dt} | {status} | {its:.2f} |\n")


if __name__ == "__main__":
    main()
