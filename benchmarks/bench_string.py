"""Hyperelastic PH string: balance errors per material, cost per step, observed orders,
wave speed, extreme cases.

    .venv/bin/python benchmarks/bench_string.py      # -> benchmarks/string.{csv,md}  (~1 min, serial)

1. Energy balance: max_n |H_{n+1} - H_n - h y.u| / max|H| on the 3D hanging-cable swing
   (tilt 30 deg, vy0 = 1, 200 steps) and on the crane manoeuvre (120 steps), for every
   material, discrete gradient vs midpoint.
2. Cost: wall time per step (best of 3) and Newton iterations per step on the hanging
   cable at 10, 100, 1000 elements (dt = 0.01, 100 steps).
3. Orders: in time (tip position at t = 0.4 against dt = 0.4/2048, 8 elements); in space,
   static (against the exact equilibrium of the logarithmic law) and dynamic (tip at
   t = 0.5 against 640 elements, dt = 1e-3 for all).
4. Wave speed of taut-string-wave against sqrt(N/mu), mu = rhoA/stretch.
5. Extreme cases: stiff cable (EA = 1e7, EA/(rhoA g L) = 1.02e6), large steps, slack cable.
"""
import math
import os
import time

import numpy as np
from mpi4py import MPI
from report import table, write_csv

from rodfem import Load, Problem, Support, run
from rodfem.app.driver import run_scene
from rodfem.demos.crane_manoeuvre import scene as crane
from rodfem.demos.hanging_cable import scene as hanging
from rodfem.demos.taut_string_wave import scene as wave
from rodfem.demos.taut_string_wave import speeds
from rodfem.forms.string import String
from rodfem.forms.string_materials import MATERIALS, tension_only

HERE = os.path.dirname(os.path.abspath(__file__))
COMM = MPI.COMM_SELF


def rel_balance(res):
    return float(np.max(np.abs(res.column("balance_error"))) / np.max(np.abs(res.column("H"))))


def its(res):
    return float(np.mean(res.column("newton_its")[1:]))


def balance_table():
    rows = []
    for scene, over in ((hanging, {"t_end": 2.0, "vy0": 1.0}), (crane, {})):
        for material in MATERIALS:
            for rule in ("discrete-gradient", "midpoint"):
                res, s = run_scene(scene, {**over, "material": material, "integrator": rule})
                rows.append({"scene": scene.name, "material": material, "integrator": rule, "steps": res.steps,
                             "max_balance_error_rel": rel_balance(res), "max_balance_error_abs": res.max_balance_error,
                             "newton_its": its(res), "ms_per_step": 1e3 * res.wall_time / res.steps})
    return rows


def cost_table():
    rows = []
    for n in (10, 100, 1000):
        best = None
        for _ in range(3):
            p = hanging.values({"n_elements": n, "t_end": 1.0, "vy0": 1.0})
            pr = hanging.build(p, COMM)
            res = run(pr, p["dt"], p["t_end"])
            row = {"n_elements": n, "dofs": pr.dofs, "ms_per_step": 1e3 * res.wall_time / res.steps,
                   "newton_its": its(res), "max_balance_error_rel": rel_balance(res)}
            if best is None or row["ms_per_step"] < best["ms_per_step"]:
                best = row
        rows.append(best)
    return rows


def tip(over):
    res, _ = run_scene(hanging, over)
    return np.array([res.column(c)[-1] for c in ("tip_x", "tip_y", "tip_z")])


def order_rows(label, hs, errs):
    out = []
    for i, (h, e) in enumerate(zip(hs, errs)):
        o = math.log(errs[i - 1] / e) / math.log(hs[i - 1] / h) if i else float("nan")
        out.append({"study": label, "h": h, "error": e, "order": o})
    return out


def time_order():
    base = {"n_elements": 8, "t_end": 0.4, "vy0": 1.0}
    rows = []
    for rule in ("discrete-gradient", "midpoint"):
        ref = tip({**base, "dt": 0.4 / 2048, "integrator": rule})
        dts = [0.4 / k for k in (16, 32, 64, 128, 256)]
        rows += order_rows(f"time, {rule} (tip at t=0.4, 8 el.)", dts,
                           [float(np.linalg.norm(tip({**base, "dt": dt, "integrator": rule}) - ref)) for dt in dts])
    return rows


def exact_hanging(s, L, EA, rhoA, g):
    k = rhoA * g / EA

    def F(u):
        return u ** 2 / 2 + (u * np.sqrt(1 + u ** 2) + np.arcsinh(u)) / 2
    u = k * (L - s)
    lam = u + np.sqrt(1 + u ** 2)
    return -(F(k * L) - F(u)) / k, lam ** 2


