"""view.py: a ParaView script written with every run, that opens the run as a rod user wants to see it.

    paraview --script=view.py                    # the motion in the ParaView window (Play)
    pvbatch view.py --screenshot run.png --time 2.4 [--array strain_from_M --component 2]

(`pvpython` instead of `pvbatch` works the same; headless: `xvfb-run -a pvbatch ...`.)  It loads
surface.pvd (the bodies' surfaces, one block per body) and joints.pvd (the joints and supports as
spheres), colours by the run's default array (a rod's or string's first strain, its first
component) with the colour range over ALL frames (`RUN["ranges"]`, computed from the files), or
per body with one colour each (a system of rigid bodies, or ``--array blocks``), sets the camera to
the box of the whole motion of the centrelines (a planar motion seen from +z), and plays the frames at their times.
The run's facts are the `RUN` literal at the top of the script (ranges, bounds, default array).
"""
import os

import numpy as np

from rodfem.io.vtk import read_pvd, read_vtp

SCRIPT = '''"""ParaView view of this rodfem run (written by rodfem, rodfem/io/paraview.py).

    paraview --script=view.py
    pvbatch view.py --screenshot run.png [--time T] [--array NAME|blocks] [--component K]
"""
import argparse
import os
import sys

from paraview.simple import (ColorBy, GetActiveViewOrCreate, GetAnimationScene, GetColorTransferFunction,
                             GetScalarBar, PVDReader, Render, SaveScreenshot, Show)

RUN = {run!r}

here = os.path.dirname(os.path.abspath(__file__))
args = argparse.ArgumentParser()
args.add_argument("--screenshot")
args.add_argument("--time", type=float)
args.add_argument("--array", default=RUN["array"])
args.add_argument("--component", type=int, default=RUN["component"])
args.add_argument("--size", default="1200x800")
a = args.parse_args([x for x in sys.argv[1:] if x != "--"])
view = GetActiveViewOrCreate("RenderView")
view.OrientationAxesVisibility = 1
surface = PVDReader(FileName=os.path.join(here, "surface.pvd"))
shown = Show(surface, view)
if a.array in RUN["ranges"]:
    where, lo, hi = RUN["ranges"][a.array][a.component if a.component is not None else 0]
    ColorBy(shown, (where, a.array, RUN["components"][a.array][a.component]) if RUN["components"][a.array]
            else (where, a.array))
    lut = GetColorTransferFunction(a.array)
    lut.RescaleTransferFunction(lo, hi if hi > lo else lo + 1e-12)
    lut.AutomaticRescaleRangeMode = "Never"
    shown.SetScalarBarVisibility(view, True)
    sb = GetScalarBar(lut, view)      # its title: the array, its unit, the component
    sb.Title = a.array + " [" + RUN["units"].get(a.array, "") + "]"
    sb.ComponentTitle = RUN["components"][a.array][a.component] if RUN["components"][a.array] else ""
    sb.Orientation, sb.WindowLocation, sb.ScalarBarLength = "Horizontal", "Lower Center", 0.4
    sb.TitleFontSize, sb.LabelFontSize = 14, 12
else:
    ColorBy(shown, ("FIELD", "vtkBlockColors"))
if RUN["joints"]:
    joints = PVDReader(FileName=os.path.join(here, "joints.pvd"))
    dots = Show(joints, view)
    ColorBy(dots, None)
    dots.AmbientColor = dots.DiffuseColor = [0.05, 0.05, 0.05]
    dots.PointSize = 10.0
    dots.RenderPointsAsSpheres = 1
    dots.LineWidth = 2.0
scene = GetAnimationScene()
scene.UpdateAnimationUsingDataTimeSteps()
lo, hi = RUN["bounds"]
centre = [0.5 * (u + v) for u, v in zip(lo, hi)]
size = max(max(v - u for u, v in zip(lo, hi)), 1e-9) * 1.2
view.CameraFocalPoint = centre
view.CameraPosition = ([centre[0], centre[1], centre[2] + 3 * size] if RUN["planar"] else
                       [centre[0] + 1.6 * size, centre[1] - 2.2 * size, centre[2] + 1.4 * size])
view.CameraViewUp = [0, 1, 0] if RUN["planar"] else [0, 0, 1]
view.CameraParallelProjection = 1 if RUN["planar"] else 0
view.CameraParallelScale = 0.6 * size
if a.screenshot:
    scene.AnimationTime = RUN["times"][-1] if a.time is None else a.time
    w, h = (int(x) for x in a.size.split("x"))
    Render(view)
    SaveScreenshot(a.screenshot, view, ImageResolution=[w, h])
'''


def run_facts(out, default=None):
    """What view.py needs of the run in directory `out`, read back from its files: the colour ranges
    of every array over all frames (per component), the bounds of the motion, the times, the default
    array, whether the motion is planar and whether there are joints."""
    ranges, comps, bounds, times = {}, {}, [np.full(3, np.inf), np.full(3, -np.inf)], []
    first_cell = None
    for t, _, f, _ in read_pvd(os.path.join(out, "centreline.pvd")):
        points = read_vtp(os.path.join(out, f)).points
        if t not in times:
            times.append(t)
        if len(points):
            bounds = [np.minimum(bounds[0], points.min(axis=0)), np.maximum(bounds[1], points.max(axis=0))]
    for t, _, f, _ in read_pvd(os.path.join(out, "surface.pvd")):
        poly = read_vtp(os.path.join(out, f))
        for where, data in (("POINTS", poly.point_data), ("CELLS", poly.cell_data)):
            for name, arr in data.items():
                v = arr.values.reshape(len(arr.values), -1)
                if not len(v):
                    continue
                if where == "CELLS" and first_cell is None:
                    first_cell = name
                comps[name] = list(arr.components)
                old = ranges.get(name, [(where, np.inf, -np.inf)] * v.shape[1])
                ranges[name] = [(where, min(o[1], float(v[:, k].min())), max(o[2], float(v[:, k].max())))
                                for k, o in enumerate(old)]
    span = float(np.max(bounds[1] - bounds[0])) if np.all(np.isfinite(bounds[0])) else 1.0
    planar = bool(np.isfinite(span) and bounds[1][2] - bounds[0][2] <= 1e-9 * max(span, 1e-300) + 1e-300)
    array = default if default is not None else (first_cell or "blocks")
    return {"ranges": ranges, "components": comps, "bounds": [bounds[0].tolist(), bounds[1].tolist()],
            "times": times, "array": array, "component": 0, "planar": planar,
            "joints": os.path.isfile(os.path.join(out, "joints.pvd"))}


def write_script(path, facts, units):
    """view.py at `path` with the run's `facts` (run_facts) and {array: unit}."""
    run = dict(facts, units=units)
    with open(path, "w") as f:
        f.write(SCRIPT.format(run=run))
