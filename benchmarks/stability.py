"""Stability sweep: push every scene to the extremes and record what happens.

    .venv/bin/python benchmarks/stability.py            # full sweep (minutes)
    .venv/bin/python benchmarks/stability.py --quick    # smoke run (shorter horizons, fewer dts)
    .venv/bin/python benchmarks/stability.py --only flying-spaghetti-2d

Writes benchmarks/stability.csv (one row per run) and benchmarks/stability.md
(the per-case summary: largest dt that converges against the explicit limit,
then every run).

What is pushed
* stiffness ratio EA L^2/EI up to 1e8 (slender steel rods), planar and 3D;
* inextensible and shear-rigid limits (zero compliance) of the 3D rod;
* time steps from below to >= 100x the explicit stability limit;
* long horizons (1e5 steps);  every other run is capped at 30 000 steps (5 000
  with --quick): its horizon t_end is then shortened, and the table says so;
* very large rotations (multi-turn roll-up, 10 turns);
* stiff and slow dashpots of a Maxwell branch (tau1 << dt, tau1 >> t_end).

Explicit limit (what a leapfrog / position-Verlet code such as PyElastica
needs, lumped mass): dt_explicit = min(h / c_i, 2 / omega_s) over the wave
speeds c = sqrt(EA/rhoA), sqrt(GA/rhoA), sqrt(EI/rhoI) on elements of length
h = L/n, and the local shear-rotation frequency omega_s = sqrt(GA/rhoI) of a
Timoshenko/Cosserat rod (the thickness-shear mode: it is what makes thin
explicit rods need tiny steps).  An estimate, stated as such; a zero
compliance (constraint) makes it 0: an explicit code cannot do it at all.

A run "converges" when Newton converges in every step.  A Newton failure is
a row with its step, time and residual (never a NaN run).  Energy drift =
max_n |H_n - H_0 - W_n| / max_n |H_n|, W_n the work supplied through the
ports up to t_n (so loaded runs count too), plus the dissipated energy
for a dissipating model (history column `dissipated`).
"""
import argparse
import math
import os
import sys
import time

import numpy as np
from report import table, write_csv

from rodfem.app.driver import run_scene
from rodfem.app.scene import scenes
from rodfem.errors import NewtonFailure, ParameterError
from rodfem.nls.newton import DEFAULTS

HERE = os.path.dirname(os.path.abspath(__file__))

ATOL = DEFAULTS["snes_atol"]
ACCURATE = 1e-2
COLUMNS = ["scene", "case", "overrides", "n_elements", "dt", "dt_explicit", "dt_over_explicit", "steps", "t_end",
           "status", "newton_its_mean", "newton_its_max", "energy_drift", "max_balance_error_relative",
           "error", "wall_time_s", "fail_step", "fail_t", "fail_residual", "fail_reason"]

EXPECTED = ["cantilever-2d", "flying-spaghetti-2d", "roll-up-2d", "roll-up-3d", "helix-3d",
            "flying-spaghetti-3d", "whirling-rod-3d", "hanging-cable", "crane-manoeuvre", "taut-string-wave"]


# -- explicit limit -------------------------------------------------------------

def _get(p, *names):
    for n in names:
        if n in p:
            return p[n]
    return None


def explicit_limit(p, length=None):
    """dt_explicit (see module doc) from whatever stiffness/density parameters the scene has; None if static."""
    L = length or p.get("L")
    if L is None:
        return None
    h = L / p["n_elements"]
    if "C_N1" in p:   # 3D rod, compliances
        if min(p[f"C_N{i}"] for i in (1, 2, 3)) == 0 or min(p[f"C_M{i}"] for i in (1, 2, 3)) == 0:
            return 0.0
        EA, GA = 1 / p["C_N1"], 1 / min(p["C_N2"], p["C_N3"])
        EI = 1 / min(p[f"C_M{i}"] for i in (1, 2, 3))
        rhoA, rhoI = p["rhoA"], min(v for v in (p.get("rhoJ1"), p.get("rhoJ2"), p.get("rhoJ3")) if v is not None)
    else:
        EA, GA, EI = _get(p, "EA"), _get(p, "GA"), _get(p, "EI")
        rhoA, rhoI = _get(p, "rhoA"), _get(p, "rhoI")
    if not rhoA:
        return None   # static
    speeds = [math.sqrt(k / rhoA) for k in (EA, GA) if k]
    dts = [h / c for c in speeds]
    if EI and rhoI:
        dts.append(h / math.sqrt(EI / rhoI))
    if GA and rhoI:
        dts.append(2 / math.sqrt(GA / rhoI))
    return min(dts) if dts else None


