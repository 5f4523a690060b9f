"""Debian 12 (DOLFINx 0.5.2) against Debian 13 (DOLFINx 0.9.0): time per step and history differences.

Run the scenes once on each release (same machine), then compare the two result directories:

    .venv/bin/python benchmarks/debian13.py run results/deb12                  # on Debian 12
    .venv/bin/python benchmarks/debian13.py run results/deb13                  # in the Debian 13 root
    .venv/bin/python benchmarks/debian13.py compare results/deb12 results/deb13 --md benchmarks/debian13.md

`run` runs each scene twice (the first compiles its forms into the JIT cache) and keeps the second; the time per step is the CLI's (summary.json, wall time of the time loop / steps).  `compare`
gives, per scene, both times and the largest difference of every history column between the two
releases, relative to that column's largest magnitude; columns that are round-off by nature (at most
1e-10 of the largest column: a zero momentum component, the constraint residual, the balance error)
are compared absolutely instead.
"""
import argparse
import csv
import json
import os
import subprocess
import sys

import numpy as np

SCENES = {   # scene: settings (small enough for a few seconds each)
    "cantilever-2d": {"t_end": "0.2"},
    "flying-spaghetti-2d": {"t_end": "4.0"},
    "flying-spaghetti-3d": {"t_end": "1.5", "n_elements": "16"},
    "four-bar-2d": {"t_end": "2.0"},
}


def rodfem(scene, settings, out):
    args = [sys.executable, "-m", "rodfem", "run", scene, "--quiet", "--out", out, "--set", "frames=2"]
    for k, v in settings.items():
        args += ["--set", f"{k}={v}"]
    subprocess.run(args, check=True, env=dict(os.environ, OMP_NUM_THREADS="1"))


def run(out):
    before = os.getloadavg()[0]
    for scene, settings in SCENES.items():
        rodfem(scene, settings, os.path.join(out, scene + ".warm"))   # compiles the forms
        rodfem(scene, settings, os.path.join(out, scene))
    with open(os.path.join(out, "load.json"), "w") as f:   # the machine's load: the times are only as good as it
        json.dump({"load_before": before, "load_after": os.getloadavg()[0], "cpus": os.cpu_count()}, f)


def history(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def compare(a, b, md):
    lines = ["# Debian 12 (DOLFINx 0.5.2) and Debian 13 (DOLFINx 0.9.0): the same scenes", "",
             "Same machine, serial, `OMP_NUM_THREADS=1`, JIT cache warm; produced by `benchmarks/debian13.py`.",
             "Relative difference: the largest |column(0.9) - column(0.5.2)| over the history, over the column's",
             "largest magnitude, the worst column named.  Round-off columns (at most 1e-10 of the largest column:",
             "zero momentum components, the constraint residual, the balance error): the largest absolute",
             "difference.  t and the Newton iteration counts are compared exactly.", "",
             "| scene | steps | ms/step 0.5.2 | ms/step 0.9 | ratio | Newton its equal | largest relative difference "
             "| round-off columns, largest difference |",
             "|---|---|---|---|---|---|---|---|"]
    for scene in SCENES:
        sa = json.load(open(os.path.join(a, scene, "summary.json")))
        sb = json.load(open(os.path.join(b, scene, "summary.json")))
        ha, hb = history(os.path.join(a, scene, "history.csv")), history(os.path.join(b, scene, "history.csv"))
        assert sa["dolfinx_version"] != sb["dolfinx_version"], "two runs of the same DOLFINx"
        keys = [k for k in ha if k not in ("t", "newton_its") and k in hb and len(ha[k]) == len(hb[k])]
        scale = {k: max(np.abs(ha[k]).max(), np.abs(hb[k]).max()) for k in keys}
        largest = max(scale.values())
        worst, name, roundoff = 0.0, "-", 0.0
        for k in keys:
            d = float(np.abs(ha[k] - hb[k]).max())
            if scale[k] <= 1e-10 * largest:
                roundoff = max(roundoff, d)
            elif d / scale[k] >= worst:
                worst, name = d / scale[k], k
        same_its = len(ha["t"]) == len(hb["t"]) and bool(np.all(ha["newton_its"] == hb["newton_its"]))
        ta, tb = sa["time_per_step_ms"], sb["time_per_step_ms"]
        lines.append(f"| {scene} | {sa['steps']} | {ta:.2f} | {tb:.2f} | {tb / ta:.2f} | "
                     f"{'yes' if same_its else 'no'} | {worst:.1e} ({name}) | {roundoff:.1e} |")
    for label, d in (("0.5.2", a), ("0.9", b)):
        if os.path.exists(os.path.join(d, "load.json")):
            load = json.load(open(os.path.join(d, "load.json")))
            lines.append(f"\nLoad average during the {label} run: {load['load_before']:.1f} before, "
                         f"{load['load_after']:.1f} after, on {load['cpus']} CPUs.")
    text = "\n".join(lines) + "\n"
    print(text)
    if md:
        with open(md, "w") as f:
            f.write(text)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("out")
    c = sub.add_parser("compare")
    c.add_argument("a")
    c.add_argument("b")
    c.add_argument("--md")
    args = ap.parse_args()
    if args.cmd == "run":
        run(args.out)
    else:
        compare(args.a, args.b, args.md)


if __name__ == "__main__":
    main()
