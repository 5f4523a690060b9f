"""Cost of a time step of the 3D Cosserat rod (flying-spaghetti-3d, torsional variant), serial.

For 16, 128 and 1024 elements: dofs, ms per step, Newton iterations per step,
and the split into Jacobian assembly (J), residual assembly (F) and the rest
(LU factorisation + solve, energy and observables), for the Newton variants
in VARIANTS (the converged step is the same, only the iteration differs).
Then the largest
dt at which flying-spaghetti-3d (10 elements, t_end = 15) still converges.

Writes bench_cosserat_rod.md and bench_cosserat_rod.csv next to this file.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_cosserat_rod.py
"""
from mpi4py import MPI
from petsc4py import PETSc
from report import table, write_report

from rodfem import run
from rodfem.demos import flying_spaghetti_3d
from rodfem.errors import NewtonFailure

# Newton variants.  "default" is what the 3D scenes use (demos/_rod3d.py NEWTON:
# chord Newton reusing the Jacobian and its LU over 8 iterations, across steps,
# full-Newton retry on failure; the partial LU of rodfem/la/partial_lu.py, which orders
# the multipliers after the dofs they constrain, after PETSc's LU meets their zero
# pivots).  "full": a fresh Jacobian every iteration.  (PETSc's own LU reordered for
# a nonzero diagonal, -pc_factor_nonzeros_along_diagonal, is not a variant: it crashed
# PETSc 3.18 on the inextensible rod and on the tendon arm, and gave the tendon arm a
# factor too inaccurate for Newton.)
VARIANTS = {"default (chord lag 8)": {},
            "full Newton": {"snes_lag_jacobian": 1}}


def set_options(opts):
    db = PETSc.Options()
    for key in {k for v in VARIANTS.values() for k in v}:
        if db.hasName("rodfem_" + key):
            db.delValue("rodfem_" + key)
    for key, value in opts.items():
        db["rodfem_" + key] = value


def timed_run(n_elements, steps, dt=0.1, variant="default (chord lag 8)"):
    set_options(VARIANTS[variant])
    scene = flying_spaghetti_3d.scene
    p = scene.values({"n_elements": n_elements, "variant": "spatial", "dt": dt, "t_end": steps * dt})
    P = scene.build(p, MPI.COMM_WORLD)
    nw = P.newton
    res = run(P, p["dt"], p["t_end"])
    T = nw.timings
    n = res.steps
    total = 1e3 * res.wall_time / n
    J_ms, F_ms = 1e3 * T["J"] / n, 1e3 * T["F"] / n
    return {"n_elements": n_elements, "dofs": P.dofs, "steps": n, "newton": variant,
            "ms_per_step": round(total, 2), "newton_its": round(float(res.column("newton_its")[1:].mean()), 2),
            "J_ms": round(J_ms, 2), "F_ms": round(F_ms, 2), "solve_and_rest_ms": round(total - J_ms - F_ms, 2),
            "linear_solver": nw.linear_solver}


def largest_dt(dts=(0.1, 0.25, 0.375, 0.5, 0.75, 1.25, 2.5)):
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
        for variant in VARIANTS:
            rows.append(timed_run(n, steps, variant=variant))
            print(rows[-1], flush=True)
    set_options({})
    dts = largest_dt()
    print(dts, flush=True)
    dts = [{"dt": dt, "result": status, "newton_its": its} for dt, status, its in dts]
    write_report("bench_cosserat_rod", rows, [
        ("n_elements", "{}", "elements"), ("dofs", "{}"), ("newton", "{}", "Newton"), ("ms_per_step", "{}", "ms/step"),
        ("newton_its", "{}", "Newton its/step"), ("J_ms", "{}", "J ms"), ("F_ms", "{}", "F ms"),
        ("solve_and_rest_ms", "{}", "LU + rest ms"), ("linear_solver", "{}", "solver")],
        "3D Cosserat rod: cost per time step (serial, flying-spaghetti-3d spatial, dt = 0.1)",
        intro=["Serial, 2-core machine. Newton variants: see VARIANTS in the script (default = the scenes' chord "
               "Newton; PETSc's LU in RCM order meets zero pivots on the multiplier rows and the engine switches "
               "to the partial LU, which orders them last; the Jacobian holds only its possible nonzeros; 3 steps at 1024 elements from a fresh start include the first factorizations: "
               "benchmarks/scaling.md has warm steps).",
               "J = Jacobian assembly, F = residual assembly, rest = LU factorisation/solve + energy + observables."],
        notes=["## Largest dt (flying-spaghetti-3d, planar variant, 10 elements, t_end = 15, scene default Newton)", "",
               *table(dts, [("dt", "{}"), ("result", "{}"), ("newton_its", "{:.2f}", "Newton its/step")])])


if __name__ == "__main__":
    main()
