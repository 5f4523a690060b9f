# # A chain of rigid boxes on springs and dashpots
#
# n boxes (3D director-based rigid bodies, forms/rigid_body.py: mass m,
# sides a x a x b) hang in a column between a ceiling (z = 0) and a floor.
# Each gap (ceiling-box 1, box 1-box 2, ..., box n-floor) is bridged at the
# four corners of the facing square faces by a spring and a dashpot: eight
# components per gap, connected with System.connect between a box's points
# (offsets in its frame) or a fixed point of the ground.  The springs are
# pre-stretched by `prestretch` so the column is taut; gravity then pulls
# the boxes down, and a sideways push and a spin of the lowest box at t = 0
# set the column swinging, twisting and bouncing.
#
# The springs' energy is one function of the squared length c = |d|^2
# (forms/components.py): `hookean` psi = k/2 (sqrt(c) - l0)^2 (a linear
# spring, non-polynomial in the coordinates) or `quartic` psi = k/2 (c - l0^2)^2.
# The dashpots act along the springs' lines with the coefficient c_d
# (objective: a rigid rotation of the whole column dissipates nothing).
# With the discrete-gradient rule (the default) the balance
#
#     H_{n+1} - H_n + dissipated_step = supplied_step     (gravity's work)
#
# holds to round-off for either spring law; each box's orthonormality
# d_i . d_j = delta_ij holds exactly (its multipliers).  Over time the
# dashpots take the motion out and the column settles at its static
# equilibrium, which `rodfem static spring-damper-chain` computes directly.
#
# What to look at: H (kinetic + the springs' energy), `supplied` (gravity),
# `dissipated`, the boxes' centres `box1_x ... boxN_z`, the springs' energies
# `spring_<gap>_<corner>.V`.
#
# Run it:  rodfem run spring-damper-chain --out results/spring-damper-chain
#          rodfem run spring-damper-chain --set law=quartic --set n_bodies=6
#          rodfem static spring-damper-chain --out results/spring-damper-chain-static

import sys

import numpy as np

from rodfem import Load, System
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.core.joints import ground
from rodfem.forms.components import dashpot, hookean, quartic, spring
from rodfem.forms.rigid_body import RigidBody

parameters = [p for p in common(n_elements=1, dt=0.02, t_end=10.0, integrator="discrete-gradient")
              if p.name not in ("n_elements", "section")] + [
    Parameter("n_bodies", 4, "", "number of boxes", low=1, high=200),
    stiffness("mass", 1.0, "kg", "mass of each box"),
    stiffness("a", 0.4, "m", "side of the boxes' square faces (the springs sit at their corners)"),
    stiffness("b", 0.2, "m", "height of the boxes"),
    stiffness("k", 100.0, "N/m", "spring stiffness (hookean: k; quartic: k of k/2 (c - l0^2)^2, in N/m^3)"),
    stiffness("rest_length", 0.3, "m", "rest length l0 of the springs"),
    Parameter("prestretch", 0.2, "", "the springs' initial stretch (length / l0 - 1)", low=0),
    Parameter("c", 0.5, "N s/m", "dashpot coefficient along each spring", low=0),
    Parameter("law", "hookean", "", "the springs' energy", choices=("hookean", "quartic")),
    Parameter("g", 9.81, "m/s^2", "gravity, acting in -z"),
    Parameter("push", 0.5, "m/s", "initial sideways velocity (x) of the lowest box"),
    Parameter("spin", 1.0, "rad/s", "initial spin of the lowest box about z"),
]
CORNERS = [(sx, sy) for sx in (-0.5, 0.5) for sy in (-0.5, 0.5)]


def layout(p):
    """The boxes' centres z_i (i = 1..n, downwards from the ceiling at 0) and the floor's height."""
    gap = p["rest_length"] * (1 + p["prestretch"])
    centres = [-(i * gap + (i - 0.5) * p["b"]) for i in range(1, p["n_bodies"] + 1)]
    return centres, -(p["n_bodies"] + 1) * gap - p["n_bodies"] * p["b"]


def build(p, comm):
    chain = System(integrator=p["integrator"], comm=comm)
    m, a, b, n = p["mass"], p["a"], p["b"], p["n_bodies"]
    inertia = m / 12.0 * np.array([a**2 + b**2, a**2 + b**2, 2 * a**2])
    centres, floor = layout(p)

    # ## The boxes, the lowest pushed sideways and spun about z
    boxes = []
    for i, z in enumerate(centres):
        last = i == n - 1
        boxes.append(chain.add(f"box{i + 1}", RigidBody(m, inertia),
                               initial=RigidBody.initial((0.0, 0.0, z), v=(p["push"] if last else 0.0, 0.0, 0.0),
                                                         omega=(0.0, 0.0, p["spin"] if last else 0.0)),
                               loads=[Load("v", [0.0, 0.0, -m * p["g"]], "domain", "gravity")]))
        chain.marker(f"box{i + 1}", boxes[-1].point())

    # ## A spring and a dashpot at each corner of each gap
    energy = (hookean if p["law"] == "hookean" else quartic)(p["k"], p["rest_length"])
    for gap in range(n + 1):
        for corner, (sx, sy) in enumerate(CORNERS):
            offset = (sx * a, sy * a)
            upper = (ground((*offset, 0.0)) if gap == 0 else boxes[gap - 1].point((*offset, -b / 2)))
            lower = (ground((*offset, floor)) if gap == n else boxes[gap].point((*offset, b / 2)))
            chain.connect(spring(energy), upper, lower, name=f"spring_{gap}_{corner}")
            if p["c"] > 0:
                chain.connect(dashpot(p["c"]), upper, lower, name=f"dashpot_{gap}_{corner}")
    return chain


scene = Scene("spring-damper-chain", "rigid boxes hanging in a taut column of springs and dashpots "
              "(hookean or quartic), pushed and spun", parameters, build,
              notes="Discrete gradient: balance to round-off for both spring laws; the dashpots settle the column "
                    "at the static equilibrium.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
