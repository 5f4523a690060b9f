"""``rodfem study``: error against run time over a sweep of time steps and element counts.

Model-agnostic: a study only uses what every scene offers (its parameters
n_elements, dt, t_end, integrator; the history columns of a run; and the
optional ``Scene.reference(p)``).

Refinement paths (each one curve in the work-precision diagram)

* ``dt``        time steps dts at the base element count n0,
* ``n``         element counts at the base time step dt0,
* ``dt+n``      both refined together, (n_i, dt_i) with n ascending and dt
                descending (only when len(dts) == len(elements)).

Defaults: n0, dt0 are the scene's values (or --set), dts = dt0 / (1, 2, 4, 8),
elements = n0 * (1, 2, 4, 8).

Reference

* analytic, when ``scene.reference(p)`` returns a dict (exact values of
  history columns at t_end, optionally "scale");
* otherwise a run refined far beyond the sweep: REF_FACTOR x the finest
  element count and 1/REF_FACTOR x the smallest time step.

Error measure (stated in study.json, study.md and on stdout)

    error = |q_h(t_end) - q_ref(t_end)|_2 / scale

with q the compared history columns: the reference's columns (analytic), or
else the tip_* columns, or else the mean_* columns (no free end), or else
the markers' positions (<name>_x, _y, _z: mechanisms), or else
every observable of the run.  scale is the reference's "scale" (analytic),
else the largest excursion
max_t |q_ref(t) - q_ref(0)| of the reference run (so a relative error is
relative to how far the compared point moves).  With a reference run also
``error_max_t`` = max over the run's time levels of |q_h(t) - q_ref(t)| / scale.

Observed orders (computed, never assumed) for each path, in study.json and
the legend:

* ``order``:      least-squares slope of log(error) against log(step), step =
                  dt or 1/n (against the reference: includes the other
                  discretisation's error, so it flattens at that floor);
* ``self_order``: from successive differences within the path,
                  log(|q_k - q_k+1| / |q_k+1 - q_k+2|) / log(ratio), median
                  over the triples: the order in the refined variable alone,
                  independent of the reference.

A Newton failure does not end a study: its row says ``newton-failure`` with
step, time and residual, and it is left out of the fits and the plot.
"""
import csv
import math
import os

import numpy as np
from mpi4py import MPI

from rodfem.analysis.timeloop import steps_for
from rodfem.app.scene import Scene, load
from rodfem.common import limits
from rodfem.errors import InputError, Interrupted, NewtonFailure, ParameterError
from rodfem.io.output import OutDir, write_json

REF_FACTOR = 4
DEFAULT_LEVELS = 4
COLUMNS = ["path", "n_elements", "dt", "integrator", "steps", "status", "error", "error_max_t",
           "self_error", "wall_time_s", "newton_its_mean", "newton_its_max", "max_balance_error",
           "max_balance_error_relative", "failure"]
BOOKKEEPING = {"t", "H", "supplied", "newton_its", "balance_error"}


def _say(*args):
    if MPI.COMM_WORLD.rank == 0:
        print(*args, flush=True)


# -- sweep definition -----------------------------------------------------------

def sweep(p, dts=None, elements=None, levels=DEFAULT_LEVELS):
    """The refinement paths: dict name -> list of (n_elements, dt); the sweep's dts and elements; and
    notes saying what a single --dt or --elements value means: the fixed value of the other path
    (one value of each: a single run)."""
    if "n_elements" not in p:   # no flexible body (four-particle, spring-damper-chain): a dt path only
        if elements:
            raise ParameterError("--elements: this scene has no n_elements (no flexible body); study it along --dt")
        elements = [1]
    if p["dt"] == "auto":
        raise ParameterError("parameter 'dt': a study refines a fixed step: give a number, not auto")
    n0, dt0, notes = int(p.get("n_elements", 1)), float(p["dt"]), []
    one_n, one_dt = bool(elements) and len(set(elements)) == 1, bool(dts) and len(set(dts)) == 1
    if one_n and not one_dt and "n_elements" in p:
        n0 = int(elements[0])
        notes.append(f"--elements {n0}: one value, the element count of the dt path (an n path needs two or more)")
    if one_dt and not one_n:
        dt0 = float(dts[0])
        notes.append(f"--dt {dt0:g}: one value, the time step of the n path (a dt path needs two or more)")
    if one_n and one_dt:
        notes.append(f"--dt {float(dts[0]):g} --elements {int(elements[0])}: one value each, a single run")
    dts = sorted({float(d) for d in dts}, reverse=True) if dts else [dt0 / 2**k for k in range(levels)]
    elements = sorted({int(n) for n in elements}) if elements else [n0 * 2**k for k in range(levels)]
    paths = {}
    if len(dts) > 1:
        paths["dt"] = [(n0, d) for d in dts]
    if len(elements) > 1:
        paths["n"] = [(n, dt0) for n in elements]
    if len(dts) == len(elements) and len(dts) > 1:
        paths["dt+n"] = list(zip(elements, dts))
    if not paths:
        paths["single"] = [(elements[0], dts[0])]
    return paths, dts, elements, notes


