"""Side by side with PyElastica: the same physical scenes, the same reference, the same error.

    scripts/install-deps --bench                      # PyElastica (optional benchmark dependency)
    .venv/bin/python benchmarks/elastica_compare.py   # both scenes (~10 min on 2 cores)
    .venv/bin/python benchmarks/elastica_compare.py --quick --only flying-spaghetti-2d

Scenes (planar; PyElastica's 3D Cosserat rod moves in the x-y plane)

* ``cantilever-2d`` under gravity: the steel strip of rodfem's scene (EA = 2.1e7 N,
  GA = 6.73e6 N, EI = 175 N m^2, rhoA = 0.785 kg/m, rhoI = 6.54e-6 kg m, L = 1 m),
  clamped at s = 0, gravity 9.81 m/s^2 switched on at t = 0, t_end = 0.06 s
  (about half the first period: the tip near its lowest point).
* ``flying-spaghetti-2d``: the standard data (EA = GA = 1e4, EI = 100, rhoA = 1,
  rhoI = 10, L = 10), end force (8, 0) and moment -80 for t <= 2.5, t_end = 15.

PyElastica is given exactly the same line properties: radius r from
r^2/4 = EI/EA, E = EA/A, density = rhoA/A, shear modulus G = GA/(alpha_c A)
with its alpha_c = 27/28, and its mass second moment of inertia overwritten
with rhoI (the spaghetti's rhoI = 10 is not a disk's).  Its clamp is
OneEndFixedBC on node 0 and element 0's directors, its end moment is applied
in the material frame (external_torques), its stepper PositionVerlet (the
default of its examples).

Reference (for both tools): rodfem's run refined far beyond both sweeps (see
``rodfem study``, n_elements = 4x the finest, dt = 1/4 of the smallest).
Error: |tip(t_end) - tip_ref(t_end)| / max_t |tip_ref(t) - tip_ref(0)|.
Energy drift (PyElastica; only once the loads are off): max |H(t) - H(t_0)| /
E_scale, H with the gravity potential, E_scale = max |H| of rodfem's run of
the scene (kinetic + strain energy).  A PyElastica run is "stable" if it
reaches t_end with finite positions within 10 L of the start AND an energy
drift below 1 (else "energy blow-up") (rodfem's exact
discrete balance is in its own summary: ~1e-12).
Wall time: the time loop only (PyElastica after numba compilation, rodfem
after form compilation), the best of `repeats` runs.

Largest stable dt (PyElastica): the largest of dt = f * dt_explicit (f from
4 down to 0.05) whose run reaches t_end with finite positions that stay
within 10 L of the start (checked every 1 % of the run).  rodfem: the largest
dt (multiples of the scene's dt) for which Newton converges in every step,
with the error it then has.

Writes benchmarks/compare/<scene>/{rodfem/study.*, elastica.csv}, benchmarks/compare_<scene>.png,
benchmarks/compare.csv (all runs of both tools) and benchmarks/compare.md (the table).
"""
import argparse
import json
import math
import os
import time

import numpy as np
from report import table, write_csv

HERE = os.path.dirname(os.path.abspath(__file__))
TARGETS = (1e-2, 1e-3, 1e-4)

SCENES = {
    "cantilever-2d": dict(
        overrides={"g": 9.81, "fy": 0.0, "fx": 0.0, "t_end": 0.06, "dt": 1e-3, "n_elements": 10},
        props=dict(L=1.0, EA=2.1e7, GA=6.73e6, EI=175.0, rhoA=0.785, rhoI=6.54e-6),
        start=(0.0, 0.0), direction=(1.0, 0.0), clamped=True, gravity=9.81, end_load=None,
        rodfem_dts=[1e-3, 5e-4, 2.5e-4, 1.25e-4], rodfem_elements=[10, 20, 40, 80],
        elastica_n=[10, 20, 40, 80], quick_n=[10, 20]),
    "flying-spaghetti-2d": dict(
        overrides={},
        props=dict(L=10.0, EA=1e4, GA=1e4, EI=100.0, rhoA=1.0, rhoI=10.0),
        start=(0.0, 8.0), direction=(0.6, -0.8), clamped=False, gravity=0.0,
        end_load=dict(F=(8.0, 0.0), M=-80.0, until=2.5),
        rodfem_dts=[0.1, 0.05, 0.025, 0.0125], rodfem_elements=[10, 20, 40, 80],
        elastica_n=[10, 20, 40, 80, 160], quick_n=[10, 20, 40]),
}