def space_order():
    L, EA, rhoA, g = 1.0, 20.0, 1.0, 9.81
    xg, wg = np.polynomial.legendre.leggauss(6)
    ns, eR, eC = [4, 8, 16, 32, 64], [], []
    for n in ns:
        pr = hanging.build(hanging.values({"n_elements": n, "angle": 0.0}), COMM)
        s, r = pr.space.nodal(pr.x0, "r")
        _, C = pr.space.nodal(pr.x0, "C")
        a2 = c2 = 0.0
        for i in range(n):
            a, b = s[i], s[i + 1]
            q = a + (b - a) * (xg + 1) / 2
            zh = r[i, 2] + (r[i + 1, 2] - r[i, 2]) * (q - a) / (b - a)
            ze, Ce = exact_hanging(q, L, EA, rhoA, g)
            a2 += (b - a) / 2 * np.sum(wg * (zh - ze) ** 2)
            c2 += (b - a) / 2 * np.sum(wg * (C[i, 0] - Ce) ** 2)
        eR.append(math.sqrt(a2))
        eC.append(math.sqrt(c2))
    hs = [L / n for n in ns]
    rows = order_rows("space, static: ||r - r_exact||_L2 (P1)", hs, eR)
    rows += order_rows("space, static: ||C - C_exact||_L2 (DG0)", hs, eC)
    base = {"t_end": 0.5, "dt": 1e-3, "vy0": 1.0}
    ref = tip({**base, "n_elements": 640})
    ns = [10, 20, 40, 80, 160]
    rows += order_rows("space, dynamic: tip at t=0.5 vs 640 el. (dt=1e-3)", [L / n for n in ns],
                       [float(np.linalg.norm(tip({**base, "n_elements": n}) - ref)) for n in ns])
    return rows


def wave_speed():
    rows = []
    for n, dt in ((50, 4e-3), (100, 2e-3), (200, 1e-3)):
        p = wave.values({"n_elements": n, "dt": dt})
        N, c_s, c = speeds(p)
        pr = wave.build(p, COMM)
        times, peaks = [], []

        class Track:
            def record(self, row, problem):
                s, r = problem.space.nodal(problem.x1, "r")
                w = r[:, 1]
                i = int(np.argmax(w))
                a, b, cc = w[i - 1], w[i], w[i + 1]
                times.append(row["t"])
                peaks.append(s[i] + 0.5 * (s[1] - s[0]) * (a - cc) / (a - 2 * b + cc))
        res = run(pr, p["dt"], p["t_end"], writer=Track())
        measured = p["stretch"] * np.polyfit(times, peaks, 1)[0]
        rows.append({"n_elements": n, "dt": dt, "tension_N": N, "c_exact": c, "c_measured": measured,
                     "rel_error": measured / c - 1, "vs_sqrt_N_over_rhoA_ref": measured / math.sqrt(N / p["rhoA"]) - 1,
                     "max_balance_error_rel": rel_balance(res)})
    return rows


def extreme():
    rows = []

    def add(case, res, extra=""):
        H = res.column("H")
        rows.append({"case": case, "steps": res.steps, "finite": bool(np.all(np.isfinite(H))),
                     "max_balance_error_rel": rel_balance(res), "newton_its": its(res),
                     "ms_per_step": 1e3 * res.wall_time / res.steps, "note": extra})
    for EA, dt, t_end in ((1e7, 0.01, 2.0), (1e7, 0.1, 5.0), (20.0, 0.25, 5.0), (1e9, 0.05, 2.0)):
        res, s = run_scene(hanging, {"EA": EA, "dt": dt, "t_end": t_end, "vy0": 0.5})
        add(f"hanging, EA={EA:g} (EA/(rhoA g L)={EA / 9.81:.2g}), dt={dt:g}", res)
    res, s = run_scene(crane, {"EA": 1e7, "dt": 0.05})
    add("crane, EA=1e7, dt=0.05", res)
    model = String(tension_only(EA=100.0), 1.0)
    pr = Problem(model, 1.0, 20, loads=[Load("v", [0.0, 0.0, -9.81], "domain", "gravity")],
                 supports=[Support("left", "pinned"), Support("right", "pinned")],
                 initial={"r": lambda x: np.vstack([0.5 * x[0], 0 * x[0], 0 * x[0]])},
                 integrator="discrete-gradient", comm=COMM)
    Cmin, Cmax = [], []

    class Track:
        def record(self, row, problem):
            C = problem.space.nodal(problem.x1, "C")[1]
            Cmin.append(C.min())
            Cmax.append(C.max())
    res = run(pr, 0.01, 2.0, writer=Track())
    add("slack cable (tension-only, pins L/2 apart), dt=0.01", res, f"C in [{min(Cmin):.3g}, {max(Cmax):.3g}]")
    return rows


def md_table(rows):
    """A Markdown table of every key of the rows, floats to 3 digits."""
    cells = [{k: f"{v:.3g}" if isinstance(v, float) else str(v) for k, v in r.items()} for r in rows]
    return table(cells, [(k, "{}") for k in rows[0]])


def main():
    t0 = time.perf_counter()
    sections = [("Energy balance per material", balance_table()),
                ("Cost per step (hanging cable, logarithmic, DG, dt = 0.01, serial LU)", cost_table()),
                ("Orders in time and space", time_order() + space_order()),
                ("Wave speed (taut-string-wave, kirchhoff, stretch 1.1)", wave_speed()),
                ("Extreme cases (logarithmic unless stated, discrete gradient)", extreme())]
    with open(os.path.join(HERE, "string.csv"), "w", newline="") as f:
        for title, rows in sections:
            write_csv(f, rows, title=title)
    lines = ["# Hyperelastic PH string: benchmark", "",
             "Generated by `benchmarks/bench_string.py` (serial, DOLFINx 0.5.2, 2 shared cores; "
             f"total {time.perf_counter() - t0:.0f} s).  Balance errors are max over steps of "
             "|H_{n+1} - H_n - h y.u| / max|H|.", ""]
    for title, rows in sections:
        lines += [f"## {title}", "", *md_table(rows), ""]
    with open(os.path.join(HERE, "string.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
