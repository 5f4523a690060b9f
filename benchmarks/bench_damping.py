"""Kelvin-Voigt and Rayleigh damping: cost per step, and measured modal damping ratios against theory.

    .venv/bin/python benchmarks/bench_damping.py            # -> benchmarks/damping.{csv,md}

Cost.  The planar cantilever (scene cantilever-2d) and the inextensible 3D cantilever
(viscoelastic-cantilever-3d with E1 = 0) at 16 and 64 elements, serial, direct LU, wall time per
step (CPU time of the single-threaded process, best of 5: the machine is shared): undamped; Kelvin-Voigt (tau_kv; no extra field); the Kelvin-Voigt solid
emulated by one stiff Maxwell branch (stiffness c = 10 times the section's, relaxation time
tau_kv / c: dashpot viscosity c k tau_kv / c = tau_kv k, extra fields per strain).  The emulation
only approaches Kelvin-Voigt for h << tau_kv / c (tests/models/test_damping.py); here its cost is
what is measured, at the scenes' steps.

Damping ratios.  A cantilever let go from (nearly) its static tip deflection: zeta of mode 1 from
the logarithmic decrement of the tip (forms/damping.py: log_decrement_zeta, averaged over one
period of mode 2), against zeta = alpha / (2 omega_1) + tau omega_1 / 2 with omega_1 from the
undamped model's `modes` analysis (rodfem/analysis/linearize.py) and from Euler-Bernoulli,
3.516 sqrt(EI / (rhoA L^4)).  Rows: the steel strip of cantilever-2d, a soft 3D rod, and the
micro-rod of PyElastica issue #310 (L = 3 mm, r = 0.3 mm, E = 14 MPa, rho = 2300 kg/m^3, which
explicit codes integrate at dt = 1e-7 s) at dt = 1e-5 s.
"""
import argparse
import logging
import os
import time

import numpy as np
from mpi4py import MPI
from report import table, write_csv

from rodfem import Load, Problem, Support, run
from rodfem.analysis.linearize import Linearization, natural_modes
from rodfem.app.scene import load
from rodfem.demos._rod3d import NEWTON, straight
from rodfem.forms import cosserat_rod, damping

HERE = os.path.dirname(os.path.abspath(__file__))
logging.getLogger().setLevel(logging.WARNING)

C = 10.0   # Maxwell emulation: branch stiffness c x the section's, relaxation time tau / c


def planar_variants(tau):
    p = {q.name: q.default for q in load("cantilever-2d").parameters}
    emu = {"EA1": C * p["EA"], "GA1": C * p["GA"], "EI1": C * p["EI"], "tau1": tau / C}
    return [("undamped", "cantilever-2d", {}), ("Kelvin-Voigt", "cantilever-2d", {"tau_kv": tau}),
            ("Maxwell emulation", "viscoelastic-cantilever-2d", emu)]


def rod_variants(tau):
    return [("undamped", "viscoelastic-cantilever-3d", {"E1": 0.0}),
            ("Kelvin-Voigt", "viscoelastic-cantilever-3d", {"E1": 0.0, "tau_kv": tau}),
            ("Maxwell emulation", "viscoelastic-cantilever-3d", {"E1": C * 7.2e10, "tau1": tau / C})]


def cost(scene_name, overrides, n, steps, repeats=5):
    scene = load(scene_name)
    best = None
    for _ in range(repeats):
        p = scene.values({**overrides, "n_elements": n})
        problem = scene.build(p, MPI.COMM_WORLD)
        t0 = time.process_time()   # CPU time of this (single-threaded) process: others' load does not count
        res = run(problem, p["dt"], steps * p["dt"])
        ms = 1e3 * (time.process_time() - t0) / steps
        row = {"dofs": problem.dofs, "ms_per_step": ms, "newton_its": float(np.mean(res.column("newton_its")[1:])),
               "balance": res.max_balance_error / np.max(np.abs(res.column("H"))),
               "dissipated": res.rows[-1].get("dissipated", 0.0)}
        if best is None or ms < best["ms_per_step"]:
            best = row
    return best


