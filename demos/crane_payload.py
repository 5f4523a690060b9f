# # Crane with a rigid payload: a hanging cable carrying a box, driven at the top
#
# The crane of `crane-manoeuvre` (a hyperelastic cable of reference length
# L = 1 hanging from a trolley at the origin, z up, gravity in -z; the
# trolley rides on a horizontal rail, its height fixed by the support
# 'fix-z', and is pushed along x by F(t) = F0 sin(2 pi t / t_move) for
# t <= t_move: accelerate, then brake) -- but the load at the lower end is
# no longer a lumped end mass of the string: it is a 3D RIGID BODY, a box of
# mass m and sides (a, b, c), hooked at the centre of its top face.
#
# Two components, one joint:
# * the string (forms/string.py: r, v, C = |d_s r|^2 on [0, L], the
#   logarithmic law of the authors' string examples, EA = 20, rhoA = 1);
# * the payload, the director-based rigid body of forms/rigid_body.py
#   (centre of mass x, directors d1, d2, d3 along the box's edges, constant
#   mass matrix diag(m, E_1, E_2, E_3), six orthonormality multipliers);
# * a SPHERICAL joint between the string's end r(L) and the hook point
#   x + (c/2) d3 of the box: x_hook - r(L) = 0, three multipliers lambda,
#   the hook force.  The hook point is linear in the box's coordinates
#   (x, d3), so the joint is a linear constraint: it holds to round-off, and
#   its reaction G^T lambda does no work -- the string and the body exchange
#   power only through the joint, and that exchange sums to zero.
#
# The ports: the trolley force (input F at s = 0, output the trolley
# velocity) and gravity on the cable (rhoA g per length) and on the box
# (m g, output the velocity of its centre).  H = the kinetic energy of both
# bodies + W(C) of the cable; gravity's work is the supplied work, so
# H - supplied is the constant total energy after t_move and the balance
# H_{n+1} - H_n = h y.u holds at every step (the discrete gradient for the
# cable's logarithmic law; H of the box is quadratic).
#
# At t = 0 everything is at rest in the static equilibrium: the cable hangs
# vertically, stretched by its own weight and the box's (solved with the box
# weight as an end force, the trolley held), and the box hangs below the
# hook with its centre of mass on the vertical through it.  An optional spin
# turns the box about that vertical (its axis d3 through hook and centre:
# the joint allows it, and the spin about the largest principal axis is
# stable).  When the trolley moves, cable and box swing like a double
# pendulum: the box tilts against the cable, and with spin the swing is
# pulled out of the x-z plane by the box's gyroscopic moment.
#
# What to look at: `payload_x, _y, _z` (the box's centre), `hook_x, ...`
# (the cable's end), `trolley_x, ...` (its top), `payload_tilt` (the angle between d3 and the vertical,
# degrees), `payload_yaw` (the angle of d1 about the vertical, degrees),
# `hook.lambda1..3` (the hook force, N), `constraint_residual` (the joint's
# gap |x_hook - r(L)|, round-off: the joint is linear) and `orthonormality`
# (max |R^T R - I| of the box: its rows are bilinear, so each step leaves it
# off by about h times Newton's tolerance |F| <= 1e-10; 3e-11 after 120 steps).
#
# Run it:  rodfem run crane-payload --out results/crane-payload
#          rodfem run crane-payload --set spin=0 --set F0=2   (a planar swing)

import sys
from types import SimpleNamespace

import numpy as np

from rodfem import Load, Support, System
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.demos._multibody import nodal, orthonormality, rigid_frame
from rodfem.demos._string_statics import static_equilibrium
from rodfem.demos.crane_manoeuvre import trolley_force
from rodfem.demos.hanging_cable import hanging_guess, material_parameters, string_model
from rodfem.forms import joints
from rodfem.forms.rigid_body import RigidBody

