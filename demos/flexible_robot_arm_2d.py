# # Flexible robot arm: a pinned beam spun up by a hub moment
#
# A flexible arm (a planar Simo-Reissner beam of length L = 1, straight
# along x on [0, 1]) is pinned at the hub s = 0: its position is fixed, its
# angle is free.  A motor drives the hub with the moment M = 8 for t <= 5
# and then switches off; the arm is spun up and turns freely afterwards
# (with this data it does so very flexibly indeed, see below).  The
# authors' data (flexible_robot_arm.m of the planar-beam code of Kinon,
# Betsch & Eugster, after Simo & Vu-Quoc 1986): EI = 1, EA = GA = 10,
# rhoA = 100, rhoI = 1, 10 elements, T = 15, the midpoint rule with 2 Gauss
# points per element; their h = 0.5 is too long for this data (see below).
#
# The hub moment is an input port on the angular velocity omega at s = 0
# (output omega(0), supplied work h M omega_m(0)).  The time function is read
# at the midpoints t_{n+1/2} of the steps: with h = 0.5 it acts in steps
# 1-10 (midpoints 0.25 ... 4.75) and not in step 11 (midpoint 5.25); with
# the default h = 0.05 in steps 1-100.
#
# What this data does.  The beam is soft in shear and stretch (GA = EA = 10)
# and heavy (rhoA = 100: inertia rhoA L^3/3 = 33 about the pin), while its
# cross-sections are light (rhoI L = 1).  The shear force that turns the
# centreline with the sections is bounded (|GA Gamma_2| <= GA |r'|, about
# 10 N) and acts over the length sqrt(EI/GA) = 0.3 m: it can pass about
# 3 N m to the centreline, less than M = 8.  So the hub moment mostly spins
# the SECTIONS: they wind up relative to the centreline (at t = 1.5 the
# section angle runs from 9.6 rad at the hub to 3.4 rad at the tip), H
# reaches 700 J (the rigid arm would hold 23 J), and the centreline is
# thrown about by the spinning sections.  With h = 0.5 the hub
# section turns by about 3 rad per step and Newton loses the step at t = 2
# (h = 0.25: t = 3.75, h = 0.1: t = 7.7); h = 0.05 (the default) runs the
# whole T = 15 in 3.3 Newton iterations per step.  The structure checks
# below hold at any step size.
#
# A payload can be carried at the free end (parameters tip_mass,
# tip_inertia): a rigid body joined RIGIDLY to the beam's end (planar_rigid:
# same point, the angle difference held), or, with tip_inertia = 0, a point
# mass pinned there.  With tip_mass = 0 (the default) there is no tip body
# and nothing of it is assembled.
#
# What to look at:
# * `H` and `supplied`: the energy balance H_{n+1} - H_n = h y.u at every
#   step; after t = 5 no input acts, H itself stays constant.
# * `L_z`, the angular momentum about the pin of beam (+ tip body),
#   int rhoA r x v + rhoI omega ds (+ m x x v + J omega).  The pin's reaction
#   acts at the origin and has no moment about it, so the hub moment is the
#   only torque: L_z(t_n) = M t_n while it acts (to round-off: the midpoint
#   rule conserves this momentum map exactly) and L_z = M t_load = 40 after.
# * `tip_x, tip_y`, the free end of the arm, and with a tip body
#   `constraint_residual` (the tip joint's gap, round-off: it is linear).
#
# Run it:  rodfem run flexible-robot-arm-2d --out results/flexible-robot-arm-2d
#          rodfem run flexible-robot-arm-2d --set tip_mass=20 --set tip_inertia=1

import sys

from rodfem import Load, Support, System, constant_in_time
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, density, stiffness
from rodfem.forms import joints
from rodfem.forms.planar_beam import PlanarBeam, quadratic, straight
from rodfem.forms.rigid_body import PlanarRigidBody, PointMass

parameters = common(n_elements=10, dt=0.05, t_end=15.0) + [
    stiffness("L", 1.0, "m", "length of the arm"),
    stiffness("EA", 10.0, "N", "axial stiffness"),
    stiffness("GA", 10.0, "N", "shear stiffness"),
    stiffness("EI", 1.0, "N m^2", "bending stiffness"),
    density("rhoA", 100.0, "kg/m", "mass per length"),
    density("rhoI", 1.0, "kg m", "rotary inertia per length"),
    Parameter("M", 8.0, "N m", "hub moment"),
    Parameter("t_load", 5.0, "s", "the hub moment acts for t <= t_load (read at the step midpoints)", low=0),
    Parameter("gauss_points", 2, "", "Gauss points per element (the authors' code: 2)", low=1, high=10),
    Parameter("tip_mass", 0.0, "kg", "mass of a rigid payload at the free end (0: none)", low=0),
    Parameter("tip_inertia", 0.0, "kg m^2", "its moment of inertia (0: a point mass, pinned)", low=0),
]


def build(p, comm):
    # The momentum maps (about the origin) go into the history although the arm is
    # pinned: the pin sits at the origin, so its reaction has no moment about it
    # and L_z changes only by the hub moment.
    arm = System(integrator=p["integrator"], comm=comm, momentum=True)

    # ## The arm: a straight beam along x, pinned at the hub, driven there by the moment M (t <= t_load)
    beam = PlanarBeam(p["rhoA"], p["rhoI"], quadratic(EA=p["EA"], GA=p["GA"], EI=p["EI"]),
                      gauss_points=p["gauss_points"])
    hub = Load("omega", constant_in_time(p["M"], until=p["t_load"]), "left", "hub moment")
    beam = arm.add("beam", beam, shape=straight((0.0, 0.0), (p["L"], 0.0)), n_elements=p["n_elements"],
                   loads=[hub], supports=[Support("left", "pinned")])

    # ## The payload (optional): a rigid body welded to the free end, or a point mass pinned there
    if p["tip_mass"] > 0:
        if p["tip_inertia"] > 0:
            tip = arm.add("tip_body", PlanarRigidBody(p["tip_mass"], p["tip_inertia"]),
                          initial=PlanarRigidBody.initial((p["L"], 0.0), phi=0.0))
            arm.join(joints.planar_rigid, beam.end, tip.point(), name="tip_weld")
        else:
            tip = arm.add("tip_body", PointMass(p["tip_mass"], dim=2), initial=PointMass.initial((p["L"], 0.0)))
            arm.join(joints.pin, beam.end, tip.point(), name="tip_pin")

    # ## What to record: the free end of the arm
    arm.marker("tip", beam.end)
    return arm


scene = Scene("flexible-robot-arm-2d", "pinned flexible arm spun up by a hub moment, then turning freely; "
              "optional rigid tip payload", parameters, build,
              notes="L_z is the angular momentum about the pin: M t while the moment acts, then constant.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