def dividing(t_end, dt):
    """The dt' <= ~dt that divides t_end into whole steps."""
    n = max(1, int(math.ceil(t_end / dt - 1e-9)))
    return t_end / n


# -- the cases --------------------------------------------------------------------

def planar_cases(quick):
    cases = []
    # Steel cantilever, load held: EA L^2/EI from 1.2e5 (10 mm strip) to 1e8 (0.4 mm wire).
    factors = [0.5, 1, 10, 100, 1000] if quick else [0.5, 1, 2, 10, 100, 1000, 5000]
    for ratio in ([1.2e5, 1e8] if quick else [1.2e5, 1e6, 1e8]):
        EA, rhoA, L = 2.1e7, 0.785, 1.0
        EI = EA * L**2 / ratio
        ov = {"EI": EI, "rhoI": rhoA * EI / EA, "fy": -0.1 * EI / L**2, "t_load": 1.0, "t_end": 0.1}
        cases.append(dict(scene="cantilever-2d", case=f"steel, EA L^2/EI = {ratio:.1e}, PL^2/EI = 0.1",
                          overrides=ov, dt_factors=factors))
    # Flying spaghetti: standard data; dt from 0.5x to 250x the explicit limit (0.01).
    cases.append(dict(scene="flying-spaghetti-2d", case="standard (Simo & Vu-Quoc data), t_end = 15",
                      overrides={}, dts=[0.005, 0.01, 0.1, 0.5, 1.0, 2.5] if quick else
                      [0.005, 0.01, 0.05, 0.1, 0.25, 0.5, 0.75, 1.0, 1.5, 2.5]))
    # Stiff flying spaghetti: EA = GA = 1e8 so that EA L^2/EI = 1e8.
    cases.append(dict(scene="flying-spaghetti-2d", case="stiff, EA = GA = 1e8 (EA L^2/EI = 1e8), t_end = 5",
                      overrides={"EA": 1e8, "GA": 1e8, "t_end": 5.0},
                      dts=[1e-3, 1e-2, 0.1, 0.5] if quick else [1e-4, 1e-3, 1e-2, 0.1, 0.25, 0.5, 1.0]))
    # Long horizons: 1e5 steps.
    nlong = 10_000 if quick else 100_000
    for dt in (0.01, 0.1):
        cases.append(dict(scene="flying-spaghetti-2d", case=f"long horizon, {nlong} steps of dt = {dt}",
                          overrides={"t_end": nlong * dt, "frames": 1}, dts=[dt], max_steps=None))
    # Multi-turn roll-up (static: no explicit limit; error against the exact circles).
    for turns in ([1, 10] if quick else [1, 3, 10]):
        cases.append(dict(scene="roll-up-2d", case=f"roll-up, {turns} turn(s), 40 elements",
                          overrides={"turns": turns, "n_elements": 40},
                          dts=[1.0, 0.5, 0.25, 0.1, 0.05, 0.02, 0.01] if not quick else [1.0, 0.5, 0.1, 0.01]))
    return cases


