# # A tensegrity prism (or a tower of prisms), pre-stressed, pushed and swinging
#
# The triangular tensegrity prism: three struts that touch no other strut,
# held by nine cables.  Its nodes lie on two equilateral triangles of
# circumradius R, the bottom one at z = 0 with nodes at the angles
# 0, 120, 240 deg, the top one at z = H turned by the twist phi.  Strut i
# runs from bottom node i to top node i; the cables are the two triangles'
# sides ("horizontal") and the three "vertical" cables from bottom node i to
# top node i - 1.  A tower stacks `stories` prisms, each turned by phi against
# the one below, sharing the triangles between them.
#
# Form finding.  A state of self-stress (force densities q = tension/length,
# sum_j q_ij (x_j - x_i) = 0 at every node, cables q > 0, struts q < 0)
# exists only at the twist phi = 150 deg (with the strut and vertical-cable
# topology above; the mirror image has -150 deg), whatever R and H, and then
#
#     q_horizontal : q_vertical : q_strut = 1 : sqrt(3) : -sqrt(3)
#
# (the classical result for the regular n-prism, twist 90 - 180/n deg from
# the other end's convention, for n = 3: Tibert & Pellegrino, "Review of
# form-finding methods for tensegrity structures", International Journal
# of Space Structures 18(4), 2003, 209-223;
# tests/models/test_many_scenes.py checks it from the null space of the
# equilibrium matrix).  In a tower the shared inner triangles carry the
# force density of two prisms, 2 q_horizontal.
#
# Model.  Struts: director-based rigid bodies (forms/rigid_body.py), thin
# uniform rods of mass m_strut.  Cables: hyperelastic strings
# (forms/string.py) of `n_elements` elements, mass rhoA per length, with a
# string material (forms/string_materials.py, default `tension-only`: the
# Kirchhoff law in tension, almost no stiffness in compression, so a slack
# cable buckles freely).  Each cable's reference length is chosen so
# that, stretched between its nodes, it carries the tension q l of the
# self-stress with the prestress level `tension` (the horizontal cables'
# tension of the bottom triangle): the struts and the straight cables are
# then at rest in equilibrium (a straight string of uniform tension with no
# distributed load is in equilibrium whatever its mass).  The cables' ends
# are joined to the struts' ends by spherical joints (forms/joints.py).
#
# Excitation: a force `push` on strut 0's centre, along y, for t < t_push
# (an input: its work is the column `supplied`).  Free-floating
# (support = free, g = 0, the default) the prism then drifts, turns and
# vibrates: H - supplied is constant and the momentum p, L changes only by
# the push, both to round-off (the discrete-gradient rule, for any string
# material).  support = pinned fixes the bottom nodes (spherical joints to
# the ground); g > 0 adds the weight of struts and cables.
#
# What to look at: `top_x, top_y, top_z` (top node 0), H - supplied, p_y,
# the joints' reactions `<node>_<k>.lambda1..3` (N).
#
# Run it:  rodfem run tensegrity --out results/tensegrity
#          rodfem run tensegrity --set stories=3 --set support=pinned --set g=9.81 --out results/tower

import sys

import numpy as np

from rodfem import Load, System
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, density, stiffness
from rodfem.core.joints import ground
from rodfem.demos._multibody import rod_inertia
from rodfem.errors import ParameterError
from rodfem.forms import joints
from rodfem.forms.rigid_body import RigidBody
from rodfem.forms.string import MATERIALS, String

parameters = [p for p in common(n_elements=2, dt=0.002, t_end=1.0, integrator="discrete-gradient")
              if p.name != "section"] + [
    Parameter("stories", 1, "", "number of prisms stacked (3 struts each)", low=1, high=50),
    stiffness("R", 0.5, "m", "circumradius of the triangles"),
    stiffness("H", 1.0, "m", "height of a prism"),
    Parameter("twist", 150.0, "deg", "twist of the top triangle against the bottom one (150: the self-stressed prism)",
              low=0, high=360, low_open=True),
    stiffness("tension", 20.0, "N", "pre-stress: tension of the bottom triangle's cables"),
    Parameter("material", "tension-only", "", "the cables' stored energy W(C) (forms/string_materials.py)",
              choices=tuple(MATERIALS)),
    stiffness("EA", 2000.0, "N", "axial stiffness of the cables"),
    stiffness("rhoA", 0.02, "kg/m", "mass per length of the cables"),
    density("m_strut", 0.5, "kg", "mass of a strut"),
    stiffness("r_strut", 0.01, "m", "radius of the struts (their inertia)"),
    Parameter("push", 20.0, "N", "force on strut 0's centre along y, for t < t_push"),
    Parameter("t_push", 0.05, "s", "duration of the push", low=0),
    Parameter("support", "free", "", "free-floating, or the bottom nodes pinned to the ground",
              choices=("free", "pinned")),
    Parameter("g", 0.0, "m/s^2", "gravity, acting in -z", low=0),
]