parameters = common(n_elements=10, dt=0.05, t_end=6.0, integrator="discrete-gradient") + material_parameters() + [
    stiffness("L", 1.0, "m", "reference (unstretched) cable length"),
    Parameter("g", 9.81, "m/s^2", "gravity, acting in -z", low=0),
    stiffness("mass", 0.5, "kg", "mass of the payload"),
    stiffness("a", 0.3, "m", "payload box: side along d1 (x at t = 0)"),
    stiffness("b", 0.2, "m", "payload box: side along d2 (y at t = 0)"),
    stiffness("c", 0.1, "m", "payload box: height along d3 (z at t = 0); the hook is at the top face's centre"),
    Parameter("spin", 1.0, "rad/s", "initial spin of the box about the vertical"),
    Parameter("trolley_mass", 0.0, "kg", "mass of the trolley at the top (0: the cable's top node only)", low=0),
    Parameter("F0", 1.0, "N", "amplitude of the trolley force"),
    Parameter("t_move", 4.0, "s", "the force F0 sin(2 pi t/t_move) acts for t <= t_move", low=0, low_open=True),
]


def box_inertia(m, a, b, c):
    """Principal moments of inertia of a box about its centre, along the sides a, b, c."""
    return m / 12.0 * np.array([b**2 + c**2, a**2 + c**2, a**2 + b**2])


def hang(body, p):
    """Put the cable `body` at rest in its static equilibrium under its weight and the payload's:
    its own loads plus the payload weight m g as an end force, the trolley held (pinned) for
    this solve (demos/_string_statics.py, static_equilibrium: then x_{n+1} = x_n, v = 0 solves the step)."""
    weight = Load("v", [0.0, 0.0, -p["mass"] * p["g"]], "right", "payload weight (static)")
    static_equilibrium(SimpleNamespace(**{**vars(body), "loads": [*body.loads, weight]}),
                       supports=[Support("left", "pinned")])


def payload_columns(system):
    """History columns of the box: tilt of d3 from the vertical, yaw of d1 about it, |R^T R - I|."""
    box = system.body("payload")
    _, R = rigid_frame(box)
    tilt = np.degrees(np.arccos(np.clip(R[2, 2], -1.0, 1.0)))
    yaw = np.degrees(np.arctan2(R[1, 0], R[0, 0]))
    return {"payload_tilt": tilt, "payload_yaw": yaw, "orthonormality": orthonormality(box)}


def build(p, comm):
    crane = System(integrator=p["integrator"], comm=comm)
    crane.record(payload_columns)
    m, c = p["mass"], p["c"]

    # ## The cable: the trolley force at the top (its height held by the rail), gravity along it
    loads = [Load("v", trolley_force(p), "left", "trolley force")]
    if p["g"] > 0:
        loads.append(Load("v", [0.0, 0.0, -p["rhoA"] * p["g"]], "domain", "gravity"))
    end_masses = {"left": p["trolley_mass"]} if p["trolley_mass"] > 0 else None
    cable = crane.add("cable", string_model(p, end_masses=end_masses), p["L"], p["n_elements"], loads=loads,
                      supports=[Support("left", "fix-z")], initial={"r": hanging_guess(p, m)})
    if p["g"] > 0:
        hang(cable.body, p)
    hook = nodal(cable.body, "r", "x0")[1][-1]     # r(L) at rest

    # ## The payload: a box hanging below the hook (R = I), spinning about the vertical
    box = RigidBody(m, box_inertia(m, p["a"], p["b"], c))
    weight = [Load("v", [0.0, 0.0, -m * p["g"]], "domain", "payload weight")] if p["g"] > 0 else []
    payload = crane.add("payload", box, loads=weight,
                        initial=RigidBody.initial(hook - [0.0, 0.0, c / 2], omega=(0.0, 0.0, p["spin"])))

    # ## The joint: the cable's end holds the centre of the box's top face
    crane.join(joints.spherical, cable.end, payload.point((0.0, 0.0, c / 2)), name="hook")

    # ## What to record: the box's centre and the hook
    crane.marker("payload", payload.point())
    crane.marker("hook", cable.end)
    crane.marker("trolley", cable.start)
    return crane


scene = Scene("crane-payload", "crane cable carrying a rigid box through a spherical joint; the trolley is "
              "pushed along a rail", parameters, build,
              notes="H excludes the gravity potential: gravity is an input, its work is the column 'supplied'.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