def rod3d_cases(quick, table):
    cases = []
    zero = {"C_N1": 0.0, "C_N2": 0.0, "C_N3": 0.0}
    if "roll-up-3d" in table:
        for label, ov in [("compliant", {}), ("inextensible and shear-rigid (C_N = 0)", zero)]:
            cases.append(dict(scene="roll-up-3d", case=label, overrides=ov,
                              dts=[1.0, 0.5, 0.25, 0.1, 0.05, 0.02] if not quick else [0.5, 0.1, 0.02]))
    for name in ("helix-3d", "flying-spaghetti-3d", "whirling-rod-3d"):
        if name in table:
            f = [1, 4, 16, 64] if quick else [0.25, 1, 4, 16, 64]
            cases.append(dict(scene=name, case="scene data", overrides={}, rel_factors=f))
            cases.append(dict(scene=name, case="inextensible and shear-rigid (C_N = 0)", overrides=zero,
                              rel_factors=f))
            if name == "flying-spaghetti-3d":   # EI = 100, L = 10: EA L^2/EI = 1e8 at C_N = 1e-8
                cases.append(dict(scene=name, case="stiff, C_N = 1e-8 (EA L^2/EI = 1e8)",
                                  overrides={k: 1e-8 for k in zero}, rel_factors=f))
    return cases


def viscoelastic_cases(quick, table):
    """Stiff and slow dashpots (Maxwell branch, benchmarks/viscoelastic.md): tau1 << dt and tau1 >> t_end."""
    cases = []
    if "viscoelastic-cantilever-2d" in table:
        f = [1, 16, 64] if quick else [0.25, 1, 4, 16, 64]
        cases.append(dict(scene="viscoelastic-cantilever-2d", case="scene data (tau1 = 0.02 s)", overrides={},
                          rel_factors=f))
        cases.append(dict(scene="viscoelastic-cantilever-2d",
                          case="stiff dashpot, tau1 = 1e-9 << dt (midpoint: a loaded branch would flip sign "
                               "every step, undamped; this one starts relaxed)",
                          overrides={"tau1": 1e-9}, rel_factors=f))
        cases.append(dict(scene="viscoelastic-cantilever-2d", case="slow dashpot, tau1 = 1e9 >> t_end",
                          overrides={"tau1": 1e9}, rel_factors=f))
    return cases


def generic_cases(quick, table, known):
    """Scenes this script has no special case for: dt from 1/4 to 64x the scene's own."""
    return [dict(scene=name, case="scene data, dt x (1/4 .. 64)", overrides={},
                 rel_factors=[1, 4, 16, 64] if quick else [0.25, 1, 4, 16, 64])
            for name in table if name not in known]


# -- running ---------------------------------------------------------------------

