"""Cost per step and build time of systems of many bodies, and of small scenes (issue 26).

    .venv/bin/python benchmarks/bench_many_bodies.py [--before CHECKOUT] [--quick]
                                                    # -> benchmarks/many_bodies.{csv,md}
    .venv/bin/python benchmarks/bench_many_bodies.py --small --before CHECKOUT [--repeats 5]
                                                    # -> benchmarks/small_steps.csv, the small-step
                                                    #    tables of many_bodies.md and small_steps.md
    .venv/bin/python benchmarks/bench_many_bodies.py --rigid [--before CHECKOUT]
                                                    # -> the chain-1000 scene's table of many_bodies.md

A hanging chain of N planar steel beams pinned end to end (the first pinned to the ground), 128
elements in total (N = 256, 1000: one element per beam), falling from horizontal under gravity:
CPU ms per step (the better of two runs of `steps` steps, each after a fresh build in the same
process; N = 1000: one run; CPU time of the process, not wall time: this machine is shared by
several developers and its wall times swing by 2x) and the build's CPU time (a build after the
first of the process: forms found in the JIT cache), for
N = 1, 4, 16, 64, 256 and 1000; then the 10-element planar beam (flying-spaghetti-2d, 300 steps)
the 10-element 3D rod (flying-spaghetti-3d, 200 steps) and the 16-element one in a 10-step and a 1000-step run.  Each case runs
in a process of its own, side by side for

* `batch`: this checkout, bodies of the same compiled forms assembled together (rodfem/fem/batch.py),
  bodies of one kind sharing their mesh and compiled forms (rodfem/core/kinds.py),
* `body by body`: this checkout with `System(batch=False)`,
* `before`: another checkout (--before, e.g. a worktree of main before this work), if given.
"""
import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)


def chain(N, total=128, distribute=None):
    """The chain of N beams (each total // N elements, at least one)."""
    from rodfem import Load, Support
    from rodfem.core.system import System
    from rodfem.forms import joints
    from rodfem.forms.planar_beam import PlanarBeam, quadratic, straight
    s = System(distribute=distribute)
    w, rho, E = 0.01, 7800.0, 2e9
    A, I = w * w, w ** 4 / 12
    model = PlanarBeam(rho * A, rho * I, quadratic(EA=E * A, GA=E / 2.6 * A, EI=E * I))
    n, L = max(total // N, 1), 1.0 / N
    prev = None
    for k in range(N):
        g = Load("v", [0.0, -rho * A * 9.81], "domain", f"gravity b{k}")
        b = s.add(f"b{k}", model, shape=straight((k * L, 0.0), ((k + 1) * L, 0.0)), n_elements=n, loads=[g],
                  supports=[Support("left", "pinned")] if k == 0 else [])
        if prev is not None:
            s.join(joints.pin, prev.end, b.start)
        prev = b
    return s


def measure(case, batch, repeats=3):
    """One case in this process: {ms_per_step, build_s, newton_its, F_ms, J_ms}."""
    from mpi4py import MPI

    from rodfem import run
    kind, arg, n, steps = case
    if kind == "chain":
        make, dt = (lambda: chain(arg)), 1e-3
    elif kind == "links":
        from rodfem.app.scene import load
        scene = load("chain-1000")
        p = scene.values({"n_links": arg})
        make, dt = (lambda: scene.build(p, MPI.COMM_WORLD)), p["dt"]
    else:
        from rodfem.app.scene import load
        scene = load(arg)
        p = scene.values({"n_elements": n})
        make, dt = (lambda: scene.build(p, MPI.COMM_WORLD)), p["dt"]
    from rodfem.core.system import System
    System.batch = batch   # (an older checkout has no batch: it ignores the attribute)
    best = None
    for k in range(repeats):   # the first: JIT modules loaded; then the better of the others
        t0 = time.process_time()
        s = make()
        s.build()
        build = time.process_time() - t0
        c0 = time.process_time()
        res = run(s, dt, steps * dt)
        cpu = time.process_time() - c0
        t = s.newton.timings
        row = {"ms_per_step": 1e3 * cpu / steps, "wall_ms_per_step": 1e3 * res.wall_time / steps, "build_s": build,
               "newton_its": sum(res.column("newton_its")) / steps,
               "F_ms": 1e3 * t["F"] / steps, "J_ms": 1e3 * t["J"] / steps}
        if (k or repeats == 1) and (best is None or row["ms_per_step"] < best["ms_per_step"]):
            best = dict(row, build_s=build if best is None else min(build, best["build_s"]))
    return best


def child(case, batch, checkout, repeats=None):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([checkout, HERE]), OMP_NUM_THREADS="1")
    code = (f"import json, sys; sys.path.insert(1, {HERE!r}); from bench_many_bodies import measure; "
            "import rodfem; assert rodfem.__file__.startswith(sys.argv[1]), rodfem.__file__; "
            f"print('RESULT', json.dumps(measure({tuple(case)!r}, {batch!r}, "
            f"{repeats or (2 if case[1] == 1000 else 3)})))")
    # (run in the checkout: `python -c` puts the working directory first on the path)
    out = subprocess.run([sys.executable, "-c", code, checkout], env=env, capture_output=True, text=True, check=True,
                         cwd=checkout)
    return json.loads(next(x for x in out.stdout.splitlines() if x.startswith("RESULT"))[6:])


