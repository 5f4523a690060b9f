"""The rod-collision scene side by side with PyElastica: the same two rods, the same contact stiffness,
a sweep of the time step for each tool.

    python3 -m venv /work/venv-elastica && /work/venv-elastica/bin/pip install pyelastica   # once, NOT rodfem's venv
    .venv/bin/python benchmarks/elastica_collision.py [--elastica-python /work/venv-elastica/bin/python] [--quick]
                                                        # -> benchmarks/elastica_collision.{csv,md}

PyElastica runs in a separate virtual environment (its own numpy and numba; it is no dependency of
rodfem and the suite never imports it): this script starts it there as a child process
(`--child elastica`, which imports numpy and elastica only) and reads back JSON.  Without it the
rodfem half runs alone and the report says how to install PyElastica.

The scene (demos/rod_collision.py, its defaults): two straight rods, L = 0.5 m, r = 0.01 m, rho =
1750 kg/m^3, E = 3e5 Pa, G = E/3, crossing at right angles at their centres (rod a along x above,
rod b along y below, 1 mm between the surfaces), moving towards each other at V = 0.1 m/s; no
gravity, no support, t_end = 1 s.  The rods are floppy (lowest free bending period about 1 s,
against a contact lasting milliseconds): the centres bounce, the rods bend, touch again about
0.5 s later and fly apart for good at about 0.6 s, each carrying part of the impact as vibration.
What is compared is what is left after that: each rod's centre-of-mass velocity (the momentum
exchanged; a rigid elastic impact of the centred crossing would exchange the velocities, -V/2 <->
+V/2), the total momentum, and the energy before and after.

Same line properties: rhoA = rho A, EA, bending E I, torsion G 2I, rotary inertia rho (2I, I, I);
shear: rodfem G A, PyElastica its alpha_c G A (alpha_c = 27/28, built into CosseratRod.straight_rod;
3.6 % softer in shear, negligible for L/r = 50).  Discretization: rodfem n = 8 P2 elements per rod
(17 nodes, 16 contact segments: the scene's default), PyElastica n = 16 elements (17 nodes, 16
segments); both cross at a node, where four segment pairs see the contact.

The contact laws differ:
* rodfem (forms/rod_contact.py): the cubic penalty psi(g) = k_c/3 <-g>^3 of each segment pair's gap g
  (force k_c g^2), integrated with a discrete gradient: energy and momenta exact per step.
  k_c is the scene's: a rigid-body impact would penetrate 1 mm if one pair took it, 4^(-1/3) mm
  = 0.63 mm with the four pairs of a crossing at a node.
* PyElastica (RodRodContact, elastica/_contact_functions.py): a linear spring-dashpot on the overlap
  of each element pair, force k gamma + nu gamma' (half to each node of the element), PLUS the
  compressive part of the elements' internal and external forces along the normal (its
  "equilibrium" term, which makes the contact push back whatever presses the rods together; not a
  potential force).  nu = 0 here (elastic; PyElastica stays stable without damping, see the table).
  k is chosen so that the same rigid impact penetrates the same depth d = 0.63 mm with four pairs:
  1/2 m_eff V^2 = 1/2 (4 k) d^2 (the same stored energy at the same maximal penetration).
PyElastica's stepper: PositionVerlet (explicit, symplectic).

Each tool: the time loop over a sweep of dt.  A run survives when it ends with the rods separated (no
contact in the last 0.2 s of the run, the centres moving apart) and: PyElastica, finite positions
within 10 L of the start (checked every 1 % of the run); rodfem, Newton converged in every step and
H finite.  Reference: each tool at its smallest dt (rodfem 0.125 ms, PyElastica 5 us); errors: the
centres' z-velocities after separation, |v_a - v_a,ref| / (V/2), against that reference and against
the other tool's.  Time: CPU seconds (time.process_time) of the time loop (after numba's compilation;
rodfem after building and form compilation), the median of three runs (rodfem below 1 ms: one run).
Equal accuracy: for each tool the largest dt at and below which every run of the sweep is within the
tolerance of its own reference (the error is not monotone in dt); there, one fresh process per tool:
whole-process CPU (getrusage of it and its children: imports, numba's compilation or rodfem's forms
from the cache of earlier runs, the run) and wall seconds seen from outside.
"""
import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = dict(L=0.5, r=0.01, rho=1750.0, E=3e5, poisson=0.5, V=0.1, gap=1e-3, penetration=1e-3, t_end=1.0,
             n_rodfem=8, n_elastica=16)