def run_case(scene, case, max_steps, quiet=False):
    """Runs of one case; each run at most `max_steps` steps (shorter horizon, stated) unless the case says None."""
    rows = []
    max_steps = case.get("max_steps", max_steps)
    p0 = scene.values({k: v for k, v in case["overrides"].items()})
    length = p0.get("L") or getattr(sys.modules.get(scene.build.__module__), "LENGTH", None)
    dt_expl = explicit_limit(p0, length)
    if "dts" in case:
        dts = case["dts"]
    elif "dt_factors" in case:
        dts = [f * dt_expl for f in case["dt_factors"]]
    else:
        dts = [f * p0["dt"] for f in case["rel_factors"]]
    dts = sorted({dividing(p0["t_end"], d) for d in dts})
    for dt in dts:
        ov = dict(case["overrides"], dt=dt)
        if max_steps and p0["t_end"] / dt > max_steps * (1 + 1e-9):
            ov["t_end"] = max_steps * dt
        ov.setdefault("frames", 1)
        p = scene.values(ov)
        row = {"scene": scene.name, "case": case["case"],
               "overrides": " ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                                     for k, v in case["overrides"].items()),
               "n_elements": p["n_elements"], "dt": dt, "t_end": p["t_end"], "steps": int(round(p["t_end"] / dt)),
               "dt_explicit": dt_expl, "dt_over_explicit": dt / dt_expl if dt_expl else None}
        t0 = time.perf_counter()
        try:
            result, summary = run_scene(scene, ov)
        except NewtonFailure as f:
            reason = f.reason
            if f.residual == f.residual and f.residual < 10 * ATOL:
                reason += (f"; the residual stagnated within 10x of snes_atol = {ATOL:g}"
                           " (round-off floor of the residual reached: not a divergence)")
            row.update(status="newton-failure", fail_step=f.step, fail_t=f.t, fail_residual=f.residual,
                       fail_reason=reason, wall_time_s=time.perf_counter() - t0)
        except ParameterError as e:
            row.update(status="bad-parameters", fail_reason=str(e))
        else:
            H, W = result.column("H"), result.column("supplied")
            D = result.column("dissipated") if "dissipated" in result.rows[0] else 0.0   # dissipating models
            scale = float(np.max(np.abs(H))) or 1.0
            row.update(status="converged", newton_its_mean=summary["newton_its_mean"],
                       newton_its_max=summary["newton_its_max"],
                       energy_drift=float(np.max(np.abs(H - H[0] + D - W))) / scale,
                       max_balance_error_relative=summary["max_balance_error_relative"],
                       wall_time_s=result.wall_time)
            ref = scene.reference(p) if scene.reference else None
            if ref:
                cols = [k for k in ref if k != "scale"]
                q = np.array([summary["final"][c] for c in cols])
                qe = np.array([ref[c] for c in cols])
                row["error"] = float(np.linalg.norm(q - qe)) / float(ref.get("scale") or np.linalg.norm(qe) or 1)
        if not quiet:
            extra = (f"its {row['newton_its_mean']:.2f}, drift {row['energy_drift']:.1e}"
                     + (f", error {row['error']:.1e}" if row.get("error") is not None else "")
                     if row["status"] == "converged"
                     else f"step {row.get('fail_step')}, t = {row.get('fail_t')}, residual {row.get('fail_residual')}"
                     f" ({row.get('fail_reason')})")
            ratio = f"{row['dt_over_explicit']:.3g}x expl." if row["dt_over_explicit"] else "static/constraint"
            print(f"  {scene.name:20s} {case['case'][:44]:44s} dt={dt:<10.4g} ({ratio:>16s}) {row['status']:15s} {extra}",
                  flush=True)
        rows.append(row)
    return rows


def fmt(v, spec):
    if v is None or v == "":
        return "–"
    return format(v, spec) if isinstance(v, (int, float)) else str(v)


