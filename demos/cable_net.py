# # A square cable net sagging under its weight
#
# A square net of n x n crossings: n cables run along x, n along y, each
# pinned at both ends on the edge of a square frame of side L (1 + prestretch)
# in the plane z = 0.  Between two neighbouring nodes (crossings or pins) a
# cable is one hyperelastic string (forms/string.py, `n_elements` elements,
# reference length a = L/(n + 1), material W(C) of forms/string_materials.py),
# so the net is 2 n (n + 1) bodies; at every crossing the ends of its four
# strings are joined by spherical joints (forms/joints.py: three joints of 3
# conditions each, quadratic: held to round-off).  The strings at the edge
# have their outer end pinned (the string's 'pinned' support).
#
# The net starts flat and at rest, every cable stretched by `prestretch`
# (uniform tension N = 2 W'(C) sqrt(C), C = (1 + prestretch)^2), and falls
# under gravity (an input: its work is the column `supplied`); undamped, it
# swings about its sagged equilibrium with
#
#     H_{n+1} - H_n = supplied_step        (discrete gradient: to round-off, any material).
#
# `rodfem static cable-net` solves the sagged equilibrium of the same
# discrete net directly (rodfem/analysis/statics.py); tests/models/
# test_many_scenes.py checks it against a Newton method in numpy on the same
# discrete springs (independent of rodfem's forms), and, for a stiff net
# under a small load, against the linear membrane (a discrete Poisson
# problem).
#
# What to look at: `centre_z` (the crossing nearest to the middle), H - supplied,
# the joints' reactions.
#
# A net is no band: in any order of its unknowns, the rows of a crossing far
# from the first ones lie far from the diagonal.  PETSc's LU in reverse
# Cuthill-McKee order (the serial default, right for chains and rods) fills
# that whole envelope; from about 2,000 unknowns the solver starts with the
# partial LU of rodfem/la/partial_lu.py instead, whose minimum-degree order
# keeps each joint's multiplier after the dofs it joins (20 x 20 crossings,
# 20,400 unknowns: 3.0e6 entries of the factor against 4.3e5, 47 against 14 ms
# per step; rodfem/la/lu_chain.py's `first_lu`).
#
# Run it:  rodfem run cable-net --out results/cable-net
#          rodfem run cable-net --set n=20 --set t_end=0.05 --out results/cable-net-20
#          rodfem static cable-net --out results/cable-net-static

import sys

import numpy as np

from rodfem import Load, Support, System
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.forms import joints
from rodfem.forms.string import MATERIALS, String

parameters = [p for p in common(n_elements=2, dt=0.005, t_end=0.5, integrator="discrete-gradient")
              if p.name != "section"] + [
    Parameter("n", 4, "", "crossings per side (n x n crossings, 2 n (n + 1) strings)", low=1, high=200),
    stiffness("L", 1.0, "m", "side of the net (unstretched: n + 1 segments of L / (n + 1))"),
    Parameter("prestretch", 0.02, "", "initial stretch of every cable (length / reference length - 1)", low=0,
              high=1, low_open=True),
    Parameter("material", "logarithmic", "", "the cables' stored energy W(C) (forms/string_materials.py)",
              choices=tuple(MATERIALS)),
    stiffness("EA", 500.0, "N", "axial stiffness of the cables"),
    stiffness("rhoA", 0.1, "kg/m", "mass per length of the cables"),
    Parameter("g", 9.81, "m/s^2", "gravity, acting in -z", low=0),
]


def node(p, i, j):
    """The position of node (i, j), i, j = 0..n+1 (0 and n+1: the edge), in the flat stretched net."""
    n, a = p["n"], p["L"] / (p["n"] + 1) * (1 + p["prestretch"])
    return np.array([(i - 0.5 * (n + 1)) * a, (j - 0.5 * (n + 1)) * a, 0.0])


def segments(n):
    """The strings as pairs of nodes ((i, j), (i', j')): along x in the rows j = 1..n, along y in the
    columns i = 1..n."""
    along_x = [((i, j), (i + 1, j)) for j in range(1, n + 1) for i in range(n + 1)]
    along_y = [((i, j), (i, j + 1)) for i in range(1, n + 1) for j in range(n + 1)]
    return along_x + along_y


def on_edge(n, ij):
    return ij[0] in (0, n + 1) or ij[1] in (0, n + 1)


def build(p, comm):
    n = p["n"]
    # (under mpirun each string is built whole on one rank: many small bodies, distribute=True)
    net = System(integrator=p["integrator"], comm=comm, distribute=True)
    model = String(MATERIALS[p["material"]](EA=p["EA"]), p["rhoA"])
    a = p["L"] / (n + 1)
    ends = {}   # crossing -> the string ends that meet there

    # ## The strings, straight and stretched between their nodes; the edge ends pinned
    for k, (A, B) in enumerate(segments(n)):
        xa, xb = node(p, *A), node(p, *B)
        supports = [Support(end, "pinned") for end, ij in (("left", A), ("right", B)) if on_edge(n, ij)]
        weight = [Load("v", [0.0, 0.0, -p["rhoA"] * p["g"]], "domain", f"gravity s{k}")] if p["g"] > 0 else []
        s = net.add(f"s{k}", model, a, p["n_elements"], loads=weight, supports=supports,
                    initial={"r": lambda x, xa=xa, xb=xb: np.outer(xb - xa, x[0] / a) + xa[:, None]})
        for end, ij in (("start", A), ("end", B)):
            if not on_edge(n, ij):
                ends.setdefault(ij, []).append(getattr(s, end))

    # ## The crossings: the four ends joined to the first by spherical joints
    for (i, j), points in ends.items():
        for k, pt in enumerate(points[1:], 1):
            net.join(joints.spherical, points[0], pt, name=f"x{i}_{j}_{k}")
    mid = (n + 1) // 2
    net.marker("centre", ends[(mid, mid)][0])
    return net


scene = Scene("cable-net", "a square net of pre-stretched string cables joined at the crossings, pinned at the "
              "edges, sagging under gravity", parameters, build,
              notes="Discrete gradient: H - supplied constant to round-off; `rodfem static cable-net`: the sagged "
                    "equilibrium.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