def cost_table():
    rows = []
    for model, variants, steps in (("planar beam", planar_variants(8e-4), 200), ("3D rod", rod_variants(2e-3), 40)):
        for n in (16, 64):
            base = None
            for name, scene, over in variants:
                r = cost(scene, over, n, steps)
                base = base or r["ms_per_step"]
                rows.append({"model": model, "variant": name, "scene": scene, "n_elements": n, "steps": steps,
                             **r, "ratio": r["ms_per_step"] / base})
                print(f"  {model} n = {n} {name:18s}: {r['ms_per_step']:.2f} ms/step, {r['dofs']} dofs, "
                      f"{r['newton_its']:.2f} its, x {rows[-1]['ratio']:.2f}", flush=True)
    return rows


# -- damping ratios ----------------------------------------------------------------------------

def omegas(problem, k):
    omega, _, _ = natural_modes(Linearization(problem), k, "dense")
    return np.asarray(omega)


def ramp_release(value, t_load):
    value = np.asarray(value, dtype=float)
    return lambda t: value * min(t / t_load, 1.0) if t <= t_load else 0 * value


def rod3d(E, G, rho, radius, L, n, force, t_load, damp=None):
    A, I = np.pi * radius ** 2, np.pi * radius ** 4 / 4
    C_N, C_M = (1 / (E * A), 1 / (G * A), 1 / (G * A)), (1 / (G * 2 * I), 1 / (E * I), 1 / (E * I))
    r = cosserat_rod.CosseratRod(rho * A, (rho * 2 * I, rho * I, rho * I), C_N, C_M,
                                 damping=None if damp is None else cosserat_rod.rayleigh(*damp, C_N, C_M))
    return Problem(r, L, n, loads=[Load("v", ramp_release([0.0, force, 0.0], t_load), "right", "tip")],
                   supports=[Support("left", "clamped")], initial=straight((0.0, 0.0, 0.0), np.eye(3)),
                   newton_options=NEWTON), E * I / (rho * A * L ** 4)


def zeta_planar(tau, alpha):
    over = {"t_end": 1.0, "t_load": 0.25, "t_ramp": 0.25}
    scene = load("cantilever-2d")
    p = scene.values(over)
    om = omegas(scene.build(p, MPI.COMM_WORLD), 2)
    res = run(scene.build(scene.values({**over, "tau_kv": tau, "rayleigh_alpha": alpha}), MPI.COMM_WORLD),
              p["dt"], p["t_end"])
    return res, om, 3.516 * np.sqrt(p["EI"] / (p["rhoA"] * p["L"] ** 4)), 0.3, p["dt"], p["n_elements"]


# rod3d arguments (E, G, rho, radius, L, elements, tip force, t_load), h, t_end
RODS = {
    "soft rod (E = 10 MPa, r = 5 cm, L = 1 m)": ((1e7, 1e7 / 3, 1000.0, 0.05, 1.0, 8, 1.5, 0.7), 5e-3, 5.0),
    "micro-rod of PyElastica #310": ((14e6, 14e6 / 3, 2300.0, 3e-4, 3e-3, 10, 3e-4, 1.5e-3), 1e-5, 1.5e-2),
}


def zeta_rod(tau, alpha, case):
    args, h, T = RODS[case]
    plain, ratio = rod3d(*args)
    om = omegas(plain, 3)[[0, 2]]                    # bending 1 (twice: y, z), bending 2
    res = run(rod3d(*args, damp=(alpha, tau))[0], h, T)
    return res, om, 3.516 * np.sqrt(ratio), 1.1 * args[7], h, args[5]


