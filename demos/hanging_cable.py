# # Hanging cable: a hyperelastic string swinging under gravity
#
# A string of reference length L hangs from a pin at the origin (z is up,
# gravity acts in -z).  It starts at rest in its own static equilibrium
# (stretched by its weight: the stretch grows towards the top), turned about
# the pin by the tilt angle (in the x-z plane), and then swings like a heavy
# chain; with vy0 != 0 the free end is also pushed out of that plane and the
# swing becomes 3D.
#
# Model: forms/string.py (state r, v, C = |d_s r|^2; H = kinetic + W(C)),
# materials: forms/string_materials.py.  Default data as in the authors'
# string examples (Kinon, Thoma, Betsch, Kotyczka): L = 1, EA = 20,
# rhoA = 1, g = 9.81, the logarithmic law W = EA/4 (C - ln C - 1), time
# stepping with the discrete gradient.
#
# What to look at: gravity is an input (a 'domain' load on v), so H does
# not contain the potential -r.b; the history column `supplied` is the work
# of gravity, and H - supplied (the total energy) stays constant: the
# discrete balance H_{n+1} - H_n = h y.u holds to solver tolerance at every
# step, for every material.  Compare with --set integrator=midpoint: for the
# logarithmic law the balance error jumps by orders of magnitude.
#
# Run it:  rodfem run hanging-cable --out results/hanging-cable
#          rodfem run hanging-cable --set material=tension-only --set vy0=2 --out results/hanging-3d

import sys

import numpy as np

from rodfem import Load, Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.demos._damping import damping
from rodfem.demos._string_statics import static_equilibrium
from rodfem.forms.string import MATERIALS, String, map_positions, rayleigh


# ## Parameters shared by the string scenes
#
# The material law is chosen by name; EA and rhoA must be positive: the
# scene rejects EA <= 0 or rhoA <= 0 with a one-line error before anything
# is built (and the model checks again).
def material_parameters(material="logarithmic", EA=20.0, rhoA=1.0):
    return [
        Parameter("material", material, "", "stored energy W(C) (forms/string_materials.py)",
                  choices=tuple(MATERIALS)),
        stiffness("EA", EA, "N", "axial stiffness (small-strain), W''(1) = EA/4"),
        stiffness("rhoA", rhoA, "kg/m", "mass per reference length"),
    ]


def string_model(p, end_masses=None):
    """The String of p (material, EA, rhoA; tau_kv and rayleigh_alpha if the scene has them)."""
    kv = damping(p, rayleigh, p["EA"]) if "tau_kv" in p else None
    return String(MATERIALS[p["material"]](EA=p["EA"]), p["rhoA"], end_masses=end_masses, damping=kv)


def hanging_guess(p, tip_mass=0.0):
    """A straight vertical line with the linearised stretch of the top element (all in tension)."""
    N_top = p["g"] * (p["rhoA"] * p["L"] + tip_mass)
    lam = 1.0 + N_top / p["EA"]
    return lambda x: np.vstack([0 * x[0], 0 * x[0], -lam * x[0]])


parameters = common(n_elements=10, dt=0.01, t_end=3.0, integrator="discrete-gradient") + material_parameters() + [
    stiffness("L", 1.0, "m", "reference (unstretched) length"),
    Parameter("g", 9.81, "m/s^2", "gravity, acting in -z", low=0),
    Parameter("angle", 30.0, "deg", "initial tilt of the cable about the pin (0 = hanging still)",
              low=-180, high=180),
    Parameter("vy0", 0.0, "m/s", "initial out-of-plane (y) velocity of the free end (linear along s)"),
]


def build(p, comm):
    # The port of gravity: a force per length rhoA g (0, 0, -1) on the whole
    # string, paired with the velocity v.  The top end s = 0 is pinned.
    loads = [Load("v", [0.0, 0.0, -p["rhoA"] * p["g"]], "domain", "gravity")] if p["g"] > 0 else []
    problem = Problem(string_model(p), p["L"], p["n_elements"], loads=loads,
                      supports=[Support("left", "pinned")], initial={"r": hanging_guess(p)},
                      integrator=p["integrator"], comm=comm)
    # Start from the discrete static equilibrium of the vertical cable (with
    # g = 0 the unstretched straight line), turned about the pin by `angle`:
    # C is unchanged by the rotation, v = 0 except for the optional push.
    if p["g"] > 0:
        static_equilibrium(problem)
    a = np.radians(p["angle"])
    R = np.array([[np.cos(a), 0.0, -np.sin(a)], [0.0, 1.0, 0.0], [np.sin(a), 0.0, np.cos(a)]])  # -e_z -> (sin a, 0, -cos a)
    map_positions(problem, lambda pos: pos @ R.T)
    if p["vy0"] != 0:
        problem.space.assign(problem.x0, "v", lambda x: np.vstack([0 * x[0], p["vy0"] * x[0] / p["L"], 0 * x[0]]))
        problem.x1.x.array[:] = problem.x0.x.array
    return problem


scene = Scene("hanging-cable", "hyperelastic string pinned at the top, swinging under gravity from a tilt angle",
              parameters, build,
              notes="H excludes the gravity potential: gravity is an input, its work is the column 'supplied'.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