RODFEM_DT = (0.125e-3, 0.25e-3, 0.5e-3, 1e-3, 2e-3, 4e-3, 10e-3, 20e-3, 50e-3, 100e-3)   # dividing t_end = 1 s
ELASTICA_DT = (5e-6, 1e-5, 2e-5, 5e-5, 1e-4, 2e-4, 5e-4, 1e-3, 1.25e-3, 1.6e-3, 2e-3)   # dividing t_end = 1 s
QUIET = 0.2      # no contact in the last QUIET seconds: separated
RODFEM, ELASTICA = "rodfem (discrete gradient)", "PyElastica (PositionVerlet)"
INSTALL = "python3 -m venv /work/venv-elastica && /work/venv-elastica/bin/pip install pyelastica==1.0.0"


def mass(s=SCENE):
    return s["rho"] * math.pi * s["r"] ** 2 * s["L"]


def m_eff(s=SCENE):
    return 0.5 * mass(s)    # centred crossing: 1/m_eff = 2/m (demos/rod_collision.py's rigid law)


def elastica_stiffness(s=SCENE):
    """k of RodRodContact: 1/2 m_eff V^2 = 1/2 (4 k) d^2 at rodfem's rigid-impact penetration with four
    pairs, d = 4^(-1/3) penetration."""
    d = 4 ** (-1 / 3) * s["penetration"]
    return m_eff(s) * s["V"] ** 2 / (4 * d ** 2)


def whole_process():
    """CPU seconds (user + system) of this process and its finished children (compilers) so far."""
    return sum(u.ru_utime + u.ru_stime for u in map(resource.getrusage, (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)))


# -- PyElastica (the child process in its own venv) ----------------------------------------

