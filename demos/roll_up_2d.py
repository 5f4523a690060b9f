# # Roll-up of a cantilever (planar, static)
#
# A straight cantilever of length L, clamped at s = 0, is bent by an end
# moment M(t) = (t / t_end) 2 pi EI / L.  At t_end the exact solution is a
# full circle of radius L / (2 pi): the tip returns to the clamp and has
# turned by 2 pi.  (Kinon, Betsch & Eugster 2025; Simo & Vu-Quoc 1986.)
# `--set turns=k` multiplies the moment by k: k circles of radius L/(2 pi k).
#
# Statics through the same integrator: the densities are zero (rhoA = rhoI =
# 0), so each midpoint step is the static equilibrium of the midpoint state
# under the load at t_{n+1/2}: load-stepped statics, as in the authors' code.
# The ramp must be smooth in t (a sudden load would make the end states
# alternate around equilibrium).
#
# Run it:  rodfem run roll-up-2d --out results/roll-up-2d

import sys

import numpy as np

from rodfem import Load, Problem, Support, ramp
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, density, stiffness
from rodfem.demos._planar import beam, material_parameters

parameters = common(n_elements=10, dt=0.01, t_end=1.0) + material_parameters() + [
    stiffness("L", 10.0, "m", "length"),
    stiffness("EA", 1e4, "N", "axial stiffness"),
    stiffness("GA", 1e4, "N", "shear stiffness"),
    stiffness("EI", 500.0, "N m^2", "bending stiffness"),
    density("rhoA", 0.0, "kg/m", "mass per length (0: statics)"),
    density("rhoI", 0.0, "kg m", "rotary inertia per length (0: statics)"),
    Parameter("turns", 1.0, "", "end moment 2 pi turns EI/L: the beam rolls into `turns` circles", low=0),
]


def build(p, comm):
    moment = 2 * np.pi * p["turns"] * p["EI"] / p["L"]
    loads = [Load("omega", ramp(moment, p["t_end"]), "right", "end moment")]
    initial = {"r": lambda x: np.vstack([x[0], 0 * x[0]])}
    return Problem(beam(p), p["L"], p["n_elements"], loads=loads, supports=[Support("left", "clamped")],
                   initial=initial, integrator=p["integrator"], comm=comm)


def reference(p):
    """Exact circle at t_end (pure bending: no axial or shear strain), radius R = L/(2 pi turns):
    tip at R (sin 2 pi turns, 1 - cos 2 pi turns), i.e. back at the clamp for whole turns."""
    if p["rhoA"] != 0 or p["rhoI"] != 0:
        return None
    theta = 2 * np.pi * p["turns"]
    R = p["L"] / theta if theta else np.inf
    tip = (R * np.sin(theta), R * (1 - np.cos(theta))) if theta else (p["L"], 0.0)
    return {"tip_x": float(tip[0]), "tip_y": float(tip[1]), "scale": p["L"]}


scene = Scene("roll-up-2d", "cantilever rolled into a full circle by an end moment 2 pi EI/L (static)",
              parameters, build, reference=reference)

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