def kept_sections(path):
    """The sections of many_bodies.md that other runs wrote between markers (``<!-- name: ...`` to
    ``<!-- /name -->``: --small, --rigid, bench_bodies_ranks.py), {name: lines}, to keep when the main
    run writes the file again."""
    text = open(path).read().split("\n") if os.path.exists(path) else []
    found, name = {}, None
    for line in text:
        if name is None and line.startswith("<!-- ") and ":" in line and not line.startswith("<!-- /"):
            name = line[5:].split(":", 1)[0]
            found[name] = []
        if name is not None:
            found[name].append(line)
            if line == f"<!-- /{name} -->":
                name = None
    return found


def focused(rows, small_section=None):
    """The build-time table (chains: build s before / now, ms/step) and the small-step table (scenes:
    ms/step before / now; the 16-element 3D rod's 10-step run against its 1000-step run), or the
    small-step section of a --small run if there is one."""
    def f(r, key, fmt):
        v = r.get(key)
        return "" if v in (None, "") else fmt.format(float(v))
    lines = ["## Build time", "", "| bodies | build s before | build s now | ms/step before | ms/step now |",
             "|---|---|---|---|---|"]
    for r in rows:
        if r["case"].startswith("chain of ") and r["case"].split()[2] != "4":
            lines.append(f"| {r['case'].split()[2]} | {f(r, 'before:build_s', '{:.2f}')} | "
                         f"{f(r, 'batch:build_s', '{:.2f}')} | {f(r, 'before:ms_per_step', '{:.3f}')} | "
                         f"{f(r, 'batch:ms_per_step', '{:.3f}')} |")
    if small_section:
        return lines + ["", "## Small steps", "", *small_section]
    lines += ["", "## Small steps", "", "| scene | steps | ms/step before | ms/step now |", "|---|---|---|---|"]
    for r in rows:
        if not r["case"].startswith("chain of "):
            lines.append(f"| {r['case']} | {r['steps']} | {f(r, 'before:ms_per_step', '{:.3f}')} | "
                         f"{f(r, 'batch:ms_per_step', '{:.3f}')} |")
    return lines


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", help="another checkout to measure side by side (e.g. main before this work)")
    ap.add_argument("--quick", action="store_true", help="N up to 64, no 1000-body chain")
    ap.add_argument("--tables", action="store_true", help="only write many_bodies.md again from many_bodies.csv")
    ap.add_argument("--small", action="store_true", help="only the small scenes, this checkout and --before in turn, "
                    "--repeats processes each: medians (the small-step tables)")
    ap.add_argument("--repeats", type=int, default=5, help="--small: processes per case and checkout")
    ap.add_argument("--before-name", help="what --before is, for the table's note (default: its path; the main run: "
                    "'main before this work')")
    ap.add_argument("--rigid", action="store_true", help="only the chain-1000 scene (rigid links on revolute joints): "
                    "build time and ms/step at 16 to 1000 links")
    args = ap.parse_args()
    from report import write_report
    if args.small:
        return small(args.before, args.repeats, args.before_name)
    if args.rigid:
        return rigid(args.before, args.before_name)
    if args.tables:
        import csv
        with open(os.path.join(HERE, "many_bodies.csv")) as fh:
            rows = list(csv.DictReader(fh))
        codes = [c for c in ("batch", "body by body", "before") if f"{c}:ms_per_step" in rows[0]]
        return report(rows, codes, write_report, None, args.before_name)
    cases = [("chain", N, None, 20) for N in (1, 4, 16, 64, 256)]
    if not args.quick:
        cases.append(("chain", 1000, None, 5))
    cases += [("scene", "flying-spaghetti-2d", 10, 300), ("scene", "flying-spaghetti-3d", 10, 200),
              ("scene", "flying-spaghetti-3d", 16, 10), ("scene", "flying-spaghetti-3d", 16, 1000)]
    if args.quick:
        cases = [c for c in cases if not (c[0] == "chain" and c[1] > 64)]
    codes = [("batch", True, ROOT), ("body by body", False, ROOT)]
    if args.before:
        codes.append(("before", True, os.path.abspath(args.before)))
    rows = []
    for case in cases:
        row = {"case": f"chain of {case[1]} beams" if case[0] == "chain" else f"{case[1]} ({case[2]} el.)",
               "steps": case[3]}
        for label, batch, checkout in codes:
            if label == "body by body" and case[0] == "chain" and case[1] == 1000:
                continue   # (body by body: minutes per run)
            r = child(case, batch, checkout)
            for k, v in r.items():
                row[f"{label}:{k}"] = v
            print(row["case"], label, r, flush=True)
        rows.append(row)
    report(rows, [label for label, _, _ in codes], write_report, os.getloadavg()[0], args.before_name)