# -- PyElastica ---------------------------------------------------------------------

def elastica_available():
    try:
        import elastica  # noqa: F401
        return True
    except ImportError:
        return False


def explicit_dt(props, n):
    """Estimated leapfrog limit (as in stability.py): min(h/c_i, 2/sqrt(GA/rhoI))."""
    h = props["L"] / n
    c = [math.sqrt(props["EA"] / props["rhoA"]), math.sqrt(props["GA"] / props["rhoA"]),
         math.sqrt(props["EI"] / props["rhoI"])]
    return min(min(h / ci for ci in c), 2 / math.sqrt(props["GA"] / props["rhoI"]))


def elastica_run(cfg, n, dt, t_end, samples=100, energy_scale=None):
    """One PyElastica run; returns dict(status, tip, wall, steps, energy drift after loads)."""
    import elastica as ea
    pr = cfg["props"]
    L = pr["L"]
    r = 2 * math.sqrt(pr["EI"] / pr["EA"])
    A = math.pi * r * r
    alpha_c = 27.0 / 28.0
    direction = np.array([*cfg["direction"], 0.0])
    rod = ea.CosseratRod.straight_rod(n, np.array([*cfg["start"], 0.0]), direction, np.array([0.0, 0.0, 1.0]),
                                      L, r, pr["rhoA"] / A, youngs_modulus=pr["EA"] / A,
                                      shear_modulus=pr["GA"] / (alpha_c * A))
    dl = L / n
    J = np.diag([pr["rhoI"], pr["rhoI"], 2 * pr["rhoI"]]) * dl
    Jinv = np.linalg.inv(J)
    for i in range(n):
        rod.mass_second_moment_of_inertia[..., i] = J
        rod.inv_mass_second_moment_of_inertia[..., i] = Jinv

    class Sim(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.CallBacks):
        pass

    sim = Sim()
    sim.append(rod)
    if cfg["clamped"]:
        sim.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,))
    if cfg["gravity"]:
        sim.add_forcing_to(rod).using(ea.GravityForces, acc_gravity=np.array([0.0, -cfg["gravity"], 0.0]))
    if cfg["end_load"]:
        load = cfg["end_load"]

        class EndLoad(ea.NoForces):
            """Force F and moment M e_z at the last node/element while t <= until (the step load of rodfem)."""

            def __init__(self, F, M, until):
                super().__init__()
                self.F, self.M, self.until = np.array([*F, 0.0]), np.array([0.0, 0.0, M]), until

            def apply_forces(self, system, time=0.0):
                if time <= self.until:
                    system.external_forces[:, -1] += self.F

            def apply_torques(self, system, time=0.0):
                if time <= self.until:   # external torques live in the material frame
                    system.external_torques[:, -1] += system.director_collection[..., -1] @ self.M

        sim.add_forcing_to(rod).using(EndLoad, F=load["F"], M=load["M"], until=load["until"])
    sim.finalize()
    stepper = ea.PositionVerlet()
    steps = int(round(t_end / dt))
    every = max(1, steps // samples)
    t = np.float64(0.0)
    limit = 10 * L + np.max(np.abs(rod.position_collection))

    def energy():
        """(H, kinetic + strain energy); H includes the lumped gravity potential."""
        E = sum(float(f()) for f in (rod.compute_translational_energy, rod.compute_rotational_energy,
                                     rod.compute_bending_energy, rod.compute_shear_energy))
        V = float(np.sum(rod.mass * cfg["gravity"] * rod.position_collection[1])) if cfg["gravity"] else 0.0
        return E + V, E

    H_after, t0, status = [], time.perf_counter(), "stable"
    for k in range(steps):
        t = stepper.step(sim, t, dt)
        if (k + 1) % every == 0 or k + 1 == steps:
            pos = rod.position_collection
            if not np.all(np.isfinite(pos)) or np.max(np.abs(pos)) > limit:
                status = f"unstable (blown up by t = {float(t):.4g})"
                break
            if not cfg["end_load"] or float(t) > cfg["end_load"]["until"] + dt:
                H_after.append(energy())
    wall = time.perf_counter() - t0
    tip = rod.position_collection[:2, -1].copy()
    drift = None
    if len(H_after) > 1 and status == "stable":  # (blown-up runs end early: no drift)
        Ha, Ea = np.array(H_after).T
        drift = float(np.max(np.abs(Ha - Ha[0])) / (energy_scale or max(np.max(np.abs(Ea)), 1e-300)))
        if energy_scale and drift > 1:
            status = "energy blow-up (|H - H0| > the scene's energy scale)"
    return dict(status=status, tip=tip, wall=wall, steps=k + 1, drift=drift)


def warm_up(cfg):
    """Compile PyElastica's numba kernels (excluded from every timing)."""
    t0 = time.perf_counter()
    elastica_run(cfg, 10, explicit_dt(cfg["props"], 10) * 0.1, explicit_dt(cfg["props"], 10) * 2)
    return time.perf_counter() - t0


# -- the comparison ----------------------------------------------------------------

def err_of(tip, study):
    ref = np.array([study["reference_values"][c] for c in ("tip_x", "tip_y")])
    return float(np.linalg.norm(np.asarray(tip) - ref)) / study["scale"]


def rodfem_largest_dt(name, cfg, study, quick):
    """Largest dt (multiples of the scene dt) with Newton converging in every step, and its error."""
    from rodfem.app.driver import run_scene
    from rodfem.app.scene import load
    from rodfem.errors import NewtonFailure
    scene = load(name)
    p = scene.values(cfg["overrides"])
    out = []
    for f in ([1, 10, 100] if quick else [1, 2, 5, 10, 20, 50, 100, 200]):
        dt = p["dt"] * f
        n = int(round(p["t_end"] / dt))
        if n < 1 or abs(n * dt - p["t_end"]) > 1e-9 * p["t_end"]:
            continue
        try:
            res, summ = run_scene(scene, dict(cfg["overrides"], dt=dt, frames=1))
            out.append(dict(dt=dt, status="converged", newton=summ["newton_its_mean"],
                            error=err_of([summ["final"]["tip_x"], summ["final"]["tip_y"]], study)))
        except NewtonFailure as e:
            out.append(dict(dt=dt, status=f"newton-failure: step {e.step}, t = {e.t:.4g}, residual {e.residual:.2e}"))
    return out


def compare(name, quick, repeats):
    from rodfem.app.study import plot_study, run_study
    cfg = SCENES[name]
    base = os.path.join(HERE, "compare", name)
    print(f"== {name}: rodfem study", flush=True)
    study = run_study(name, dict(cfg["overrides"], frames=1), out=os.path.join(base, "rodfem"),
                      dts=cfg["rodfem_dts"][:3] if quick else cfg["rodfem_dts"],
                      elements=cfg["rodfem_elements"][:3] if quick else cfg["rodfem_elements"],
                      repeats=repeats, quiet=True)
    t_end = study["parameters"]["t_end"]
    from rodfem.app.driver import run_scene
    energy_scale = run_scene(name, dict(cfg["overrides"], frames=1))[1]["max_abs_H"]
    rodfem_rows = [dict(tool="rodfem", scene=name, path=r["path"], n_elements=r["n_elements"], dt=r["dt"],
                        status=r["status"], error=r["error"], wall_time_s=r.get("wall_time_s"))
                   for r in study["rows"] if r["path"] != "reference"]
    big = rodfem_largest_dt(name, cfg, study, quick)
    print(f"   rodfem largest dt: {[(b['dt'], b['status']) for b in big]}", flush=True)

    rows = []
    if elastica_available():
        print(f"   PyElastica numba warm-up {warm_up(cfg):.1f} s", flush=True)
        ns = cfg["quick_n"] if quick else cfg["elastica_n"]
        factors = [4, 2, 1.5, 1, 0.75, 0.5, 0.35, 0.25, 0.1, 0.05]
        stable_dt = {}
        for n in ns:
            dte = explicit_dt(cfg["props"], n)
            for f in factors:
                dt = t_end / math.ceil(t_end / (f * dte))
                run = elastica_run(cfg, n, dt, t_end, energy_scale=energy_scale)
                if run["status"] == "stable":
                    best = run
                    for _ in range(repeats - 1):
                        again = elastica_run(cfg, n, dt, t_end, energy_scale=energy_scale)
                        best = again if again["wall"] < best["wall"] else best
                    stable_dt[n] = dt
                    rows.append(dict(tool="PyElastica", scene=name, path="largest stable dt", n_elements=n, dt=dt,
                                     dt_over_explicit=dt / dte, status="stable", error=err_of(best["tip"], study),
                                     wall_time_s=best["wall"], energy_drift=best["drift"]))
                    print(f"   PyElastica n={n:<4d} largest stable dt = {dt:.3g} ({dt / dte:.2f} x estimate), "
                          f"error {rows[-1]['error']:.2e}, wall {best['wall']:.2f} s, drift {best['drift']}", flush=True)
                    break
                rows.append(dict(tool="PyElastica", scene=name, path="search", n_elements=n, dt=dt,
                                 dt_over_explicit=dt / dte, status=run["status"],
                                 error=err_of(run["tip"], study) if np.all(np.isfinite(run["tip"])) else None,
                                 wall_time_s=run["wall"], energy_drift=run["drift"]))
            if n in stable_dt:   # the time-step error at this n: dt/4
                dt = stable_dt[n] / 4
                run = elastica_run(cfg, n, dt, t_end, energy_scale=energy_scale)
                rows.append(dict(tool="PyElastica", scene=name, path="dt / 4", n_elements=n, dt=dt,
                                 dt_over_explicit=dt / explicit_dt(cfg["props"], n), status=run["status"],
                                 error=err_of(run["tip"], study) if run["status"] == "stable" else None,
                                 wall_time_s=run["wall"], energy_drift=run["drift"]))
    else:
        print("   PyElastica not installed: scripts/install-deps --bench", flush=True)

    os.makedirs(base, exist_ok=True)
    extra = []
    for path, style in (("largest stable dt", dict(marker="D", ls="--", color="k")),
                        ("dt / 4", dict(marker="v", ls=":", color="gray"))):
        pts = [r for r in rows if r["path"] == path and r["error"]]
        if pts:
            extra.append((f"PyElastica, {path} (n = {', '.join(str(r['n_elements']) for r in pts)})",
                          [r["wall_time_s"] for r in pts], [r["error"] for r in pts], style))
    plot_study(os.path.join(HERE, f"compare_{name}.png"), study, study["rows"], extra=extra,
               title=f"{name}: rodfem ({study['integrator']}) and PyElastica (PositionVerlet); "
                     "reference: refined rodfem run")
    return study, rodfem_rows, rows, big


def time_to(rows, target):
    ok = [r["wall_time_s"] for r in rows if r.get("error") is not None and r["error"] <= target and r.get("wall_time_s")
          and r["status"] in ("stable", "completed")]
    return min(ok) if ok else None


def write(results, quick):
    all_rows = []
    for name, (study, rf, pe, big) in results.items():
        all_rows += rf + pe
    cols = ["tool", "scene", "path", "n_elements", "dt", "dt_over_explicit", "status", "error", "wall_time_s",
            "energy_drift"]
    suffix = "-quick" if quick else ""
    write_csv(os.path.join(HERE, f"compare{suffix}.csv"), all_rows, cols)
    lines = ["# rodfem and PyElastica side by side", "",
             f"Generated by `benchmarks/elastica_compare.py` ({time.strftime('%Y-%m-%d %H:%M')}). Wall time: the "
             "time loop only, best of the repeats, on a shared 2-core machine (noisy). Error: relative tip error "
             "at t_end against a refined rodfem run (see the script's docstring). '–' = not reached by the sweep.", ""]

    def fmt(x, spec=".3g", unit=" s"):
        return "–" if x is None else format(x, spec) + unit

    def times(rows):        # wall time to each error of TARGETS
        return {f"{t:g}": fmt(time_to(rows, t)) for t in TARGETS}
    summary = []
    for name, (study, rf, pe, big) in results.items():
        ok = [b for b in big if b["status"] == "converged"]
        fail = [b for b in big if b["status"] != "converged"]
        best = max(ok, key=lambda b: b["dt"]) if ok else None
        note = (f"Newton converges up to dt = {best['dt']:g} (error there {best['error']:.1e}, "
                f"{best['newton']:.1f} its/step)" if best else "")
        if fail:
            note += f"; fails at dt = {min(b['dt'] for b in fail):g}"
        elif big:
            note += " (largest dt tried)"
        summary.append({"scene": name, "tool": "rodfem", **times(rf),
                        "dt": f"{fmt(best['dt'] if best else None, 'g', '')} (Newton)", "note": note})
        stab = [r for r in pe if r["path"] == "largest stable dt"]
        if pe and not stab:
            summary.append({"scene": name, "tool": "PyElastica", **times([]), "dt": "none",
                            "note": "no dt tried was stable (see every run below)"})
        if stab:
            base = stab[0]
            drifts = [r["energy_drift"] for r in stab if r.get("energy_drift") is not None]
            note = (f"at n = {base['n_elements']}: {base['dt_over_explicit']:.2f} x the estimated explicit limit"
                    + (f"; energy drift after the load {min(drifts):.1e} .. {max(drifts):.1e}" if drifts else ""))
            summary.append({"scene": name, "tool": "PyElastica", **times(pe),
                            "dt": f"{base['dt']:.3g} (n = {base['n_elements']})", "note": note})
    lines += [*table(summary, [("scene", "{}"), ("tool", "{}"),
                               *((f"{t:g}", "{}", h) for t, h in zip(TARGETS, ("wall time to error 1e-2", "1e-3", "1e-4"))),
                               ("dt", "{}", "largest stable dt"), ("note", "{}")]),
              "", "## Every run", "",
              *table(all_rows, [("scene", "{}"), ("tool", "{}"), ("path", "{}"), ("n_elements", "{}", "n"), ("dt", "{:.4g}"),
                                ("status", "{}"), ("error", lambda r: fmt(r.get("error"), ".2e", "")),
                                ("wall_time_s", lambda r: fmt(r.get("wall_time_s"), ".3f", ""), "wall (s)")])]
    with open(os.path.join(HERE, f"compare{suffix}.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(HERE, f"compare{suffix}.json"), "w") as f:
        json.dump({n: {"rodfem_largest_dt": big, "orders": study["orders"], "reference": study["reference"],
                       "error_measure": study["error_measure"]} for n, (study, rf, pe, big) in results.items()},
                  f, indent=2, default=float)


def main(argv=None):
    ap = argparse.ArgumentParser(description="rodfem and PyElastica side by side")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--only", nargs="+", choices=list(SCENES))
    ap.add_argument("--repeats", type=int, default=2, help="timed repeats per run (the best counts)")
    args = ap.parse_args(argv)
    results = {}
    for name in args.only or list(SCENES):
        results[name] = compare(name, args.quick, 1 if args.quick else args.repeats)
    write(results, args.quick)
    print(f"wrote {HERE}/compare{'-quick' if args.quick else ''}.csv/.md and compare_<scene>.png", flush=True)


if __name__ == "__main__":
    main()
