# # Flying spaghetti (planar)
#
# A free beam of length L = 10 lies straight from (0, 8) to (6, 0).  At the
# (6, 0) end a force (8, 0) and a moment -80 act for t <= 2.5 and then stop;
# the beam tumbles freely through the plane.  Data: Simo & Vu-Quoc (1988) as
# used by Kinon, Betsch & Eugster (2025), whose reference code holds the load
# constant on (0, 2.5] (a step, not the classical hat).
#
# What to look at: after t = 2.5 no load acts, so H, the momentum p and the
# angular momentum L_z must stay constant (columns of history.csv), and the
# discrete energy balance H_{n+1} - H_n = h y.u holds at every step.
#
# Run it:  rodfem run flying-spaghetti-2d --out results/flying-spaghetti-2d
#     or:  python demos/flying_spaghetti_2d.py --out results/flying-spaghetti-2d

import sys

import numpy as np

from rodfem import Load, Problem, constant_in_time
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, density, stiffness
from rodfem.demos._planar import beam, material_parameters

# ## Parameters (all can be changed with --set NAME=VALUE)
parameters = common(n_elements=10, dt=0.1, t_end=15.0) + material_parameters() + [
    stiffness("EA", 1e4, "N", "axial stiffness"),
    stiffness("GA", 1e4, "N", "shear stiffness"),
    stiffness("EI", 100.0, "N m^2", "bending stiffness"),
    density("rhoA", 1.0, "kg/m", "mass per length"),
    density("rhoI", 10.0, "kg m", "rotary inertia per length"),
    Parameter("Fx", 8.0, "N", "end force, x"),
    Parameter("Fy", 0.0, "N", "end force, y"),
    Parameter("M", -80.0, "N m", "end moment"),
    Parameter("t_load", 2.5, "s", "the end load acts for t <= t_load", low=0),
]

START, END = np.array([0.0, 8.0]), np.array([6.0, 0.0])
LENGTH = float(np.linalg.norm(END - START))


def build(p, comm):
    # The straight initial beam: r(s) = START + s/L (END - START), phi = angle of the tangent.
    direction = (END - START) / LENGTH
    phi0 = np.arctan2(direction[1], direction[0])
    initial = {
        "r": lambda x: START[:, None] + np.outer(direction, x[0]),
        "phi": lambda x: np.full(x.shape[1], phi0),
    }
    # The ports: force and moment at the end s = L (the (6, 0) end), paired
    # with the end velocity v(L) and angular velocity omega(L).  No support:
    # the body is free, so the history also gets p_x, p_y, L_z.
    loads = [
        Load("v", constant_in_time([p["Fx"], p["Fy"]], until=p["t_load"]), "right", "end force"),
        Load("omega", constant_in_time(p["M"], until=p["t_load"]), "right", "end moment"),
    ]
    return Problem(beam(p), LENGTH, p["n_elements"], loads=loads, initial=initial,
                   integrator=p["integrator"], comm=comm)


scene = Scene("flying-spaghetti-2d", "free planar beam tumbling after a short end force and moment",
              parameters, build)

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