def nodes(p):
    """The nodes X[level, i] (stories + 1 levels of 3): level j turned by j twist, at height j H."""
    phi = np.radians(p["twist"])
    a = 2 * np.pi * np.arange(3) / 3
    return np.array([[(p["R"] * np.cos(ai + j * phi), p["R"] * np.sin(ai + j * phi), j * p["H"]) for ai in a]
                     for j in range(p["stories"] + 1)])


def members(p):
    """Struts [(a, b)] and cables [(a, b, q / q_horizontal)] by node (level, i): the self-stress's force
    densities relative to the outer triangles' (module docstring)."""
    S = p["stories"]
    struts = [((j, i), (j + 1, i)) for j in range(S) for i in range(3)]
    cables = [((j, i), (j, (i + 1) % 3), 1.0 if j in (0, S) else 2.0) for j in range(S + 1) for i in range(3)]
    cables += [((j, i), (j + 1, (i - 1) % 3), np.sqrt(3.0)) for j in range(S) for i in range(3)]
    return struts, cables


def reference_length(material, length, tension):
    """The reference length L0 of a string that carries `tension` when stretched to `length`:
    N(lambda) = tension (bisection on the stretch lambda = length / L0 > 1)."""
    lo, hi = 1.0, 2.0
    while material.tension(hi) < tension:
        lo, hi = hi, 2 * hi
        if hi > 1e3:
            raise ParameterError(f"parameter 'tension' ({tension:g} N) is beyond what the cables (EA) can carry")
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if material.tension(mid) < tension else (lo, mid)
    return length / (0.5 * (lo + hi))


def frame_along(e):
    """An orthonormal frame [d1 d2 d3] with d1 = e."""
    e = e / np.linalg.norm(e)
    helper = np.array([0.0, 0.0, 1.0]) if abs(e[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    d2 = np.cross(helper, e)
    d2 /= np.linalg.norm(d2)
    return np.column_stack([e, d2, np.cross(e, d2)])


def build(p, comm):
    X = nodes(p)
    struts, cables = members(p)
    # (under mpirun each strut and cable is built whole on one rank: many small bodies, distribute=True)
    prism = System(integrator=p["integrator"], comm=comm, distribute=True)
    material = MATERIALS[p["material"]](EA=p["EA"])
    side = np.linalg.norm(X[0, 1] - X[0, 0])
    q_h = p["tension"] / side   # the outer triangles' force density

    # ## The struts: rigid thin rods between their nodes, at rest (strut 0 pushed)
    at = {}   # node -> the points that meet there
    for k, (a, b) in enumerate(struts):
        axis = X[b] - X[a]
        ls = float(np.linalg.norm(axis))
        if p["r_strut"] >= 0.5 * ls:
            raise ParameterError(f"parameter 'r_strut' must be < half a strut's length ({0.5 * ls:g} m; got {p['r_strut']:g})")
        loads = [Load("v", [0.0, 0.0, -p["m_strut"] * p["g"]], "domain", f"gravity strut{k}")] if p["g"] > 0 else []
        if k == 0 and p["push"] != 0 and p["t_push"] > 0:
            loads.append(Load("v", lambda t, f=p["push"], tp=p["t_push"]: np.array([0.0, f if t < tp else 0.0, 0.0]),
                              "domain", "push"))
        s = prism.add(f"strut{k}", RigidBody(p["m_strut"], rod_inertia(p["m_strut"], ls, p["r_strut"])),
                      initial=RigidBody.initial(0.5 * (X[a] + X[b]), R=frame_along(axis)), loads=loads)
        at.setdefault(a, []).append(s.point((-0.5 * ls, 0.0, 0.0)))
        at.setdefault(b, []).append(s.point((0.5 * ls, 0.0, 0.0)))

    # ## The cables: strings stretched between their nodes to the self-stress's tension q l
    for k, (a, b, ratio) in enumerate(cables):
        length = float(np.linalg.norm(X[b] - X[a]))
        L0 = reference_length(material, length, ratio * q_h * length)
        weight = [Load("v", [0.0, 0.0, -p["rhoA"] * p["g"]], "domain", f"gravity cable{k}")] if p["g"] > 0 else []
        c = prism.add(f"cable{k}", String(material, p["rhoA"]), L0, p["n_elements"], loads=weight,
                      initial={"r": lambda x, xa=X[a], xb=X[b], L0=L0: np.outer(xb - xa, x[0] / L0) + xa[:, None]})
        at[a].append(c.start)
        at[b].append(c.end)

    # ## The nodes: every point that meets there joined to the first (a strut's end) by a spherical joint
    for (j, i), points in at.items():
        for k, pt in enumerate(points[1:], 1):
            prism.join(joints.spherical, points[0], pt, name=f"n{j}{i}_{k}")
        if p["support"] == "pinned" and j == 0:
            prism.join(joints.spherical, ground(X[j, i]), points[0], name=f"pin{i}")
    prism.marker("top", at[(p["stories"], 0)][0])
    return prism


scene = Scene("tensegrity", "a pre-stressed tensegrity prism (or tower) of rigid struts and string cables, "
              "pushed and swinging", parameters, build,
              notes="Discrete gradient: H - supplied constant and, free-floating, the momentum changed by the push "
                    "only, to round-off; twist 150 deg: the self-stressed equilibrium.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