def check_runs(scene, p, points, reference=None, ref_factor=REF_FACTOR, comm=MPI.COMM_WORLD):
    """Refuse the study before any run if one of its runs would be refused: every time step (the
    steps it makes of t_end) and every element count (the scene built up to its first mesh:
    n_elements in range, fewer than the ranks, too large for the memory), the reference run's
    (n, dt) too."""
    runs = [(n, dt, f"--elements {n}", f"--dt {dt:g}") for n, dt in points]
    if reference:
        n, dt = reference
        runs.append((n, dt, f"the reference run's n_elements = {n} ({ref_factor}x the finest)",
                     f"the reference run's dt = {dt:g} (1/{ref_factor} of the finest)"))
    for dt, what in sorted({(dt, what) for _, dt, _, what in runs}, reverse=True):
        try:
            steps_for(dt, p["t_end"])
        except ValueError as e:
            raise ParameterError(f"{what}: {e}") from None
    for n, what in sorted({(n, what) for n, _, what, _ in runs}):
        try:
            with limits.checking():
                scene.build(scene.values(_at(p, n)), comm)
        except limits.Checked:
            pass
        except InputError as e:
            raise ParameterError(f"{what}: {e}") from None


def _at(p, n):
    """The parameters p with n elements (unchanged for a scene without n_elements)."""
    return dict(p, n_elements=n) if "n_elements" in p else dict(p)


# -- running --------------------------------------------------------------------

def _run(scene, p, n, dt, repeats=1):
    """One run; returns a record (never raises NewtonFailure)."""
    from rodfem.app.driver import run_scene
    overrides = dict(_at(p, n), dt=dt)
    rec = _record(p, n, dt)
    best = None
    for _ in range(max(1, repeats)):
        try:
            result, summary = run_scene(scene, overrides)
        except NewtonFailure as fail:
            rec.update(status="newton-failure", failure=str(fail), result=None,
                       failure_info={"step": fail.step, "t": fail.t, "residual": fail.residual,
                                     "iterations": fail.iterations, "reason": fail.reason})
            return rec
        if best is None or result.wall_time < best[0].wall_time:
            best = (result, summary)
    result, summary = best
    rec.update(status="completed", failure="", result=result, wall_time_s=result.wall_time,
               newton_its_mean=summary["newton_its_mean"], newton_its_max=summary["newton_its_max"],
               max_balance_error=summary["max_balance_error"],
               max_balance_error_relative=summary["max_balance_error_relative"])
    return rec


def _record(p, n, dt, status=None, failure=""):
    """The record of a run (before it runs, or one that did not: `status`)."""
    rec = {"n_elements": n, "dt": dt, "integrator": p["integrator"], "steps": steps_for(dt, p["t_end"])}
    if status:
        rec.update(status=status, failure=failure, result=None)
    return rec


def compared_columns(row, analytic=None):
    """History columns the error compares (see module doc)."""
    if analytic:
        return [k for k in analytic if k != "scale"]
    tips = [k for k in row if k.startswith("tip_")]
    markers = [k for k in row if k.endswith(("_x", "_y", "_z")) and not k.startswith(("p_", "L_", "mean_"))]
    return (tips or [k for k in row if k.startswith("mean_")] or markers
            or [k for k in row if k not in BOOKKEEPING])


