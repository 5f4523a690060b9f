"""Screenshots of runs opened in ParaView through the view.py every run writes (rodfem/io/paraview.py).

    .venv/bin/python benchmarks/bench_paraview.py      # needs ParaView's pvbatch (apt: paraview,
                                                        # python3-paraview, xvfb); not in install-deps

For each case the scene runs (rodfem run) into a temporary directory, then `pvbatch view.py
--screenshot` renders one frame to benchmarks/paraview_<name>.png, headless (each in its own
`xvfb-run -a` when there is no display); the table in
benchmarks/paraview.md says what each shows and how long ParaView took.  Without pvbatch it says so
and exits 2.  Run from the repository root.
"""
import os
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
CASES = [  # name, scene, --set parameters, view.py options, what it shows
    ("flying_spaghetti_3d", "flying-spaghetti-3d", ["frames=76"], ["--time", "2.4", "--array", "strain_from_M",
                                                                   "--component", "2"],
     "3D flying spaghetti at t = 2.4 s, coloured by the bending strain C_M3 M3 (1/m), range over all frames"),
    ("flying_spaghetti_3d_axial", "flying-spaghetti-3d", ["frames=76"], ["--time", "2.4"],
     "the same, coloured by the axial strain C_N1 N1 (the default array): smooth, no node-to-node zig-zag"),
    ("slider_crank", "slider-crank-3d", ["frames=51"], ["--time", "1.5"],
     "slider crank at t = 1.5 s: crank and connecting rod as bars between their joints, the slider block, "
     "the joints as spheres, the guide as a line from its ground point; one colour per body"),
    ("four_bar", "four-bar-2d", ["frames=51"], ["--time", "1.0"],
     "flexible four-bar at t = 1.0 s (its reference time, now a frame): three beams with their 5 cm square "
     "section, one colour per body, the pins and ground pivots as spheres"),
    ("soft_arm", "soft-arm-swing", ["frames=31"], [],
     "soft arm at t_end: the physical section (R_out = 8 mm, marker fin along d2), coloured by the axial strain"),
]


def main():
    pvbatch = shutil.which("pvbatch") or shutil.which("pvpython")
    if not pvbatch:
        print("bench_paraview: ParaView's pvbatch is not installed (apt-get install paraview python3-paraview xvfb)")
        return 2
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}   # ParaView's own Python modules
    xvfb = ["xvfb-run", "-a"] if not os.environ.get("DISPLAY") and shutil.which("xvfb-run") else []
    rows = []
    for name, scene, sets, options, what in CASES:
        with tempfile.TemporaryDirectory() as out:
            args = [sys.executable, "-m", "rodfem", "run", scene, "--quiet", "--out", out]
            for s in sets:
                args += ["--set", s]
            subprocess.run(args, check=True)
            png = os.path.join(HERE, f"paraview_{name}.png")
            t0 = time.perf_counter()
            subprocess.run([*xvfb, pvbatch, os.path.join(out, "view.py"), "--screenshot", png, "--size", "900x600", *options],
                           check=True, env=env, cwd=out, stderr=subprocess.DEVNULL)
            rows.append((name, what, time.perf_counter() - t0, os.path.getsize(png)))
            print(f"{name}: {rows[-1][2]:.1f} s", flush=True)
    lines = ["# ParaView screenshots (benchmarks/bench_paraview.py)", "",
             "Each run's view.py opened headless by `pvbatch view.py --screenshot` (ParaView 5.11, xvfb).", "",
             "| file | what it shows | pvbatch s |", "|---|---|---|"]
    lines += [f"| paraview_{n}.png | {w} | {s:.1f} |" for n, w, s, _ in rows]
    with open(os.path.join(HERE, "paraview.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
