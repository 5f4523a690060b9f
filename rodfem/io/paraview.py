"""view.py: a ParaView script written with every run, that opens the run as a rod user wants to see it.

    paraview --script=view.py                    # the motion in the ParaView window (Play)
    pvbatch view.py --screenshot run.png --time 2.4 [--array strain_from_M --component 2]

(`pvpython` instead of `pvbatch` works the same; headless: `xvfb-run -a pvbatch ...`.)  It loads
surface.pvd (the bodies' surfaces, one block per body) and joints.pvd (the joints and supports as
spheres), colours by the run's default array (a rod's or string's first strain, its first
component) with the colour range over ALL frames (`RUN["ranges"]`, gathered as the frames are written), or
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


class RunFacts:
    """What view.py needs of a run, gathered frame by frame: the box of the centrelines' motion, the
    frames' times, every surface array's range per component (and where it lives: POINTS or CELLS), the
    first cell array met.  The writer adds each frame as it writes it (rodfem/io/output.py); `run_facts`
    reads them back from the files (a run resumed from a checkpoint: the frames before it)."""

    def __init__(self):
        self.ranges, self.comps, self.times, self.first_cell = {}, {}, [], None
        self.bounds = [np.full(3, np.inf), np.full(3, -np.inf)]

    def centreline(self, t, points):
        """A centreline file of the frame at time t (its points)."""
        if t not in self.times:
            self.times.append(t)
        if len(points):
            self.bounds = [np.minimum(self.bounds[0], points.min(axis=0)), np.maximum(self.bounds[1], points.max(axis=0))]

    def surface(self, poly):
        """A surface file (PolyData): the ranges of its point and cell arrays."""
        for where, data in (("POINTS", poly.point_data), ("CELLS", poly.cell_data)):
            for name, arr in data.items():
                v = np.asarray(arr.values).reshape(len(arr.values), -1)
                if not len(v):
                    continue
                if where == "CELLS" and self.first_cell is None:
                    self.first_cell = name
                self.comps[name] = list(arr.components)
                old = self.ranges.get(name, [(where, np.inf, -np.inf)] * v.shape[1])
                self.ranges[name] = [(where, min(o[1], float(v[:, k].min())), max(o[2], float(v[:, k].max())))
                                     for k, o in enumerate(old)]

    def facts(self, default=None, joints=False):
        """The `RUN` literal of view.py: ranges, components, bounds, times, the default array (`default`, else
        the first cell array, else blocks), whether the motion is planar and whether joints.pvd is there."""
        bounds = self.bounds
        span = float(np.max(bounds[1] - bounds[0])) if np.all(np.isfinite(bounds[0])) else 1.0
        planar = bool(np.isfinite(span) and bounds[1][2] - bounds[0][2] <= 1e-9 * max(span, 1e-300) + 1e-300)
        array = default if default is not None else (self.first_cell or "blocks")
        return {"ranges": dict(self.ranges), "components": dict(self.comps),
                "bounds": [bounds[0].tolist(), bounds[1].tolist()], "times": list(self.times), "array": array,
                "component": 0, "planar": planar, "joints": bool(joints)}


def run_facts(out, default=None):
    """RunFacts.facts of the run in directory `out`, read back from its files (centreline.pvd, surface.pvd)."""
    facts = RunFacts()
    for t, _, f, _ in read_pvd(os.path.join(out, "centreline.pvd")):
        facts.centreline(t, read_vtp(os.path.join(out, f)).points)
    for _, _, f, _ in read_pvd(os.path.join(out, "surface.pvd")):
        facts.surface(read_vtp(os.path.join(out, f)))
    return facts.facts(default, os.path.isfile(os.path.join(out, "joints.pvd")))


def write_script(path, facts, units):
    """view.py at `path` with the run's `facts` (run_facts) and {array: unit}."""
    run = dict(facts, units=units)
    with open(path, "w") as f:
        f.write(SCRIPT.format(run=run))