def _history(result, cols):
    return result.column("t"), np.column_stack([result.column(c) for c in cols])


# -- orders ---------------------------------------------------------------------

def fitted_order(steps, errors):
    """Least-squares slope of log(error) against log(step); None if < 2 usable points."""
    s = np.array([a for a, e in zip(steps, errors) if e is not None and e > 0])
    e = np.array([e for e in errors if e is not None and e > 0])
    if len(s) < 2 or len(set(s)) < 2:
        return None
    return float(np.polyfit(np.log(s), np.log(e), 1)[0])


def self_orders(steps, finals):
    """Orders from successive differences of q(t_end) along a path (steps decreasing)."""
    out = []
    for k in range(len(finals) - 2):
        q = finals[k:k + 3]
        if any(x is None for x in q):
            continue
        d1, d2 = np.linalg.norm(q[0] - q[1]), np.linalg.norm(q[1] - q[2])
        r1, r2 = steps[k] / steps[k + 1], steps[k + 1] / steps[k + 2]
        if d1 > 0 and d2 > 0 and abs(math.log(r1) - math.log(r2)) < 1e-9:
            out.append(math.log(d1 / d2) / math.log(r1))
    return out


# -- the study ------------------------------------------------------------------

def run_study(scene_name, overrides=None, out=None, dts=None, elements=None, repeats=1,
              levels=DEFAULT_LEVELS, ref_factor=REF_FACTOR, plot=True, quiet=False):
    """Run the study; write study.csv, study.json, study.md, study.png into `out`.

    Every run is checked before the first one (`check_runs`).  A run that ends the study (an input
    or output error, an interrupt; a Newton failure does not) leaves the files with the runs finished
    before it (study.json: "status"), the others marked "not-run", and is re-raised.
    Returns the study dict (what study.json holds, plus the rows).
    """
    scene = scene_name if isinstance(scene_name, Scene) else load(scene_name)
    p = scene.values(overrides)
    paths, dts, elements, notes = sweep(p, dts, elements, levels)
    out = out or os.path.join("results", f"study-{scene.name}")
    say = (lambda *a: None) if quiet else _say

    analytic = scene.reference(p) if scene.reference else None
    points = list(dict.fromkeys(pt for pts in paths.values() for pt in pts))
    reference = None if analytic else (ref_factor * max(n for n, _ in points) if "n_elements" in p else 1,
                                       min(dt for _, dt in points) / ref_factor)
    check_runs(scene, p, points, reference, ref_factor)
    runs = {}

    def get(n, dt):
        key = (int(n), float(dt))
        if key not in runs:
            say(f"  run n_elements={n:<5d} dt={dt:<10.4g} ...", )
            try:
                runs[key] = _run(scene, p, n, dt, repeats)
            except (InputError, Interrupted) as stop:
                runs[key] = _record(p, n, dt, "interrupted" if isinstance(stop, Interrupted) else "error", str(stop))
                raise
            r = runs[key]
            if r["status"] != "completed":
                say(f"    {r['failure']}")
        return runs[key]

    say(f"rodfem study {scene.name}: integrator {p['integrator']}, t_end = {p['t_end']:g}")
    for note in notes:
        say(note)
    reference_run, stop = None, None
    if analytic:
        ref_desc = f"analytic (scene.reference): {', '.join(f'{k} = {v:g}' for k, v in analytic.items())}"
    else:
        n_ref, dt_ref = reference
        ref_desc = (f"no analytic solution: a run refined far beyond the sweep, n_elements = {n_ref}, "
                    f"dt = {dt_ref:g} ({ref_factor}x the finest of the sweep in each)" if "n_elements" in p else
                    f"no analytic solution: a run with dt = {dt_ref:g} ({ref_factor}x finer than the sweep's finest)")
        say(f"reference: {ref_desc}")
    try:
        if reference:
            reference_run = _run(scene, p, n_ref, dt_ref, 1)
            if reference_run["status"] != "completed":
                _say(f"rodfem study: the reference run (n_elements = {n_ref}, dt = {dt_ref:g}) failed")
                raise NewtonFailure(**reference_run["failure_info"])
        for n, dt in points:
            get(n, dt)
    except (InputError, Interrupted) as e:
        stop = e
        if not any(r["result"] is not None for r in runs.values()):
            raise                                     # nothing finished: nothing to keep
        for n, dt in points:
            runs.setdefault((int(n), float(dt)), _record(p, n, dt, "not-run", f"not run: the study stopped ({e})"))

    # -- errors -------------------------------------------------------------
    first = next((r for r in runs.values() if r["result"] is not None), None)
    if first is None:
        raise NewtonFailure(**next(iter(runs.values()))["failure_info"])  # every run failed: report the first
    cols = compared_columns(first["result"].rows[-1], analytic)
    if analytic:
        q_ref = np.array([analytic[c] for c in cols], dtype=float)
        scale = float(analytic.get("scale") or np.linalg.norm(q_ref) or 1.0)
        measure = (f"relative error at t_end: |q_h(t_end) - q_exact|_2 / scale, q = ({', '.join(cols)}), "
                   f"scale = {scale:g} (from the scene's reference)")
    else:
        t_ref, Q_ref = _history(reference_run["result"], cols)
        q_ref = Q_ref[-1]
        scale = float(np.max(np.linalg.norm(Q_ref - Q_ref[0], axis=1))) or float(np.linalg.norm(q_ref)) or 1.0
        measure = (f"relative error at t_end: |q_h(t_end) - q_ref(t_end)|_2 / scale, q = ({', '.join(cols)}), "
                   f"scale = max_t |q_ref(t) - q_ref(0)| = {scale:.6g} (largest excursion in the reference run); "
                   f"error_max_t: the same, maximum over the run's time levels")
    say(f"error measure: {measure}")

    for r in runs.values():
        r["final"] = None
        r["error"] = r["error_max_t"] = None
        if r["result"] is None:
            continue
        t, Q = _history(r["result"], cols)
        r["final"] = Q[-1]
        r["error"] = float(np.linalg.norm(Q[-1] - q_ref)) / scale
        if reference_run is not None:
            Qi = np.column_stack([np.interp(t, t_ref, Q_ref[:, j]) for j in range(len(cols))])
            r["error_max_t"] = float(np.max(np.linalg.norm(Q - Qi, axis=1))) / scale

    # -- orders per path ---------------------------------------------------------
    orders = {}
    rows = []
    for name, pts in paths.items():
        recs = [runs[(int(n), float(dt))] for n, dt in pts]
        step = [dt for n, dt in pts] if name == "dt" else [1.0 / n for n, dt in pts]
        if name == "dt+n":
            step = [dt for n, dt in pts]
        errs = [r["error"] for r in recs]
        finals = [r["final"] for r in recs]
        so = self_orders(step, finals)
        orders[name] = {"order": fitted_order(step, errs),
                        "self_orders": so,
                        "self_order": float(np.median(so)) if so else None,
                        "step": "dt" if name != "n" else "1/n_elements",
                        "points": [[n, dt] for n, dt in pts]}
        for k, r in enumerate(recs):
            nxt = finals[k + 1] if k + 1 < len(finals) else None
            self_err = (float(np.linalg.norm(finals[k] - nxt)) / scale
                        if finals[k] is not None and nxt is not None else None)
            rows.append({"path": name, **{c: r.get(c) for c in COLUMNS if c in r and c != "path"},
                         "error": r["error"], "error_max_t": r["error_max_t"], "self_error": self_err})
    if reference_run is not None:
        r = reference_run
        rows.append({"path": "reference", **{c: r.get(c) for c in COLUMNS if c in r and c != "path"},
                     "error": 0.0, "error_max_t": 0.0, "self_error": None})

    study = {"scene": scene.name, "parameters": p, "integrator": p["integrator"],
             "reference": ref_desc, "reference_kind": "analytic" if analytic else "refined-run",
             "error_measure": measure, "compared_columns": cols, "scale": scale,
             "reference_values": {c: float(v) for c, v in zip(cols, q_ref)},
             "orders": orders, "paths": {k: [[n, dt] for n, dt in v] for k, v in paths.items()},
             "failures": [{"n_elements": r["n_elements"], "dt": r["dt"], **r["failure_info"]}
                          for r in runs.values() if r["status"] == "newton-failure"],
             "status": _status(stop), **({"stopped": str(stop)} if stop else {})}
    OutDir(out, MPI.COMM_WORLD).do("write the study", write_files, out, study, rows, plot)
    if stop:
        stop.kept = out   # the command line says so
        raise stop
    for name, o in orders.items():
        say(f"path {name:5s}: observed order {_fmt(o['order'])} (against the reference), "
            f"self-convergence order {_fmt(o['self_order'])}")
    say(f"results in {out}/: study.csv, study.json, study.md, study.png")
    study["rows"] = rows
    return study