def zeta_table():
    rows = []
    cases = [("cantilever-2d (steel strip)", zeta_planar, 52.556)]
    cases += [(case, lambda tau, alpha, c=case: zeta_rod(tau, alpha, c), omegas(rod3d(*RODS[case][0])[0], 1)[0])
              for case in RODS]
    for label, runner, w in cases:   # zeta_1 = 0.02 (KV), 0.02 (alpha), 0.01 + 0.01, 0.1 (KV)
        for tau, alpha in ((0.04 / w, 0.0), (0.0, 0.04 * w), (0.02 / w, 0.02 * w), (0.2 / w, 0.0)):
            t0 = time.perf_counter()
            res, om, w_eb, after, h, n = runner(tau, alpha)
            t, y = res.column("t"), res.column("tip_y")
            zeta = damping.log_decrement_zeta(t[t > after], y[t > after], average_over=2 * np.pi / om[1])
            theory = float(damping.zeta_rayleigh(om[0], alpha, tau))
            rows.append({"case": label, "elements": n, "h": h, "h_omega1": h * om[0], "tau_kv": tau, "alpha": alpha,
                         "omega1": om[0], "omega1_EB": w_eb, "zeta_measured": zeta, "zeta_theory": theory,
                         "zeta_theory_EB": float(damping.zeta_rayleigh(w_eb, alpha, tau)),
                         "error": zeta / theory - 1,
                         "balance": res.max_balance_error / np.max(np.abs(res.column("H"))),
                         "steps": res.steps, "seconds": time.perf_counter() - t0})
            print(f"  {label}: tau {tau:.3g} alpha {alpha:.3g}: zeta {zeta:.5f} vs {theory:.5f} ({zeta / theory - 1:+.2%}), "
                  f"omega_1 {om[0]:.4g} (EB {w_eb:.4g}), balance {rows[-1]['balance']:.1e}", flush=True)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.parse_args()
    start = time.time()
    print("cost per step:")
    cost_rows = cost_table()
    print("damping ratios:")
    zeta_rows = zeta_table()
    write_csv(os.path.join(HERE, "damping.csv"), cost_rows + zeta_rows,
              fieldnames=sorted({k for r in cost_rows + zeta_rows for k in r}))
    lines = [
        "# Kelvin-Voigt and Rayleigh damping benchmarks", "",
        f"Generated by `benchmarks/bench_damping.py` ({time.strftime('%Y-%m-%d %H:%M')}, {time.time() - start:.0f} s; "
        "serial, direct LU; CPU times of the single-threaded process, best of 5, on a shared 2-core machine).", "",
        "## Cost per time step", "",
        f"Kelvin-Voigt (`tau_kv`: viscous stresses in the momentum rows, no extra field) against the undamped "
        f"scene and against its emulation by one Maxwell branch of {C:g} x the section's stiffness and relaxation "
        "time tau_kv/" f"{C:g} (extra fields). Planar: cantilever-2d, 200 steps of 1 ms, tau_kv = 8e-4 s. 3D rod: "
        "viscoelastic-cantilever-3d (inextensible; dashpots on torsion and bending), 40 steps of 1 ms, "
        "tau_kv = 2e-3 s. x = ms/step over the undamped one (CPU time, best of 5).", "",
        *table(cost_rows, [("model", "{}"), ("n_elements", "{}", "elements"), ("variant", "{}"), ("dofs", "{}"),
                           ("ms_per_step", "{:.2f}", "ms/step"), ("ratio", "{:.2f}", "x"),
                           ("newton_its", "{:.2f}", "Newton its"), ("balance", "{:.1e}", "balance error / max H")]),
        "", "## Damping ratio of mode 1: measured against theory", "",
        "Free decay after a ramped tip load is removed. zeta measured: logarithmic decrement of the tip "
        "deflection (after a moving average over mode 2's period). Theory: zeta = alpha/(2 omega_1) + "
        "tau_kv omega_1 / 2 with omega_1 of the undamped model (`modes`), and with Euler-Bernoulli's "
        "omega_1 = 3.516 sqrt(EI/(rhoA L^4)) (EB).", "",
        *table(zeta_rows, [("case", "{}"), ("elements", "{}"), ("h", "{:.0e}"), ("h_omega1", "{:.3f}", "h omega_1"),
                           ("tau_kv", "{:.3g}", "tau_kv (s)"), ("alpha", "{:.3g}", "alpha (1/s)"),
                           ("omega1", "{:.4g}", "omega_1 modes"), ("omega1_EB", "{:.4g}", "omega_1 EB"),
                           ("zeta_measured", "{:.5f}", "zeta measured"), ("zeta_theory", "{:.5f}", "zeta theory"),
                           ("error", "{:+.2%}", "error"), ("zeta_theory_EB", "{:.5f}", "zeta EB"),
                           ("balance", "{:.1e}", "balance error / max H")]),
        "",
        "The micro-rod of PyElastica #310 (omega_1 ~ 4.5e3 rad/s, axial wave speed 78 m/s: explicit codes "
        "need dt ~ 1e-7 s) runs here at dt = 1e-5 s with the right omega_1 and zeta_1 (its omega_1 is 2 % below "
        "Euler-Bernoulli's: L/r = 10, shear and rotary inertia count). The Maxwell emulation of the cost table "
        "only approaches Kelvin-Voigt for h << tau_kv/c (tests/models/test_damping.py: "
        "test_kelvin_voigt_is_the_stiff_maxwell_limit).",
    ]
    with open(os.path.join(HERE, "damping.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {os.path.join(HERE, 'damping.md')}")


if __name__ == "__main__":
    main()