def elastica_run(dt, s=SCENE, samples=100):
    """One run of the collision; dict(status, v_a, v_b, p0, p1, E0, E1, last_contact, cpu)."""
    import elastica as ea
    from elastica.contact_forces import RodRodContact

    class Sim(ea.BaseSystemCollection, ea.Contact):
        pass

    class Flagged(RodRodContact):
        """RodRodContact that notes the last time it pushed (the stepper zeroes the forces after each step)."""
        last = None

        def apply_contact(self, system_one, system_two, time=np.float64(0.0)):
            super().apply_contact(system_one, system_two, time)
            if np.any(system_one.external_forces):
                Flagged.last = float(time)
    sim = Sim()
    n, L, r, V = s["n_elastica"], s["L"], s["r"], s["V"]
    z = r + 0.5 * s["gap"]
    G = s["E"] / (2 * (1 + s["poisson"]))
    a = ea.CosseratRod.straight_rod(n, np.array([-0.5 * L, 0.0, z]), np.array([1.0, 0.0, 0.0]),
                                    np.array([0.0, 1.0, 0.0]), L, r, s["rho"], youngs_modulus=s["E"], shear_modulus=G)
    b = ea.CosseratRod.straight_rod(n, np.array([0.0, -0.5 * L, -z]), np.array([0.0, 1.0, 0.0]),
                                    np.array([0.0, 0.0, 1.0]), L, r, s["rho"], youngs_modulus=s["E"], shear_modulus=G)
    a.velocity_collection[2, :] = -0.5 * V
    b.velocity_collection[2, :] = 0.5 * V
    for rod in (a, b):
        sim.append(rod)
    sim.detect_contact_between(a, b).using(Flagged, k=elastica_stiffness(s), nu=0.0)
    sim.finalize()

    def momentum():
        return (a.mass @ a.velocity_collection.T + b.mass @ b.velocity_collection.T).tolist()

    def energy():
        return float(sum(rod.compute_translational_energy() + rod.compute_rotational_energy()
                         + rod.compute_bending_energy() + rod.compute_shear_energy() for rod in (a, b)))
    p0, E0 = momentum(), energy()
    stepper = ea.PositionVerlet()
    steps = int(round(s["t_end"] / dt))
    every = max(1, steps // samples)
    limit = 10 * L
    t, status = np.float64(0.0), "stable"
    c0 = time.process_time()
    for k in range(steps):
        t = stepper.step(sim, t, dt)
        if (k + 1) % every == 0 or k + 1 == steps:
            if not all(np.all(np.isfinite(rod.position_collection)) and np.max(np.abs(rod.position_collection)) <= limit
                       for rod in (a, b)):
                status = f"blown up by t = {float(t):.3g}"
                break
    cpu = time.process_time() - c0
    if status != "stable":
        return dict(status=status, cpu=cpu)
    last = Flagged.last
    v_a, v_b = a.compute_velocity_center_of_mass().tolist(), b.compute_velocity_center_of_mass().tolist()
    if last is not None and (last > s["t_end"] - QUIET or v_a[2] <= v_b[2]):
        status = f"not separated (last contact at t = {last:.3g})"
    return dict(status=status, v_a=v_a, v_b=v_b, p0=p0, p1=momentum(), E0=E0, E1=energy(), last_contact=last, cpu=cpu)


def spring_only():
    """Replace (in this process) RodRodContact's force by its spring alone: the source of PyElastica 1.0.0's
    _calculate_contact_forces_rod_rod with the 'equilibrium' term set to zero, compiled anew.  A check of
    where its energy goes, not a fix: its spring force k gamma still goes half to each node of the element
    whatever the closest point (not the gradient of 1/2 k gamma^2)."""
    import inspect

    import elastica._contact_functions as functions
    import elastica.contact_forces as forces
    from numba import njit
    src = inspect.getsource(functions._calculate_contact_forces_rod_rod.py_func)
    old = "normal_force = abs(min(normal_force, 0.0))"
    assert old in src, "PyElastica's rod-rod contact changed: the spring-only check is for 1.0.0"
    namespace = dict(functions.__dict__)
    exec(src.replace(old, "normal_force = 0.0").replace("@njit(cache=True)  # type: ignore\n", ""), namespace)
    forces._calculate_contact_forces_rod_rod = njit(namespace["_calculate_contact_forces_rod_rod"])


def elastica_child(dts, repeats, once=False):
    """The sweep of dt in this (PyElastica's) process: JSON rows (`once`: one run, whole-process figures)."""
    w0 = time.perf_counter()
    elastica_run(1e-4, dict(SCENE, t_end=2e-3))   # numba's compilation
    rows = []
    for dt in dts:
        runs = [elastica_run(dt)]
        if runs[0]["status"] == "stable":
            runs += [elastica_run(dt) for _ in range(repeats - 1)]
        row = dict(runs[0], dt=dt, cpu=float(np.median([x["cpu"] for x in runs])))
        rows.append(row)
        print(json.dumps(row), file=sys.stderr, flush=True)
    out = dict(version=_version("pyelastica"), numba=_version("numba"), numpy=np.__version__, rows=rows,
               k=elastica_stiffness())
    if once:
        out.update(process_cpu=whole_process(), process_wall=time.perf_counter() - w0)
    else:
        spring_only()
        out["spring_only"] = [dict(elastica_run(dt), dt=dt) for dt in (min(dts), 1e-3)]
    print("RESULT " + json.dumps(out))


def _version(dist):
    from importlib.metadata import version
    return version(dist)


# -- rodfem ----------------------------------------------------------------------------------

def rodfem_run(dt, repeats=1):
    """dict(status, v_a, v_b, p0, p1, E0, E1, last_contact, cpu, build, newton, balance) of rodfem's
    rod-collision scene at step dt: the median time loop of `repeats` runs."""
    from mpi4py import MPI

    from rodfem import run
    from rodfem.demos.rod_collision import scene
    from rodfem.errors import NewtonFailure
    s = SCENE
    p = scene.values({"n_elements": s["n_rodfem"], "dt": dt, "t_end": s["t_end"], "L": s["L"], "r": s["r"],
                      "rho": s["rho"], "E": s["E"], "poisson": s["poisson"], "V": s["V"], "gap": s["gap"],
                      "penetration": s["penetration"]})
    cpus, row = [], None
    for _ in range(repeats):
        t0 = time.process_time()
        system = scene.build(p, MPI.COMM_WORLD)
        build = time.process_time() - t0
        c0 = time.process_time()
        try:
            res = run(system, dt, s["t_end"])
        except NewtonFailure as e:
            return dict(status=f"Newton failed at t = {e.t:.3g}", cpu=time.process_time() - c0, build=build)
        except Exception as e:   # anything else a large step may bring: say so in the table
            return dict(status=f"failed: {type(e).__name__}: {str(e)[:80]}", cpu=time.process_time() - c0, build=build)
        cpus.append(time.process_time() - c0)
        rows = res.rows
        if row is None:
            m = mass()
            first, last = rows[0], rows[-1]
            contact = [x["t"] for x in rows if x["touch.N"] > 0]
            x_ok = all(np.isfinite(x["H"]) for x in rows)
            v_a, v_b = [0.0, 0.0, last["pz_a"] / m], [0.0, 0.0, last["pz_b"] / m]
            row = dict(status="converged" if x_ok else "NaN", v_a=v_a, v_b=v_b,
                       p0=[first[f"p_{c}"] for c in "xyz"], p1=[last[f"p_{c}"] for c in "xyz"],
                       E0=first["H"], E1=last["H"], last_contact=contact[-1] if contact else None, build=build,
                       newton=float(np.mean([x["newton_its"] for x in rows[1:]])),
                       balance=res.max_balance_error / max(abs(x["H"]) for x in rows))
            if row["last_contact"] is not None and (row["last_contact"] > s["t_end"] - QUIET or v_a[2] <= v_b[2]):
                row["status"] = f"not separated (last contact at t = {row['last_contact']:.3g})"
    row["cpu"] = float(np.median(cpus))
    return row


def rodfem_child(dt):
    """One fresh rodfem process at step dt: whole-process figures (imports, form compilation, the run)."""
    w0 = time.perf_counter()
    row = rodfem_run(dt)
    print("RESULT " + json.dumps(dict(row, process_cpu=whole_process(), process_wall=time.perf_counter() - w0)))


def fresh(cmd, env=None):
    """Run a child; its RESULT line as a dict and the wall seconds seen from outside."""
    w0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - w0
    if p.returncode:
        sys.exit(f"{' '.join(cmd)} failed:\n{p.stderr[-3000:]}")
    out = json.loads(next(x for x in p.stdout.splitlines() if x.startswith("RESULT "))[7:])
    out["outside_wall"] = wall
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--elastica-python", default="/work/venv-elastica/bin/python",
                    help="the Python of the venv that has PyElastica")
    ap.add_argument("--child", choices=("elastica", "rodfem"), help=argparse.SUPPRESS)
    ap.add_argument("--dt", type=float, nargs="+", help=argparse.SUPPRESS)
    ap.add_argument("--once", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--tolerance", type=float, nargs="+", default=[0.01, 0.05],
                    help="the accuracies at which the tools are compared: |v_a - v_a,ref| / (V/2)")
    ap.add_argument("--save", help=argparse.SUPPRESS)
    ap.add_argument("--load", help=argparse.SUPPRESS)
    ap.add_argument("--quick", action="store_true", help="fewer steps: rodfem from 1 ms, PyElastica from 20 us")
    args = ap.parse_args()
    if args.child == "elastica":
        return elastica_child(args.dt, args.repeats, args.once)
    if args.child == "rodfem":
        return rodfem_child(args.dt[0])

    from report import write_report
    rodfem_dts = [d for d in RODFEM_DT if d >= 1e-3] if args.quick else list(RODFEM_DT)
    elastica_dts = [d for d in ELASTICA_DT if d >= 2e-5] if args.quick else list(ELASTICA_DT)
    env = dict(os.environ, PYTHONPATH="")
    if args.load:     # the sweeps of an earlier run (--save), to redo the report
        with open(args.load) as f:
            rows, out, load = (json.load(f) + [None])[:3]
    else:
        rows = []
        for dt in rodfem_dts:
            r = rodfem_run(dt, 1 if dt < 1e-3 else args.repeats)   # the long runs once: the machine is shared
            rows.append(dict(tool=RODFEM, n=SCENE["n_rodfem"], dt=dt, **r))
            print({k: v for k, v in rows[-1].items()}, flush=True)
        have = os.path.exists(args.elastica_python) and subprocess.run(
            [args.elastica_python, "-c", "import elastica"], capture_output=True, cwd="/",
            env=env).returncode == 0
        out = None
        if have:
            out = fresh([args.elastica_python, os.path.abspath(__file__), "--child", "elastica", "--repeats",
                         str(args.repeats), "--dt", *map(str, elastica_dts)], env)
            for r in out["rows"]:
                rows.append(dict(tool=ELASTICA, n=SCENE["n_elastica"], **r))
                print(rows[-1], flush=True)
        else:
            print(f"PyElastica is not importable with {args.elastica_python}: rodfem only.  To compare, install it "
                  f"from PyPI in a venv of its own:\n    {INSTALL}", flush=True)
        if args.save:
            with open(args.save, "w") as f:
                json.dump([rows, out, os.getloadavg()[0]], f)

    # errors against each tool's reference (its smallest dt) and the other tool's
    V2 = 0.5 * SCENE["V"]
    refs = {}
    for tool in [t for t in (RODFEM, ELASTICA) if any(r["tool"] == t for r in rows)]:   # in this order
        mine = [r for r in rows if r["tool"] == tool]
        assert mine[0]["status"] in ("converged", "stable"), mine[0]
        refs[tool] = mine[0]
    for r in rows:
        ok = r["status"] in ("converged", "stable")
        r["error"] = abs(r["v_a"][2] - refs[r["tool"]]["v_a"][2]) / V2 if ok else None
        other = [t for t in refs if t != r["tool"]]
        r["error_other"] = abs(r["v_a"][2] - refs[other[0]]["v_a"][2]) / V2 if ok and other else None
        r["dp"] = float(np.max(np.abs(np.subtract(r["p1"], r["p0"])))) / (mass() * V2) if ok else None
        r["dE"] = (r["E1"] - r["E0"]) / r["E0"] if ok else None
        r["steps"] = int(round(SCENE["t_end"] / r["dt"]))

    # equal accuracy: each tool's largest dt at and below which every step of the sweep is within the
    # tolerance of its own reference (the error is not monotone in dt: a coarse run can land close by chance)
    chosen = {}
    for tol in args.tolerance:
        for tool in refs:
            sweep = sorted((r for r in rows if r["tool"] == tool and r is not refs[tool]), key=lambda r: r["dt"])
            for r in sweep:
                if r["error"] is None or r["error"] > tol:
                    break
                chosen[tol, tool] = r
    process = {}
    for tol in args.tolerance:
        if (tol, RODFEM) in chosen and (tol, ELASTICA) in chosen:
            process[tol, "rodfem"] = fresh([sys.executable, os.path.abspath(__file__), "--child", "rodfem", "--dt",
                                            str(chosen[tol, RODFEM]["dt"])])
            process[tol, "elastica"] = fresh([args.elastica_python, os.path.abspath(__file__), "--child", "elastica",
                                              "--once", "--repeats", "1", "--dt", str(chosen[tol, ELASTICA]["dt"])], env)

    def fmt(v, spec):
        return "" if v is None else format(v, spec)
    columns = [("tool", "{}"), ("n", "{}"), ("dt", lambda r: fmt(r["dt"], ".3g"), "h (s)"), ("steps", "{}"),
               ("status", "{}"), ("cpu", lambda r: fmt(r["cpu"], ".2f"), "time loop (CPU s, median)"),
               ("v_a", lambda r: fmt(r["v_a"][2], ".5f") if r.get("v_a") else "", "v_a,z after (m/s)"),
               ("v_b", lambda r: fmt(r["v_b"][2], ".5f") if r.get("v_b") else "", "v_b,z after (m/s)"),
               ("error", lambda r: fmt(r["error"], ".1e"), "error vs own ref"),
               ("error_other", lambda r: fmt(r["error_other"], ".1e"), "vs other tool's ref"),
               ("dp", lambda r: fmt(r["dp"], ".1e"), "max abs(p(end) - p(0)) / (m V/2)"),
               ("dE", lambda r: fmt(r["dE"], ".1e"), "(E(end) - E(0)) / E(0)"),
               ("last_contact", lambda r: fmt(r.get("last_contact"), ".3f"), "last contact (s)"),
               ("newton", lambda r: fmt(r.get("newton"), ".2f"), "Newton its/step")]
    load = os.getloadavg()[0] if not args.load or load is None else load
    intro = [f"Two rods crossing at right angles collide (demos/rod_collision.py: L = {SCENE['L']}, r = {SCENE['r']}, "
             f"rho = {SCENE['rho']:g}, E = {SCENE['E']:.1e}, V = {SCENE['V']} m/s), t_end = {SCENE['t_end']} s "
             f"(benchmarks/elastica_collision.py).  Rigid-body answer: v_a,z = +{V2}, v_b,z = -{V2} "
             f"(the floppy rods keep part of the energy as vibration).  rodfem: cubic penalty k_c = "
             f"{1.5 * m_eff() * SCENE['V'] ** 2 / SCENE['penetration'] ** 3:.4g} N/m^2 per segment pair, "
             f"n = {SCENE['n_rodfem']} P2; PyElastica: RodRodContact k = {elastica_stiffness():.4g} N/m per "
             f"element pair, nu = 0, n = {SCENE['n_elastica']}.  Errors: |v_a,z - v_a,z(ref)| / (V/2)."]
    notes = []
    for tol in args.tolerance:
        notes += ["", f"Equal accuracy, error vs own reference <= {tol:g} at this h and every smaller h of the sweep:", ""]
        for tool in refs:
            r = chosen.get((tol, tool))
            notes.append(f"* {tool}: largest such h = {r['dt']:.3g} s, time loop {r['cpu']:.2f} CPU s, error "
                         f"{r['error']:.1e}." if r else f"* {tool}: no step of the sweep but the reference.")
        if (tol, "rodfem") in process:
            rf, pe = chosen[tol, RODFEM], chosen[tol, ELASTICA]
            notes.append(f"* step ratio h_rodfem / h_PyElastica = {rf['dt'] / pe['dt']:.3g}; time-loop CPU ratio "
                         f"rodfem / PyElastica = {rf['cpu'] / pe['cpu']:.3g}.")
            for key, tool in (("rodfem", "rodfem"), ("elastica", "PyElastica")):
                q = process[tol, key]
                notes.append(f"* one fresh {tool} process at that h: {q['process_cpu']:.1f} CPU s (imports, "
                             f"{'forms from the warm cache' if key == 'rodfem' else 'numba compilation'}, run), {q['outside_wall']:.1f} "
                             f"s wall.")
    notes.append("")
    for tool in refs:
        surv = [r for r in rows if r["tool"] == tool and r["status"] in ("converged", "stable")]
        fail = [r for r in rows if r["tool"] == tool and r not in surv]
        notes.append(f"Largest h {tool} survives: {max(r['dt'] for r in surv):.3g} s"
                     + (f" (fails from {min(r['dt'] for r in fail):.3g} s: {min(fail, key=lambda r: r['dt'])['status']})."
                        if fail else " (the largest tried)."))
    notes += ["", "Reading the table:", ""]
    good = [r for r in rows if r.get("error") is not None]
    notes.append(f"* Momentum: {'both tools keep' if out else 'rodfem keeps'} the total momentum to round-off (at most "
                 f"{max(r['dp'] for r in good):.0e} of m V/2).")
    rf_dE = max(abs(r["dE"]) for r in good if r["tool"] == RODFEM)
    notes.append(f"* Energy: rodfem's H after the collision equals H before to {rf_dE:.0e} at every step (the discrete "
                 "gradient of the contact, exact per step).")
    if out:
        fine = [r["dE"] for r in good if r["tool"] == ELASTICA and r["dt"] <= 1e-4]
        sp = out["spring_only"][0]
        notes.append(f"  PyElastica loses {-100 * max(fine):.1f} to {-100 * min(fine):.1f} % of the energy in the "
                     f"contact at every h up to 1e-4 s (the same at 5 us: the contact law, not the time stepping), "
                     f"and {-100 * (sp['E1'] - sp['E0']) / sp['E0']:.1f} % with its 'equilibrium' term removed.  A likely "
                     "cause (not isolated here): its spring force k gamma is split half and half between the two nodes of each element whatever "
                     "the closest point (the gradient of 1/2 k gamma^2 would split it as (1 - a, a)), which is not "
                     "the force of a potential.  With nu = 0 it needs no damping to stay stable.")
        diff = abs(refs[RODFEM]["v_a"][2] - refs[ELASTICA]["v_a"][2]) / V2
        notes.append(f"* The two references' v_a,z differ by {diff:.1e} of V/2 (different contact laws, elements and "
                     f"shear factor); both exchange {100 * (refs[RODFEM]['v_a'][2] + V2) / (2 * V2):.0f} % "
                     f"(rodfem) and {100 * (refs[ELASTICA]['v_a'][2] + V2) / (2 * V2):.0f} % (PyElastica) of the "
                     "rigid impact's velocity change: the rest rings on as bending vibration.")
        per = {t: np.median([r["cpu"] / r["steps"] for r in good if r["tool"] == t]) for t in refs}
        notes.append(f"* Cost per step (median over the sweep): rodfem {1e3 * per[RODFEM]:.1f} CPU ms (Newton, "
                     f"PETSc LU, a Python time loop), PyElastica {1e6 * per[ELASTICA]:.0f} CPU us (numba).  rodfem "
                     "survives far larger steps than PyElastica's explicit limit (about the shear wave across the "
                     "radius, r / sqrt(G / rho) = "
                     f"{SCENE['r'] / math.sqrt(SCENE['E'] / (2 * (1 + SCENE['poisson'])) / SCENE['rho']) * 1e3:.2g} ms), "
                     "but its momentum exchange is accurate only at steps that resolve the contact's chatter "
                     "(milliseconds): above that its error is large and not monotone in h.  At equal accuracy "
                     "PyElastica is cheaper on this scene (the ratios above).")
    notes.append("")
    if out:
        notes.append(f"PyElastica {out['version']} (numba {out['numba']}, numpy {out['numpy']}) in its own venv "
                     f"({args.elastica_python}); rodfem of this checkout, serial, one thread.")
        for r in out["spring_only"]:
            notes.append(f"PyElastica with the spring alone (its 'equilibrium' term removed, benchmarks/"
                         f"elastica_collision.py's spring_only), h = {r['dt']:.3g} s: {r['status']}, v_a,z = "
                         f"{r['v_a'][2]:.5f}, (E(end) - E(0)) / E(0) = {(r['E1'] - r['E0']) / r['E0']:.1e}.")
    else:
        notes.append(f"PyElastica not installed: `{INSTALL}`.")
    notes.append(f"Load average while this ran: {load:.1f} on 2 cores (the machine is shared): CPU seconds, not wall.")
    while notes and not notes[0]:
        notes.pop(0)
    write_report("elastica_collision", rows, columns, "Rod collision: rodfem and PyElastica over a sweep of the step",
                 intro=intro, notes=notes)


if __name__ == "__main__":
    sys.exit(main())