SMALL = [("scene", "flying-spaghetti-2d", 10, 300), ("scene", "flying-spaghetti-3d", 10, 200),
         ("scene", "flying-spaghetti-3d", 16, 10), ("scene", "flying-spaghetti-3d", 16, 1000)]
SMALL_START, SMALL_END = "<!-- small: written by bench_many_bodies.py --small -->", "<!-- /small -->"


def small(before, repeats, name=None):
    """The small scenes, this checkout and `before` alternating, `repeats` processes each (each: the better
    of two runs after a first, CPU time): the median over the processes, and their spread."""
    import statistics
    codes = [("now", ROOT)] + ([("before", os.path.abspath(before))] if before else [])
    rows = []
    for case in SMALL:
        row = {"case": f"{case[1]} ({case[2]} el.)", "steps": case[3]}
        runs = {label: [] for label, _ in codes}
        for _ in range(repeats):
            for label, checkout in codes:
                runs[label].append(child(case, True, checkout))
        for label, _ in codes:
            ms = [r["ms_per_step"] for r in runs[label]]
            row[f"{label}:ms_per_step"] = statistics.median(ms)
            row[f"{label}:min"], row[f"{label}:max"] = min(ms), max(ms)
            row[f"{label}:newton_its"] = runs[label][0]["newton_its"]
        print(row, flush=True)
        rows.append(row)
    from report import table, write_csv
    write_csv("small_steps", rows)
    columns = [("case", "{}", "scene"), ("steps", "{}")]
    for label, _ in codes:
        columns += [(f"{label}:ms_per_step", "{:.3f}", f"ms/step {label} (median)"),
                    (f"{label}:range", lambda r, k=label: f"{r[k + ':min']:.3f}-{r[k + ':max']:.3f}", f"{label}: range")]
    if before:
        columns.append(("ratio", lambda r: f"{r['now:ms_per_step'] / r['before:ms_per_step']:.2f}", "now / before"))
    lines = [SMALL_START, "", f"CPU ms per step (the process's CPU time over the run, the better of two runs after a first "
             f"in each process), median of {repeats} processes per checkout, the checkouts alternating; "
             f"load average {os.getloadavg()[0]:.1f} on 2 cores.  now: this checkout; before: {name or before}.", "",
             *table(rows, columns), "", SMALL_END]
    for name in ("many_bodies.md", "small_steps.md"):
        _replace_section(os.path.join(HERE, name), lines, "## Small steps" if name == "many_bodies.md" else None)
    print("\n".join(lines))


RIGID_START, RIGID_END = "<!-- rigid: written by bench_many_bodies.py --rigid -->", "<!-- /rigid -->"


