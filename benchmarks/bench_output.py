"""Cost of a run's output per frame: gathering the state, writing the .vtp files (centreline and
surface of every body), and the pictures (shapes.png, animation.gif) at the end.

    .venv/bin/python benchmarks/bench_output.py                 # writes benchmarks/output.md
    .venv/bin/python benchmarks/bench_output.py --out /tmp/o.md # another commit: PYTHONPATH=<its checkout>
    .venv/bin/python benchmarks/bench_output.py --large --out /tmp/large.md   # frames of 10^5 elements

Each scene runs with `frames` frames (a frame per level where frames > steps); the wall time of the
writer's parts is measured by wrapping RunWriter's methods (the same on any commit that has them),
the time steps' own cost excluded; "pictures" is everything at the end: shapes.png, animation.gif,
energy.png and view.py.  Serial, one core.
"""
import argparse
import os
import sys
import tempfile
import time

from mpi4py import MPI

from rodfem.analysis.timeloop import run, steps_for
from rodfem.app.scene import load
from rodfem.io import output

CASES = [  # scene, parameters, frames
    ("flying-spaghetti-3d", dict(n_elements=10, t_end=5.0), 51),
    ("flying-spaghetti-2d", dict(n_elements=10, t_end=5.0), 51),
    ("four-bar-2d", dict(t_end=0.5), 51),
    ("slider-crank-3d", dict(t_end=0.5), 51),
    ("viscoelastic-cantilever-3d", dict(t_end=0.05), 51),
]
LARGE = [("flying-spaghetti-2d", dict(n_elements=100_000, t_end=0.5), 6)]   # (--large: a frame of 23 or 17 MB)


def measure(name, overrides, frames):
    scene = load(name)
    p = scene.values({**overrides, "frames": frames})
    problem = scene.build(p, MPI.COMM_WORLD)
    spent = {"frames": 0.0, "pictures": 0.0}
    writer_cls = output.RunWriter

    def timed(key, fn):
        def wrapper(*args, **kw):
            t0 = time.perf_counter()
            try:
                return fn(*args, **kw)
            finally:
                spent[key] += time.perf_counter() - t0
        return wrapper

    class Writer(writer_cls):
        pass
    Writer.frame = timed("frames", writer_cls.frame)
    for part in ("_plots", "_view_script", "_pictures", "_energy_and_view"):   # (before 2026-11-25: the first two)
        if hasattr(writer_cls, part):
            setattr(Writer, part, timed("pictures", getattr(writer_cls, part)))
    hold = getattr(writer_cls, "hold", None)
    if hold is not None:    # the state kept for a frame between two levels: part of a frame's cost
        Writer.hold = timed("frames", hold)
    with tempfile.TemporaryDirectory() as tmp:
        od = output.OutDir(tmp, MPI.COMM_WORLD)
        with od.claimed({}):
            writer = Writer(od, problem, steps_for(p["dt"], p["t_end"]), frames, p["section"])
            t0 = time.perf_counter()
            result = run(problem, p["dt"], p["t_end"], writer=writer)
            total = time.perf_counter() - t0
            writer.finish({}, result)
        n = len(writer.frames)
        size = sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(tmp) for f in fs
                   if f.endswith(".vtp")) / n
    return dict(scene=name, frames=n, steps=len(result.rows) - 1, run_s=total,
                frame_ms=1e3 * spent["frames"] / n, pictures_ms=1e3 * spent["pictures"] / n, kb=size / 1e3)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "output.md"))
    ap.add_argument("--label", default="this commit")
    ap.add_argument("--large", action="store_true", help="the cases of LARGE instead (10^5 elements)")
    args = ap.parse_args()
    rows = [measure(*case) for case in (LARGE if args.large else CASES)]
    lines = ["| scene | frames | steps | frame (gather + .vtp) ms | pictures ms/frame | .vtp kB/frame |",
             "|---|---|---|---|---|---|"]
    lines += [f"| {r['scene']} | {r['frames']} | {r['steps']} | {r['frame_ms']:.2f} | {r['pictures_ms']:.1f} | "
              f"{r['kb']:.1f} |" for r in rows]
    text = f"### {args.label}\n\n" + "\n".join(lines) + "\n"
    print(text)
    with open(args.out, "w") as f:
        f.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