def write(rows, missing, out_csv, out_md, wall):
    write_csv(out_csv, rows, COLUMNS)

    def opt(key, spec):     # a cell that may be missing
        return lambda r: fmt(r.get(key), spec)
    lines = ["# Stability sweep", "",
             f"Generated by `benchmarks/stability.py` ({time.strftime('%Y-%m-%d %H:%M')}, {wall:.0f} s; "
             "wall times on a shared 2-core machine: noisy). "
             "dt_explicit: estimated explicit (leapfrog) limit, see the script's docstring; 0 = a constraint "
             "(zero compliance) an explicit code cannot take; – = static.", "",
             "## Largest converging dt per case", ""]
    keys, cases = [], []
    for r in rows:
        if (r["scene"], r["case"]) not in keys:
            keys.append((r["scene"], r["case"]))
    for key in keys:
        rs = [r for r in rows if (r["scene"], r["case"]) == key]
        ok = [r for r in rs if r["status"] == "converged"]
        bad = [r for r in rs if r["status"] != "converged"]
        best = max(ok, key=lambda r: r["dt"]) if ok else None
        acc = [r["dt"] for r in ok if r.get("error") is not None and r["error"] < ACCURATE]
        acc = (format(max(acc), ".4g") if acc else "none") if any(r.get("error") is not None for r in ok) else "–"
        failures = "; ".join(f"dt={r['dt']:.3g}: {r['status']} at step {r.get('fail_step')}, t={fmt(r.get('fail_t'), '.3g')},"
                             f" residual {fmt(r.get('fail_residual'), '.2e')}" for r in bad) or "none"
        best = best or {}
        cases.append({"scene": key[0], "case": key[1], "dt_explicit": fmt(rs[0]["dt_explicit"], ".3g"),
                      "dt": fmt(best.get("dt"), ".4g"), "ratio": fmt(best.get("dt_over_explicit"), ".3g"),
                      "its": f"{fmt(best.get('newton_its_mean'), '.2f')}/{fmt(best.get('newton_its_max'), 'd')}",
                      "drift": fmt(best.get("energy_drift"), ".1e"), "error": fmt(best.get("error"), ".1e"),
                      "accurate": acc, "failures": failures})
    lines += table(cases, [("scene", "{}"), ("case", "{}"), ("dt_explicit", "{}"), ("dt", "{}", "largest dt that converges"),
                           ("ratio", "{}", "× explicit"), ("its", "{}", "Newton its (mean/max)"),
                           ("drift", "{}", "energy drift"), ("error", "{}", "error vs exact"),
                           ("accurate", "{}", f"largest dt with error < {ACCURATE:g}"), ("failures", "{}")])
    if missing:
        lines += ["", f"Scenes not swept (not registered or not loadable when this ran): {'; '.join(missing)}."]
    lines += ["", "## Every run", "", *table(rows, [
        ("scene", "{}"), ("case", "{}"), ("dt", "{:.4g}"), ("dt_over_explicit", opt("dt_over_explicit", ".3g"), "× explicit"),
        ("steps", "{steps} ({t_end:.4g})", "steps (t_end)"),
        ("status", lambda r: r["status"] if r["status"] == "converged" else (
            f"{r['status']}: step {r.get('fail_step')}, t={fmt(r.get('fail_t'), '.4g')}, residual {fmt(r.get('fail_residual'), '.2e')} ({r.get('fail_reason')})")),
        ("its", lambda r: f"{fmt(r.get('newton_its_mean'), '.2f')}/{fmt(r.get('newton_its_max'), 'd')}", "Newton its mean/max"),
        ("energy_drift", opt("energy_drift", ".1e"), "energy drift"),
        ("max_balance_error_relative", opt("max_balance_error_relative", ".1e"), "balance error (rel.)"),
        ("error", opt("error", ".1e"), "error vs exact"), ("wall_time_s", opt("wall_time_s", ".2f"), "wall (s)")])]
    with open(out_md, "w") as f:
        f.write("\n".join(lines) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="shorter horizons and fewer dts (a smoke run)")
    ap.add_argument("--only", nargs="+", metavar="SCENE", help="only these scenes")
    ap.add_argument("--out", default=HERE, help="directory for stability.csv / stability.md")
    args = ap.parse_args(argv)
    table = scenes()
    cases = planar_cases(args.quick) + rod3d_cases(args.quick, table) + viscoelastic_cases(args.quick, table)
    known = {c["scene"] for c in cases} | set(EXPECTED)
    cases += generic_cases(args.quick, table, known)
    missing = [n for n in EXPECTED if n not in table]
    cases = [c for c in cases if c["scene"] in table and (not args.only or c["scene"] in args.only)]
    for name in EXPECTED:
        if name in table and name not in {c["scene"] for c in cases} and not args.only:
            cases += generic_cases(args.quick, {name: None}, set())
    print(f"stability sweep: {len(cases)} cases; not registered: {', '.join(missing) or 'none'}", flush=True)
    t0 = time.perf_counter()
    rows = []
    suffix = "-quick" if args.quick else ""
    for case in cases:
        try:
            scene = table[case["scene"]].load()
        except Exception as e:   # a scene still being written by someone else: say so, go on
            print(f"  {case['scene']}: could not be loaded ({type(e).__name__}: {e}); not swept", flush=True)
            if case["scene"] not in missing:
                missing.append(f"{case['scene']} (failed to load: {type(e).__name__}: {e})")
            continue
        try:
            rows += run_case(scene, case, 5_000 if args.quick else 30_000)
        except ParameterError as e:
            print(f"  {case['scene']}: case '{case['case']}' skipped: {e}", flush=True)
        write(rows, missing, os.path.join(args.out, f"stability{suffix}.csv"),
              os.path.join(args.out, f"stability{suffix}.md"), time.perf_counter() - t0)
    print(f"wrote {args.out}/stability{suffix}.csv and .md", flush=True)


if __name__ == "__main__":
    main()