def rigid(before, name=None):
    """The chain-1000 scene at 16-1000 links: build CPU s (a build after the first of the process) and CPU
    ms/step (the better of two 5-step runs), this checkout and `before` (one run each at 1000 links)."""
    codes = [("now", ROOT)] + ([("before", os.path.abspath(before))] if before else [])
    lines = [RIGID_START, "", "## Rigid links: the chain-1000 scene", "",
             f"The chain-1000 scene (rigid links on revolute joints, forms/joints.py), 5 steps of its h = 5 ms; build: "
             f"CPU s of a build after the first of the process (JIT cache warm), ms/step: CPU time.  Load average "
             f"{os.getloadavg()[0]:.1f} on 2 cores.  now: this checkout; before: {name or before}.", "",
             "| links | " + " | ".join(f"build s {c} | ms/step {c}" for c, _ in codes) + " |",
             "|---|" + "---|---|" * len(codes)]
    for N in (16, 64, 256, 1000):
        cells = []
        for label, checkout in codes:
            r = child(("links", N, None, 5), True, checkout, repeats=1 if N == 1000 else 3)
            print(N, label, r, flush=True)
            cells += [f"{r['build_s']:.2f}", f"{r['ms_per_step']:.2f}"]
        lines.append(f"| {N} | " + " | ".join(cells) + " |")
    lines += ["", RIGID_END]
    _replace_section(os.path.join(HERE, "many_bodies.md"), lines, None, (RIGID_START, RIGID_END))
    print("\n".join(lines))


def _replace_section(path, lines, heading, markers=(SMALL_START, SMALL_END)):
    """The lines between the `markers` of the file at path replaced (if they are not there: the
    section under `heading` up to the next one, or the end of the file)."""
    text = open(path).read().split("\n") if os.path.exists(path) else []
    start, end = markers
    if start in text:
        a, b = text.index(start), text.index(end) + 1
    elif heading in text:
        a = text.index(heading) + 2
        b = next((i for i in range(a, len(text)) if text[i].startswith("## ")), len(text)) - 1
    else:
        a = b = len(text)
    with open(path, "w") as fh:
        fh.write("\n".join(text[:a] + lines + text[b:]))


def report(rows, codes, write_report, load, before_name=None):
    """benchmarks/many_bodies.{csv,md}: every case side by side, then the two focused tables."""
    def cell(key, fmt):
        return lambda r: fmt.format(float(r[key])) if r.get(key) not in (None, "") else ""
    columns = [("case", "{}"), ("steps", "{}")]
    for label in codes:
        columns += [(f"{label}:ms_per_step", cell(f"{label}:ms_per_step", "{:.3f}"), f"{label} ms/step"),
                    (f"{label}:build_s", cell(f"{label}:build_s", "{:.2f}"), f"{label} build s")]
    path = os.path.join(HERE, "many_bodies.md")
    sections = kept_sections(path)
    if load is None:   # (--tables: the note of the run that measured them)
        with open(os.path.join(HERE, "many_bodies.md")) as fh:
            kept = [x for x in fh.read().splitlines() if x.startswith("Load average")]
        load_note = kept[0] if kept else ""
    else:
        load_note = f"Load average while this ran: {load:.1f} on 2 cores (the machine is shared: +-50 % " \
                    "between runs is usual)."
    write_report("many_bodies", rows, columns, "Many bodies and small scenes: cost per step and build time",
                 intro=["Chain: N planar beams pinned end to end, 128 elements in total (N >= 128: one per beam), "
                        "h = 1 ms; scenes at their default h.  ms/step: CPU time of the process per step, the better "
                        "of two runs; build: CPU seconds of a build after the first of a process (JIT cache warm). "
                        "Serial, one thread.  batch: this checkout; body by body: this checkout with System(batch=False); "
                        f"before: the checkout given as --before ({before_name or 'main before this work'})."],
                 notes=[load_note, "", *focused(rows, sections.pop("small", None))])
    if sections:   # (the ranks and rigid-links sections, after the rest)
        with open(path, "a") as fh:
            fh.write("".join("\n" + "\n".join(lines) + "\n" for lines in sections.values()))


if __name__ == "__main__":
    main()