def _status(stop):
    """study.json's status: completed, or how the study was stopped."""
    return "completed" if stop is None else "interrupted" if isinstance(stop, Interrupted) else "error"


def write_files(out, study, rows, plot=True):
    """study.csv, study.json, study.md and (plot) study.png in `out`."""
    os.makedirs(out, exist_ok=True)
    write_csv(os.path.join(out, "study.csv"), rows)
    write_json(os.path.join(out, "study.json"), study)
    write_md(os.path.join(out, "study.md"), study, rows)
    if plot:
        plot_study(os.path.join(out, "study.png"), study, rows)


def _fmt(x, spec=".2f"):
    return "n/a" if x is None else format(x, spec)


def write_csv(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({c: ("" if r.get(c) is None else (repr(r[c]) if isinstance(r[c], float) else r[c]))
                        for c in COLUMNS})


def write_md(path, study, rows):
    lines = [f"# Study: {study['scene']} ({study['integrator']})", "",
             f"* Reference: {study['reference']}", f"* Error: {study['error_measure']}", "",
             "| path | order (vs reference) | self-convergence order |", "|---|---|---|"]
    for name, o in study["orders"].items():
        lines.append(f"| {name} | {_fmt(o['order'])} | {_fmt(o['self_order'])} |")
    lines += ["", "| path | n_elements | dt | status | error | wall time (s) | Newton its | max balance error |",
              "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['path']} | {r['n_elements']} | {r['dt']:g} | {r['status']} | "
                     f"{_fmt(r.get('error'), '.3e')} | {_fmt(r.get('wall_time_s'), '.3f')} | "
                     f"{_fmt(r.get('newton_its_mean'), '.2f')} | {_fmt(r.get('max_balance_error'), '.1e')} |")
    for fl in study["failures"]:
        lines.append(f"\nNewton failure at n_elements = {fl['n_elements']}, dt = {fl['dt']:g}: step {fl['step']}, "
                     f"t = {fl['t']:g}, residual {fl['residual']:.3e} ({fl['reason']})")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


LABELS = {"dt": "dt refined (n = {n})", "n": "n refined (dt = {dt:g})", "dt+n": "dt and n refined",
          "single": "single run"}


def path_label(name, study):
    pts = study["paths"][name]
    o = study["orders"][name]
    lab = LABELS.get(name, name).format(n=pts[0][0], dt=pts[0][1])
    return f"{lab}: order {_fmt(o['order'])}, self {_fmt(o['self_order'])}"


def plot_study(path, study, rows, extra=None, title=None):
    """Work-precision diagram: error against wall time, log-log, one curve per path.

    `extra`: optional list of (label, wall_times, errors, style dict) drawn too
    (the benchmarks put other tools on the same diagram with it).
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.5, 5.5))
    markers = {"dt": "o-", "n": "s-", "dt+n": "^-", "single": "x"}
    for name in study["paths"]:
        pts = [r for r in rows if r["path"] == name and r.get("error") and r.get("wall_time_s")]
        if not pts:
            continue
        ax.loglog([r["wall_time_s"] for r in pts], [r["error"] for r in pts], markers.get(name, "o-"),
                  label=path_label(name, study))
    for label, w, e, style in extra or []:
        ok = [(a, b) for a, b in zip(w, e) if a and b and b > 0]
        if ok:
            ax.loglog(*zip(*ok), label=label, **(style or {}))
    ax.set_xlabel("wall time of the time loop (s)")
    ax.set_ylabel("relative error")
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title(title or f"{study['scene']} ({study['integrator']}); reference: {study['reference_kind']}",
                 fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
