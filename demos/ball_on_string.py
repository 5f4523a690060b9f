# # A ball dropped on a taut string: contact of a rigid body's sphere with a string
#
# A string (forms/string.py, Biot's material N = EA (lambda - 1), reference length L, pinned at its
# ends `stretch` L apart: the tension T_0 = EA (stretch - 1)) is taut along x.  A ball (a point mass
# M carrying a sphere of radius R_s) falls under gravity from `drop` above it, lands on the string's
# centre, and bounces on it.  The string itself has no weight here (its line density rhoA gives it
# inertia only), so its rest state is straight.
#
# ## The contact (forms/rod_contact.py, rodfem/core/bodycontact.py)
#
# The sphere about the ball's position x touches the tube of radius r about the string's centreline:
# for each segment of the centreline the gap is g = |x - y(b)| - (R_s + r), y(b) the segment's point
# closest to x (the sphere's centre is the segment of zero length [x, x] of the rod-rod contact's
# segment pairs), and the stored energy is the cubic penalty k/3 <-g>^3 summed over the segments.
# Its discrete gradient (Gonzalez's, projected off the rigid motions with x as a node) makes the
# contact's work in every step exactly the change of its energy, so with gravity's work as the
# supplied energy
#
#   * H_{n+1} - H_n = supplied to round-off (`balance_error`);
#   * the force acts through the ball's centre (a rigid body's rotation would not feel it).
#
# The penalty k is chosen so that the ball, stopped by a rigid string, would penetrate
# `penetration`: 1/2 M v^2 = k d^3 / 3 with v the landing speed sqrt(2 g drop).
#
# ## The rest state (the ball would settle there with damping)
#
# At rest each half of the string is straight: 2 T sin(theta) = M g with T = EA (lambda - 1) and
# lambda = stretch / cos(theta) (root finding), the kink sag_rest = stretch L/2 tan(theta) below the
# ends; the ball's centre (R_s + r) / cos(theta) above the kink (column z_rest; tests/models/
# test_rigid_rod_contact.py checks the static sag against this answer).  Without damping the ball
# bounces about it for ever.
#
# Run it:  rodfem run ball-on-string --out results/ball-on-string
#          rodfem run ball-on-string --set M=0.2 --set drop=0.05 --out results/ball-on-string-heavy

import sys

import numpy as np
from scipy.optimize import brentq

from rodfem import Load, Support, System
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.forms.rigid_body import PointMass
from rodfem.forms.rod_contact import RodContact
from rodfem.forms.string import String
from rodfem.forms.string_materials import biot

parameters = common(n_elements=16, dt=1e-3, t_end=0.5, integrator="discrete-gradient") + [
    stiffness("L", 1.0, "m", "reference length of the string"),
    Parameter("stretch", 1.01, "", "distance of the pinned ends / L (> 1: taut)", low=1, low_open=True),
    stiffness("EA", 1000.0, "N", "axial stiffness of the string"),
    stiffness("rhoA", 0.01, "kg/m", "line density of the string"),
    stiffness("r", 0.002, "m", "radius of the string's tube"),
    stiffness("M", 0.05, "kg", "mass of the ball"),
    stiffness("R_s", 0.03, "m", "radius of the ball"),
    stiffness("drop", 0.02, "m", "height of the ball's lowest point above the string's surface at the start"),
    stiffness("g", 9.81, "m/s^2", "gravity (on the ball)"),
    stiffness("penetration", 1e-3, "m", "penetration of the landing on a rigid string (sets the penalty k)"),
]


def rest(p):
    """(theta, sag of the kink, the ball centre's height z_rest) of the string at rest under the ball."""
    half = 0.5 * p["stretch"] * p["L"]
    weight = p["M"] * p["g"]
    theta = brentq(lambda t: 2 * p["EA"] * (p["stretch"] / np.cos(t) - 1) * np.sin(t) - weight, 0.0, 1.5, xtol=1e-15)
    sag = half * np.tan(theta)
    return theta, sag, (p["R_s"] + p["r"]) / np.cos(theta) - sag


def build(p, comm):
    L, stretch = p["L"], p["stretch"]
    system = System(integrator=p["integrator"], comm=comm, newton_options={"snes_atol": 1e-12, "snes_max_it": 40})
    # ## The string: straight along x, centred at the origin, pinned at both ends
    string = system.add("string", String(biot(EA=p["EA"]), p["rhoA"]), L, p["n_elements"],
                        initial={"r": lambda x: np.vstack([stretch * (x[0] - 0.5 * L), 0 * x[0], 0 * x[0]]),
                                 "v": lambda x: np.zeros((3, x.shape[1]))},
                        supports=[Support("left", "pinned"), Support("right", "pinned")])
    # ## The ball: a point mass with its weight, above the string's centre
    z0 = p["r"] + p["R_s"] + p["drop"]
    ball = system.add("ball", PointMass(p["M"]), initial=PointMass.initial((0.0, 0.0, z0)),
                      loads=[Load("v", [0.0, 0.0, -p["M"] * p["g"]], "domain", "weight")])
    # ## The contact: columns hit.N (normal force), hit.Fn_x, _y, _z (on the string), hit.penetration
    k = 1.5 * p["M"] * 2 * p["g"] * p["drop"] / p["penetration"] ** 3
    system.contact(RodContact(k, p["r"], radius_b=p["R_s"]), string, ball, name="hit")
    system.marker("ball", ball.point())
    z_rest = rest(p)[2]
    system.record(lambda s: {"z_rest": z_rest})
    return system


scene = Scene("ball-on-string", "a ball dropped on a taut string bounces on it (contact of a rigid body's sphere "
              "with a string): the energy balance exact through the contact",
              parameters, build,
              notes="H - supplied constant to round-off (balance_error); ball_z bounces about z_rest, the "
                    "ball's height at rest on the string (two straight halves, exact).")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
