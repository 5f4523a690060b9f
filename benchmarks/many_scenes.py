"""The many-part scenes at their big sizes: build time, time per step, serial and on 2 ranks (issue 26).

    .venv/bin/python benchmarks/many_scenes.py [--quick] [--ranks 1 2] [--timeout 1500] [--only SIZE ...] [--append]
                                               # -> benchmarks/many_scenes.{csv,md}

--only runs the cases whose size label contains one of the words (e.g. --only "1000 links" tower);
--append keeps the rows of an earlier run (benchmarks/many_scenes.csv) of the cases and rank counts not run now.
The table is rewritten after every case.

Each case runs in a process of its own (under `mpirun -n 2` for 2 ranks, inside `timeout`): the
scene's system is sketched and built (`build s`: wall and CPU time of scene.build + System.build,
forms from a warm JIT cache), then `steps` steps are run (`ms/step`: wall and CPU time of the time
loop per step, `its`: Newton iterations per step).  The machine is shared by several developers.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

CASES = [   # (scene, overrides, steps, what, rank counts)
    ("chain-1000", {"n_links": 16}, 200, "16 links (default)", (1, 2)),
    ("chain-1000", {"n_links": 100}, 20, "100 links", (1, 2)),
    ("chain-1000", {"n_links": 256}, 200, "256 links, 1 s (its failed steps halved)", (1, 2)),
    ("chain-1000", {"n_links": 300}, 5, "300 links", (1,)),
    ("chain-1000", {"n_links": 1000}, 5, "1000 links", (1, 2)),   # (0.4 GB per process)
    ("tensegrity", {}, 200, "1 prism: 3 struts, 9 cables (default)", (1, 2)),
    ("tensegrity", {"stories": 10}, 20, "tower of 10 prisms: 30 struts, 63 cables", (1, 2)),
    ("cable-net", {}, 20, "4 x 4 crossings, 40 strings (default)", (1, 2)),
    ("cable-net", {"n": 20}, 5, "20 x 20 crossings, 840 strings", (1, 2)),
]
QUICK = [c for c in CASES if "default" in c[3]]

CHILD = r"""
import json, sys, time
from mpi4py import MPI
from rodfem import run
from rodfem.app.scene import load
name, overrides, steps = sys.argv[1], json.loads(sys.argv[2]), int(sys.argv[3])
scene = load(name)
p = scene.values(overrides)
t0, c0 = time.perf_counter(), time.process_time()
system = scene.build(p, MPI.COMM_WORLD).build()
build, build_cpu = time.perf_counter() - t0, time.process_time() - c0
c0 = time.process_time()
res = run(system, p["dt"], steps * p["dt"])
cpu = time.process_time() - c0
its = sum(res.column("newton_its")) / steps
row = dict(build_s=build, build_cpu_s=build_cpu, ms_per_step=1e3 * res.wall_time / steps, cpu_ms_per_step=1e3 * cpu / steps, newton_its=its, bodies=len(system.bodies),
           joints=len(system.joints), dofs=system.dofs,
           balance=res.max_balance_error / max(abs(h) for h in res.column("H")))
if MPI.COMM_WORLD.rank == 0:
    print("RESULT " + json.dumps(row))
