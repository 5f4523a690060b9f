"""Many rods side by side with PyElastica: the same rods, the same duration, each tool at the largest step it survives.

    python3 -m venv /work/venv-elastica && /work/venv-elastica/bin/pip install pyelastica   # once, NOT rodfem's venv
    .venv/bin/python benchmarks/elastica_many.py [--elastica-python /work/venv-elastica/bin/python] [--quick]
                                                   # -> benchmarks/elastica_many.{csv,md}

PyElastica runs in a separate virtual environment (its own numpy and numba; it is no dependency of
rodfem and the suite never imports it): this script starts it there as a child process
(`--child elastica`, which imports numpy and elastica only) and reads back JSON.

The scene: M = 8 soft rods (solid circular section, radius r = 1 cm, E = 1e8 Pa, G = E/3, rho =
1000 kg/m^3) clamped at the origin, lying horizontal in a fan (directions at angles 0, 45, ..., 315
deg in the x-y plane), lengths 0.6, 0.65, ..., 0.95 m, released at rest under gravity (9.81 m/s^2,
-z) at t = 0, t_end = 0.4 s: each rod sags and swings down past the static deflection.  Both
tools get the same line properties: rhoA = rho A, EA = E A, shear stiffness GA = alpha_c G A with
PyElastica's alpha_c = 27/28, torsion G 2I, bending E I, rotary inertia rho (2I, I, I); PyElastica's
clamp is OneEndFixedBC (node 0, element 0's directors), its gravity GravityForces, its stepper
PositionVerlet, no damping; rodfem's rods are forms/cosserat_rod.py with the 'clamped' support and
gravity as an input, the discrete-gradient rule.

Reference: rodfem with 4 x the most elements of the runs (n = 160) at h = 0.5 ms.  Error: max over the rods of
|tip(t_end) - tip_ref(t_end)| / max over the rods of |tip_ref(t_end) - tip(0)|.

Largest step: PyElastica's largest dt = f * dt_explicit (f = 4, 2, 1.5, 1, 0.75, 0.5, 0.35, 0.25,
0.1, 0.05; dt_explicit = min(h / c, r / c_shear), c = sqrt(E/rho), c_shear = sqrt(G/rho)) whose
run ends with finite positions within 10 L of the start (checked every 1 % of the run) and a
final tip within 0.5 L of the reference; rodfem's largest dt of 2.5 ms x 2^k (k = 0..5) with Newton
converging in every step.  Time: CPU seconds of the time loop only (after numba's compilation; rodfem
after building and form compilation), the better of two runs (CPU, not wall time: the machine is
shared by several developers and its wall times swing by several times).
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = dict(M=8, r=0.01, E=1e8, G=1e8 / 3, rho=1000.0, g=9.81, t_end=0.4, n=10,
             lengths=[0.6 + 0.05 * k for k in range(8)], angles=[45.0 * k for k in range(8)])
ALPHA_C = 27.0 / 28.0   # PyElastica's shear correction (elastica/rod/factory_function.py)
FACTORS = (4, 2, 1.5, 1, 0.75, 0.5, 0.35, 0.25, 0.1, 0.05)


def line_properties(s=SCENE):
    A, I = math.pi * s["r"] ** 2, math.pi * s["r"] ** 4 / 4
    return dict(A=A, I=I, rhoA=s["rho"] * A, EA=s["E"] * A, GA=ALPHA_C * s["G"] * A, GJ=s["G"] * 2 * I,
                EI=s["E"] * I, rhoJ=(s["rho"] * 2 * I, s["rho"] * I, s["rho"] * I))


def direction(angle):
    a = math.radians(angle)
    return np.array([math.cos(a), math.sin(a), 0.0])


def explicit_dt(n, s=SCENE):
    h = min(s["lengths"]) / n
    return min(h / math.sqrt(s["E"] / s["rho"]), s["r"] / math.sqrt(s["G"] / s["rho"]))


# -- PyElastica (the child process in its own venv) ----------------------------------------

def elastica_run(n, dt, s=SCENE, samples=100):
    """One run of the M rods; dict(status, tips, wall)."""
    import elastica as ea

    class Sim(ea.BaseSystemCollection, ea.Constraints, ea.Forcing):
        pass
    sim, rods = Sim(), []
    for L, angle in zip(s["lengths"], s["angles"]):
        rod = ea.CosseratRod.straight_rod(n, np.zeros(3), direction(angle), np.array([0.0, 0.0, 1.0]), L, s["r"],
                                          s["rho"], youngs_modulus=s["E"], shear_modulus=s["G"])
        sim.append(rod)
        sim.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,))
        sim.add_forcing_to(rod).using(ea.GravityForces, acc_gravity=np.array([0.0, 0.0, -s["g"]]))
        rods.append(rod)
    sim.finalize()
    stepper = ea.PositionVerlet()
    steps = int(round(s["t_end"] / dt))
    every = max(1, steps // samples)
    limit = 10 * max(s["lengths"])
    t, status, t0 = np.float64(0.0), "stable", time.process_time()
    for k in range(steps):
        t = stepper.step(sim, t, dt)
        if (k + 1) % every == 0 or k + 1 == steps:
            pos = [rod.position_collection for rod in rods]
            if not all(np.all(np.isfinite(p)) and np.max(np.abs(p)) <= limit for p in pos):
                status = f"blown up by t = {float(t):.3g}"
                break
    wall = time.process_time() - t0
    tips = [rod.position_collection[:, -1].tolist() for rod in rods]
    return dict(status=status, tips=tips, wall=wall)


def elastica_child(ns, reference_tips, repeats):
    """The largest surviving dt at each n of `ns` (and its error), in this (PyElastica's) process: JSON rows."""
    elastica_run(4, explicit_dt(4) * 0.5, dict(SCENE, t_end=20 * explicit_dt(4)))   # numba's compilation
    ref = np.asarray(reference_tips)
    rows = []
    for n in ns:
        for f in FACTORS:
            dt = SCENE["t_end"] / math.ceil(SCENE["t_end"] / (f * explicit_dt(n)))
            run = elastica_run(n, dt)
            if run["status"] == "stable" and np.max(np.linalg.norm(np.asarray(run["tips"]) - ref, axis=1)) > \
                    0.5 * min(SCENE["lengths"]):
                run["status"] = "wrong (a tip more than L/2 from the reference)"
            rows.append(dict(n=n, dt=dt, factor=f, **run))
            if run["status"] == "stable":
                for _ in range(repeats - 1):
                    again = elastica_run(n, dt)
                    rows[-1]["wall"] = min(rows[-1]["wall"], again["wall"])
                break
    print("RESULT " + json.dumps(dict(version=_version("pyelastica"), numba=_version("numba"), numpy=np.__version__,
                                      rows=rows)))


def _version(dist):
    from importlib.metadata import version
    return version(dist)


# -- rodfem ----------------------------------------------------------------------------------

def rodfem_system(n, s=SCENE):
    from rodfem import Load, Support, System
    from rodfem.demos._rod3d import straight
    from rodfem.forms.cosserat_rod import CosseratRod
    lp = line_properties(s)
    model = CosseratRod(lp["rhoA"], lp["rhoJ"], [1 / lp["EA"], 1 / lp["GA"], 1 / lp["GA"]],
                        [1 / lp["GJ"], 1 / lp["EI"], 1 / lp["EI"]])
    system = System(integrator="discrete-gradient")
    for k, (L, angle) in enumerate(zip(s["lengths"], s["angles"])):
        d1 = direction(angle)
        d2 = np.cross(np.array([0.0, 0.0, 1.0]), d1)
        rod = system.add(f"rod{k}", model, L, n, initial=straight(np.zeros(3), [d1, d2, np.cross(d1, d2)]),
                         supports=[Support("left", "clamped")],
                         loads=[Load("v", [0.0, 0.0, -lp["rhoA"] * s["g"]], "domain", f"gravity rod{k}")])
        system.marker(f"tip{k}", rod.end)
    return system


def rodfem_run(n, dt, repeats=1):
    """dict(status, tips, wall, build, balance) of rodfem at (n, dt): the better wall time of `repeats` runs."""
    from rodfem import run
    from rodfem.errors import NewtonFailure
    best = None
    for _ in range(repeats):
        t0 = time.process_time()
        system = rodfem_system(n).build()
        build = time.process_time() - t0
        c0 = time.process_time()
        try:
            res = run(system, dt, SCENE["t_end"])
        except NewtonFailure as e:
            return dict(status=f"Newton failed at t = {e.t:.3g}", tips=None, wall=None, build=build, balance=None)
        cpu = time.process_time() - c0
        last = res.rows[-1]
        row = dict(status="converged", tips=[[last[f"tip{k}_{c}"] for c in "xyz"] for k in range(SCENE["M"])],
                   wall=cpu, build=build, balance=res.max_balance_error / np.max(np.abs(res.column("H"))),
                   newton=float(np.mean(res.column("newton_its")[1:])))
        best = row if best is None or row["wall"] < best["wall"] else best
    return best


def error(tips, ref):
    tips, ref = np.asarray(tips), np.asarray(ref)
    start = np.array([L * direction(a) for L, a in zip(SCENE["lengths"], SCENE["angles"])])
    return float(np.max(np.linalg.norm(tips - ref, axis=1)) / np.max(np.linalg.norm(ref - start, axis=1)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--elastica-python", default="/work/venv-elastica/bin/python",
                    help="the Python of the venv that has PyElastica")
    ap.add_argument("--child", choices=("elastica",), help=argparse.SUPPRESS)
    ap.add_argument("--n", type=int, nargs="+", default=[10, 20], help="elements per rod (rodfem and PyElastica)")
    ap.add_argument("--elastica-n", type=int, nargs="+", default=[10, 20, 40], help="elements per rod of PyElastica")
    ap.add_argument("--reference", help=argparse.SUPPRESS)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="reference at 2 x the elements and h = 1 ms")
    args = ap.parse_args()
    if args.child:
        return elastica_child(args.elastica_n, json.loads(args.reference), args.repeats)

    from report import write_report
    ref_n, ref_dt = (2 * max(args.n), 1e-3) if args.quick else (4 * max(args.elastica_n + args.n), 5e-4)
    print(f"reference: rodfem n = {ref_n}, h = {ref_dt}", flush=True)
    ref = rodfem_run(ref_n, ref_dt)
    assert ref["status"] == "converged", ref["status"]
    rows = []
    for n in args.n:
        for k in range(6):   # rodfem: the largest step that converges (0.08 s: 5 steps)
            dt = 2.5e-3 * 2 ** k
            r = rodfem_run(n, dt, args.repeats)
            rows.append(dict(tool="rodfem (discrete gradient)", n=n, dt=dt, status=r["status"], wall=r["wall"],
                             build=r["build"], steps=int(round(SCENE["t_end"] / dt)), newton=r.get("newton"),
                             error=error(r["tips"], ref["tips"]) if r["tips"] else None, balance=r["balance"]))
            print(rows[-1], flush=True)
            if r["status"] != "converged":
                break
    p = subprocess.run([args.elastica_python, os.path.abspath(__file__), "--child", "elastica", "--elastica-n",
                        *map(str, args.elastica_n), "--reference", json.dumps(ref["tips"]), "--repeats", str(args.repeats)],
                       capture_output=True, text=True, cwd="/", env=dict(os.environ, PYTHONPATH=""))
    if p.returncode:
        sys.exit(f"PyElastica's run failed:\n{p.stderr[-3000:]}")
    out = json.loads(next(x for x in p.stdout.splitlines() if x.startswith("RESULT "))[7:])
    for r in out["rows"]:
        rows.append(dict(tool="PyElastica (PositionVerlet)", n=r["n"], dt=r["dt"], status=r["status"], wall=r["wall"],
                         build=None, steps=int(round(SCENE["t_end"] / r["dt"])), newton=None,
                         error=error(r["tips"], ref["tips"]) if r["status"] == "stable" else None, balance=None))
        print(rows[-1], flush=True)

    def fmt(v, spec):
        return "" if v is None else format(v, spec)
    columns = [("tool", "{}"), ("n", "{}"), ("dt", lambda r: fmt(r["dt"], ".3g"), "h (s)"), ("steps", "{}"),
               ("status", "{}"), ("wall", lambda r: fmt(r["wall"], ".3f"), "time loop (CPU s)"),
               ("error", lambda r: fmt(r["error"], ".2e"), "tip error"),
               ("newton", lambda r: fmt(r["newton"], ".2f"), "Newton its/step"),
               ("balance", lambda r: fmt(r["balance"], ".1e"), "max balance error / max H")]
    load = os.getloadavg()[0]
    write_report("elastica_many", rows, columns, "Many rods: rodfem and PyElastica side by side",
                 intro=[f"{SCENE['M']} clamped rods in a fan, falling under gravity for {SCENE['t_end']} s "
                        f"(benchmarks/elastica_many.py), n elements each.  Reference: rodfem, n = {ref_n}, "
                        f"h = {ref_dt}; tip error = max over the rods |tip - tip_ref| / max |tip_ref - tip(0)| at "
                        f"t_end.  Each tool down to the largest step it survives (rodfem: 2.5 ms x 2^k while Newton "
                        f"converges; PyElastica: f x the explicit estimate {explicit_dt(n):.3g} s until stable)."],
                 notes=[f"PyElastica {out['version']} (numba {out['numba']}, numpy {out['numpy']}) in its own venv "
                        f"({args.elastica_python}); rodfem of this checkout, serial, one thread.  CPU times of the time "
                        "loop, the better of two runs.",
                        f"Load average while this ran: {load:.1f} on 2 cores (the machine is shared)."])


if __name__ == "__main__":
    sys.exit(main())
