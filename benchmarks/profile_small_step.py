"""Where a small step's time goes (issue 26): the parts of a step of a scene, this checkout and another.

    .venv/bin/python benchmarks/profile_small_step.py [--before CHECKOUT] [--scene flying-spaghetti-2d]
                                                      [--n 10] [--steps 300]

A step of the time loop (rodfem/analysis/timeloop.py) is: the inputs at t_{n+1/2} (`set_time`), the
predictor, Newton (residuals, Jacobians, their LU factorizations and solves, PETSc's SNES around
them), the functionals of the history (H, the supplied work, the columns) and `accept`.  Each part is
timed on its own, at the state after a few steps, many times over (CPU time, the median of three
rounds), and multiplied by how often a step calls it (counted in a run of `--steps` steps); "the rest"
is the run's CPU time per step less those parts: SNES's own work (line search, norms, convergence
tests, its calls into Python), the loop's bookkeeping (the history's row) and what the parts cost
together beyond their sum.  Each checkout runs in a process of its own; the table goes to stdout.
"""
import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def _median_us(f, n):
    f()
    rounds = []
    for _ in range(3):
        c = time.process_time()
        for _ in range(n):
            f()
        rounds.append((time.process_time() - c) / n * 1e6)
    return sorted(rounds)[1]


def profile(scene_name, n_elements, steps):
    """{part: (calls per step, us per call)} and the run's us per step, in this process."""
    from mpi4py import MPI

    from rodfem import run
    from rodfem.app.scene import load
    from rodfem.nls.newton import Newton
    scene = load(scene_name)
    p = scene.values({"n_elements": n_elements})
    counts = {"F": 0, "J": 0}
    residual, jacobian = Newton._residual, Newton._jacobian

    def counted_residual(self, *a):
        counts["F"] += 1
        return residual(self, *a)

    def counted_jacobian(self, *a):
        counts["J"] += 1
        return jacobian(self, *a)
    best = None
    for k in range(3):   # (the first: JIT modules loaded; then the better of two runs)
        Newton._residual, Newton._jacobian = counted_residual, counted_jacobian   # (before the SNES takes them)
        s = scene.build(p, MPI.COMM_WORLD)
        s.build()
        counts.update(F=0, J=0)
        c = time.process_time()
        res = run(s, p["dt"], steps * p["dt"])
        cpu = (time.process_time() - c) / steps * 1e6
        Newton._residual, Newton._jacobian = residual, jacobian
        if k and (best is None or cpu < best[0]):
            best = (cpu, counts["F"] / steps, counts["J"] / steps, sum(res.column("newton_its")) / steps, s)
    total, F_per, J_per, its, s = best
    nw, asm = s.newton, s.newton.assembler
    x, b, A = nw.xv, nw.b.copy(), nw.A
    ksp = nw.snes.getKSP()
    pc = ksp.getPC()
    y = x.duplicate()

    def jacobian_and_factor():
        asm.jacobian(x, A)
        ksp.setOperators(A, A)
        pc.setUp()
    asm.residual(x, b)
    parts = {}
    parts["residual"] = (F_per, _median_us(lambda: asm.residual(x, b), 2000))
    t_J = _median_us(lambda: asm.jacobian(x, A), 300)
    parts["Jacobian"] = (J_per, t_J)
    parts["LU factorization"] = (J_per, max(_median_us(jacobian_and_factor, 200) - t_J, 0.0))
    parts["LU solve"] = (its, _median_us(lambda: ksp.solve(b, y), 2000))
    parts["H"] = (1.0, _median_us(s.hamiltonian, 2000))
    parts["supplied work"] = (1.0, _median_us(s.supplied_work, 2000))
    parts["columns (observe)"] = (1.0, _median_us(s.observe, 2000))
    parts["inputs (set_time)"] = (1.0, _median_us(lambda: s.set_time(0.5 * p["dt"]), 2000))
    previous = s.X0.getArray(readonly=True).copy()
    parts["predictor"] = (1.0, _median_us(lambda: s.predict(previous, 1.0), 2000))
    parts["accept"] = (1.0, _median_us(s.accept, 2000))
    return {"total": total, "parts": parts, "its": its, "solver": nw.linear_solver, "dofs": A.getSize()[0]}


def child(checkout, scene, n, steps):
    env = dict(os.environ, PYTHONPATH=checkout, OMP_NUM_THREADS="1")
    code = (f"import json, sys; sys.path.insert(1, {HERE!r}); from profile_small_step import profile; "
            "import rodfem; assert rodfem.__file__.startswith(sys.argv[1]), rodfem.__file__; "
            f"print('RESULT', json.dumps(profile({scene!r}, {n}, {steps})))")
    out = subprocess.run([sys.executable, "-c", code, checkout], env=env, capture_output=True, text=True, check=True,
                         cwd=checkout)
    return json.loads(next(x for x in out.stdout.splitlines() if x.startswith("RESULT"))[6:])


def table(results):
    """The Markdown table: per part, calls per step and us per step for each checkout."""
    labels = list(results)
    head = "| part | " + " | ".join(f"{k}: calls/step | {k}: us/call | {k}: us/step" for k in labels) + " |"
    lines = [head, "|---|" + "---|---|---|" * len(labels)]
    first = results[labels[0]]
    for part in first["parts"]:
        cells = []
        for k in labels:
            calls, us = results[k]["parts"][part]
            cells.append(f"{calls:.2f} | {us:.1f} | {calls * us:.1f}")
        lines.append(f"| {part} | " + " | ".join(cells) + " |")
    rest = []
    for k in labels:
        r = results[k]
        parts = sum(c * u for c, u in r["parts"].values())
        rest.append(f" | | {r['total'] - parts:.1f}")
    lines.append("| the rest (SNES, the loop) |" + " |".join(rest) + " |")
    lines.append("| **step (run)** |" + " |".join(f" | | **{results[k]['total']:.1f}**" for k in labels) + " |")
    return lines


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", help="another checkout, profiled side by side")
    ap.add_argument("--scene", default="flying-spaghetti-2d")
    ap.add_argument("--n", type=int, default=10)
    ap.add_argument("--steps", type=int, default=300)
    args = ap.parse_args()
    results = {}
    if args.before:
        results["before"] = child(os.path.abspath(args.before), args.scene, args.n, args.steps)
    results["now"] = child(ROOT, args.scene, args.n, args.steps)
    r = results["now"]
    print(f"{args.scene}, {args.n} elements ({r['dofs']} unknowns), {args.steps} steps: Newton iterations per step "
          f"{r['its']:.2f}, LU {r['solver']}; load average {os.getloadavg()[0]:.1f}\n")
    print("\n".join(table(results)))


if __name__ == "__main__":
    main()