"""


def child(case, ranks, timeout):
    name, overrides, steps = case[:3]
    env = dict(os.environ, PYTHONPATH=ROOT, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    cmd = [sys.executable, "-c", CHILD, name, json.dumps(overrides), str(steps)]
    if ranks > 1:
        cmd = [shutil.which("mpirun"), "--allow-run-as-root", "--oversubscribe", "-n", str(ranks), *cmd]
    try:
        out = subprocess.run(["timeout", str(timeout), *cmd], env=env, capture_output=True, text=True, cwd=ROOT,
                             timeout=timeout + 60)
    except subprocess.TimeoutExpired:
        return {"status": f"over {timeout} s"}
    lines = [x for x in out.stdout.splitlines() if x.startswith("RESULT ")]
    if out.returncode or not lines:
        return {"status": f"over {timeout} s" if out.returncode == 124 else f"failed ({out.stderr.strip()[-200:]})"}
    return dict(json.loads(lines[-1][7:]), status="ok")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="the default sizes only")
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--timeout", type=int, default=1500, help="seconds per case and rank count")
    ap.add_argument("--only", nargs="+", help="the cases whose size label contains one of these texts")
    ap.add_argument("--append", action="store_true", help="keep the earlier rows of the cases not run now")
    args = ap.parse_args()
    sys.path.insert(0, HERE)
    cases = [c for c in (QUICK if args.quick else CASES) if not args.only or any(w in c[3] for w in args.only)]
    rows = earlier([(c[0], c[3], r) for c in cases for r in args.ranks if r in c[4]]) if args.append else []
    for case in cases:
        for ranks in [r for r in args.ranks if r in case[4]]:
            r = child(case, ranks, args.timeout)
            rows.append(dict(scene=case[0], size=case[3], ranks=ranks, steps=case[2], **r))
            print(rows[-1], flush=True)
            report(sorted(rows, key=order))


def order(row):
    """The rows in the order of CASES, then by ranks."""
    labels = [(c[0], c[3]) for c in CASES]
    key = (row["scene"], row["size"])
    return (labels.index(key) if key in labels else len(labels), int(row["ranks"]))


def earlier(replaced):
    """The rows of benchmarks/many_scenes.csv but those of the runs `replaced` ((scene, size, ranks)), numbers as
    numbers."""
    import csv
    path = os.path.join(HERE, "many_scenes.csv")
    if not os.path.exists(path):
        return []
    with open(path) as f:
        rows = [r for r in csv.DictReader(f) if (r["scene"], r["size"], int(r["ranks"])) not in replaced]
    for r in rows:
        for k, v in list(r.items()):
            if v == "":
                del r[k]
            elif k not in ("scene", "size", "status"):
                r[k] = float(v) if any(c in v for c in ".e") else int(v)
    return rows


def report(rows):
    from report import write_report
    keys = list(dict.fromkeys(k for r in rows for k in r))
    rows = [{k: r.get(k) for k in keys} for r in rows]   # (the CSV's columns: those of every row)

    def fmt(key, spec):
        return lambda r: format(r[key], spec) if r.get(key) is not None else ""
    columns = [("scene", "{}"), ("size", "{}"), ("ranks", "{}"), ("bodies", fmt("bodies", "d")),
               ("joints", fmt("joints", "d")), ("dofs", fmt("dofs", "d")), ("build_s", fmt("build_s", ".2f"), "build s"),
               ("build_cpu_s", fmt("build_cpu_s", ".2f"), "build CPU s"), ("steps", "{}"),
               ("ms_per_step", fmt("ms_per_step", ".2f"), "ms/step"), ("cpu_ms_per_step", fmt("cpu_ms_per_step", ".2f"),
                                                                         "CPU ms/step (rank 0)"),
               ("newton_its", fmt("newton_its", ".2f"), "Newton its/step"),
               ("balance", fmt("balance", ".1e"), "max balance error / max H"), ("status", "{}")]
    load = os.getloadavg()[0]
    path = os.path.join(HERE, "many_scenes.md")
    kept = ""   # (what follows KEPT in the file: comparisons written by hand, kept when the table is written again)
    if os.path.exists(path):
        text = open(path).read()
        kept = text[text.index(KEPT):] if KEPT in text else ""
    write_report("many_scenes", rows, columns, "The many-part scenes at their big sizes: build and step times",
                 intro=["build = scene.build + System.build (JIT cache warm), ms/step = the time loop per step; wall "
                        "and CPU time of rank 0 (the machine is shared: wall times swing by several times, CPU times "
                        "less; on 2 ranks the CPU time includes MPI's busy waiting).  Each case in its own process; "
                        "2 ranks: `mpirun -n 2` on this 2-core machine."],
                 notes=[f"Load average while this ran: {load:.1f} on 2 cores (shared with other developers)."])
    if kept:
        with open(path, "a") as fh:
            fh.write("\n" + kept)


KEPT = "<!-- kept: written by hand -->"


if __name__ == "__main__":
    main()
