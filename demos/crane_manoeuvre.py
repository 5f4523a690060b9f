# # Crane manoeuvre: a hanging cable with a load, driven at the top
#
# The harbour-crane situation of Kinon et al. (PAMM 2023): a cable of reference length L
# hangs from a trolley at the origin (z is up, gravity in -z) and carries a
# load of mass m at its lower end.  The trolley rides on a horizontal rail:
# its vertical position is fixed (support 'fix-z'), and it is pushed along x
# by a force input F(t) = F0 sin(2 pi t / t_move) for t <= t_move, zero
# after -- accelerate, then brake, the "left-to-right manoeuvre" of the
# authors (IFAC 2024: F = rhoA sin(pi t / 2) for t <= 4, EA = 20, rhoA = 1,
# h = 0.05, T = 6, starting from the static equilibrium).
#
# The ports of this scene:
#   * the trolley force (input F at s = 0, output the trolley velocity),
#   * gravity on the cable (input rhoA g per length, output v),
#   * gravity on the load (input m g at s = L, output the load velocity);
# the load's kinetic energy 1/2 m |v(L)|^2 is part of H (a lumped end mass of
# the model), a trolley mass is optional.  The balance
# H_{n+1} - H_n = h y.u holds at every step; H - supplied is constant.
#
# Run it:  rodfem run crane-manoeuvre --out results/crane-manoeuvre

import sys

import numpy as np

from rodfem import Load, Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.demos._string_statics import static_equilibrium
from rodfem.demos.hanging_cable import hanging_guess, material_parameters, string_model

parameters = common(n_elements=10, dt=0.05, t_end=6.0, integrator="discrete-gradient") + material_parameters() + [
    stiffness("L", 1.0, "m", "reference (unstretched) cable length"),
    Parameter("g", 9.81, "m/s^2", "gravity, acting in -z", low=0),
    Parameter("tip_mass", 0.5, "kg", "mass of the load at the lower end", low=0),
    Parameter("trolley_mass", 0.0, "kg", "mass of the trolley at the top (0: the cable's top node only)", low=0),
    Parameter("F0", 1.0, "N", "amplitude of the trolley force"),
    Parameter("t_move", 4.0, "s", "the force F0 sin(2 pi t/t_move) acts for t <= t_move", low=0, low_open=True),
]


def trolley_force(p):
    def u(t):
        f = p["F0"] * np.sin(2 * np.pi * t / p["t_move"]) if t <= p["t_move"] else 0.0
        return np.array([f, 0.0, 0.0])
    return u


def build(p, comm):
    m = p["tip_mass"]
    loads = [Load("v", trolley_force(p), "left", "trolley force")]
    if p["g"] > 0:
        loads.append(Load("v", [0.0, 0.0, -p["rhoA"] * p["g"]], "domain", "gravity"))
        if m > 0:
            loads.append(Load("v", [0.0, 0.0, -m * p["g"]], "right", "load weight"))
    model = string_model(p, end_masses={"left": p["trolley_mass"], "right": m})
    problem = Problem(model, p["L"], p["n_elements"], loads=loads, supports=[Support("left", "fix-z")],
                      initial={"r": hanging_guess(p, m)}, integrator=p["integrator"], comm=comm)
    # Start at rest in the static equilibrium under gravity (F(0) = 0); for
    # the static solve the trolley is held (pinned), otherwise the rigid
    # horizontal motion would make the static problem singular.
    if p["g"] > 0:
        static_equilibrium(problem, supports=[Support("left", "pinned")])
    return problem


scene = Scene("crane-manoeuvre", "hanging cable with an end load; its top is pushed along a horizontal rail",
              parameters, build,
              notes="H excludes the gravity potential: gravity is an input, its work is the column 'supplied'.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
