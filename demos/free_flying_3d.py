# # Free-flying 3D system: two rods joined by a ball joint (or a rod with a welded rigid body)
#
# Two flexible 3D Cosserat rods form an L in the xy-plane: rod A from
# (0, 0, 0) to (4, 0, 0), rod B from (4, 0, 0) to (4, 3, 0).  A SPHERICAL
# joint holds A's end and B's start together and leaves their directors
# free: the two rods may fold, twist and swivel about the common point.
# Nothing holds the system and no gravity acts.  For t <= t_load a force F
# and a body-fixed moment M_B act at B's free end; then they stop and the
# system tumbles freely through space, folding about the ball joint and
# vibrating.
#
# Variant `rod-body`: rod A carries a rigid box (the director-based rigid
# body of forms/rigid_body.py, mass m, sides (a, b, b)) WELDED to its end by
# the `rigid` joint (the points coincide and the frames keep their relative
# orientation: 6 conditions, quadratic in the directors of rod end and
# body), and the load acts on the box: F at its centre of mass, M_B about
# its axes.
#
# Material (the 3D flying spaghetti's): EA = GA = 1e4, GJ = 200, EI = 100,
# rhoA = 1, rhoJ = (10, 10, 10); P2 kinematics, the midpoint rule
# (Kinon, Eugster & Betsch 2026: exact energy balance, orthonormality at the nodes).
#
# What to look at: no support and no joint to the ground, so the System
# writes the totals p_x, p_y, p_z (linear momentum) and L_x, L_y, L_z
# (angular momentum about the origin) of all bodies.  While the load acts
# they change by h F and h (r x F + m) per step; afterwards the only forces
# are internal: the joint's reactions act at one point on both sides, equal
# and opposite, and the joint's g is invariant under rigid motions, so
# its reactions carry no net force and no net moment.  So H, p and L are
# constant after t_load -- to round-off and Newton's tolerance, since the
# midpoint rule conserves these quadratic momentum maps exactly -- and
# H_{n+1} - H_n = h y.u at every step.  `constraint_residual` is the joint's
# gap (spherical: linear, round-off; rigid: its rotation rows are bilinear,
# so they hold to Newton's tolerance).
#
# Run it:  rodfem run free-flying-3d --out results/free-flying-3d
#          rodfem run free-flying-3d --set variant=rod-body --out results/free-flying-rod-body

import sys

import numpy as np

from rodfem import Load, constant_in_time
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.core.system import System
from rodfem.demos._rod3d import NEWTON, end_moment, material_parameters, rod, straight
from rodfem.forms import joints
from rodfem.forms.rigid_body import RigidBody

parameters = common(n_elements=4, dt=0.05, t_end=10.0) + [
    Parameter("variant", "rods", "", "two rods joined by a spherical joint, or rod A with a rigid box welded to its end",
              choices=("rods", "rod-body")),
    Parameter("Fx", 0.0, "N", "load force, x"),
    Parameter("Fy", 0.0, "N", "load force, y"),
    Parameter("Fz", 10.0, "N", "load force, z (out of the plane of the L)"),
    Parameter("M1", 5.0, "N m", "load moment about d1 (body-fixed: torsion of rod B)"),
    Parameter("M2", 0.0, "N m", "load moment about d2 (body-fixed)"),
    Parameter("M3", 20.0, "N m", "load moment about d3 (body-fixed: in-plane bending)"),
    Parameter("t_load", 1.0, "s", "force and moment act for t <= t_load (read at the step midpoints)", low=0),
    stiffness("box_mass", 3.0, "kg", "rod-body: mass of the box"),
    stiffness("box_a", 1.0, "m", "rod-body: length of the box along rod A's axis"),
    stiffness("box_b", 0.5, "m", "rod-body: its two other sides"),
] + material_parameters(EA=1e4, GA=1e4, GJ=200.0, EI=100.0, rhoA=1.0, rhoJ=(10.0, 10.0, 10.0))
# n_elements: elements of EACH rod.

A = (np.array([0.0, 0.0, 0.0]), np.array([4.0, 0.0, 0.0]))
B = (np.array([4.0, 0.0, 0.0]), np.array([4.0, 3.0, 0.0]))
E3 = np.array([0.0, 0.0, 1.0])


def add_rod(system, name, ends, p, loads=()):
    """A straight rod between `ends`: d1 along it, d3 = e3, d2 = d3 x d1."""
    length = float(np.linalg.norm(ends[1] - ends[0]))
    d1 = (ends[1] - ends[0]) / length
    directors = (d1, np.cross(E3, d1), E3)
    return system.add(name, rod(p), length, p["n_elements"], loads=loads, initial=straight(ends[0], directors))


def load(p, where):
    """The force F and the body-fixed moment M_B at `where` ('right': a rod end; 'domain': a rigid body)."""
    until = p["t_load"]
    return [Load("v", constant_in_time([p["Fx"], p["Fy"], p["Fz"]], until=until), where, "force"),
            end_moment(constant_in_time([p["M1"], p["M2"], p["M3"]], until=until), "body", where, "moment")]


def build(p, comm):
    system = System(integrator=p["integrator"], comm=comm, newton_options=NEWTON)
    if p["variant"] == "rods":
        # ## Two rods, the load at B's free end; a ball joint between A's end and B's start
        rod_a = add_rod(system, "rod_a", A, p)
        rod_b = add_rod(system, "rod_b", B, p, loads=load(p, "right"))
        system.join(joints.spherical, rod_a.end, rod_b.start, name="ball")
        system.marker("tip_b", rod_b.end)
    else:
        # ## Rod A and a box welded to its end (the centre of the box's face), the load on the box
        m, a, b = p["box_mass"], p["box_a"], p["box_b"]
        inertia = m / 12.0 * np.array([2 * b**2, a**2 + b**2, a**2 + b**2])
        rod_a = add_rod(system, "rod_a", A, p)
        box = system.add("box", RigidBody(m, inertia), loads=load(p, "domain"),
                         initial=RigidBody.initial(A[1] + [a / 2, 0.0, 0.0]))
        system.join(joints.rigid, rod_a.end, box.point((-a / 2, 0.0, 0.0)), name="weld")
        system.marker("box", box.point())
    system.marker("tip_a", rod_a.start)
    return system


scene = Scene("free-flying-3d", "two free rods joined by a ball joint (or a rod with a welded rigid box), "
              "tumbling after a short force and moment", parameters, build,
              notes="No supports: the history has the total momenta p_x..p_z, L_x..L_z, constant after t_load.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
