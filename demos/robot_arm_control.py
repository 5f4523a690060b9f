# # A flexible robot arm brought to a set angle by a passive controller
#
# A flexible arm (a planar Simo-Reissner beam of length L, straight along x)
# is pinned at the hub s = 0; a motor there turns it.  The motor is run by a
# controller at the hub's collocated port (input: the hub moment u, output:
# the hub's angular velocity omega(0)).  The set point r(t) moves the arm
# from 0 to `angle` along a smooth rest-to-rest profile in t_move seconds and
# then stays.
#
# The controller is PD control, u = -kp (phi(0) - r(t)) - kd omega(0).  As
# a port-Hamiltonian system it is a VIRTUAL SPRING of energy
# kp/2 (phi(0) - r)^2 between the ground and the hub (energy shaping: the
# closed loop's energy has its minimum at the set point) and a damper kd on
# the hub's rate (damping injection): Ortega, van der Schaft, Maschke &
# Escobar, Automatica 38 (2002).  Coupled to the arm through the hub's port,
# the closed loop is passive: once the set point stops, its energy (arm +
# virtual spring) can only decrease, by the damper's dissipation, and the
# arm's vibration decays until it rests at r, straight.  The damper acts
# only at the hub, so the flexible modes are damped through the arm's
# coupling to the hub; kd near sqrt(kp J_hub)-ish damps them well.
#
# `controller=pid` adds integral action, u = -kp e - ki z - kd omega(0),
# z' = e = phi(0) - r: the integral z is the controller's own state (kept
# in the checkpoint); integral action is not passive, so its work is in
# `supplied` and the closed loop's energy need not decrease.  Without a
# disturbance it only adds a slow mode (ki = 0.5: within 2 % of the set
# angle after 1.5 s, as PD, but within 1 % only after 2.7 s against PD's
# 2.2 s); it pays where a constant load (gravity, a payload) would leave
# PD an offset kp^-1 M.
#
# `controller=law` runs the same PD law as plain Python, u = law(t, phi,
# omega) (rodfem.forms.components.control_law): the input is read at the
# step midpoints and its work h u omega_m is recorded in `supplied`.  The
# two controllers must give the same motion (to Newton's tolerance).
#
# What to look at: `tip_angle` (the angle of the free end seen from the
# hub) reaching `angle`, `tip_deflection` (the tip's distance from the
# hub's tangent line: the vibration), `hub_P.V` (the virtual spring's
# energy: the controller's state), H (arm + controller) and `dissipated`
# (the damper), and `supplied` (the work of the moving set point; for
# `controller=law`, all of the controller's work).
#
# `controller=external` builds no controller: the hub moment is an input
# port of the arm (`beam.hub moment`, output omega(0)), zero unless driven,
# e.g. by the user's own loop through the step interface
# (rodfem.Simulator, docs/guide/control.md).
#
# Run it:  rodfem run robot-arm-control --out results/robot-arm-control
#          rodfem run robot-arm-control --set controller=law --out results/robot-arm-law
#          rodfem run robot-arm-control --set controller=pid --out results/robot-arm-pid

import sys

import numpy as np

from rodfem import Load, Support, System
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, density, stiffness
from rodfem.core.joints import ground
from rodfem.demos._multibody import nodal
from rodfem.forms.components import control_law, pd_control, pid_control, rest_to_rest
from rodfem.forms.planar_beam import PlanarBeam, quadratic, straight

parameters = common(n_elements=8, dt=0.01, t_end=6.0) + [
    stiffness("L", 1.0, "m", "length of the arm"),
    stiffness("EA", 1e4, "N", "axial stiffness"),
    stiffness("GA", 1e4, "N", "shear stiffness"),
    stiffness("EI", 5.0, "N m^2", "bending stiffness"),
    density("rhoA", 1.0, "kg/m", "mass per length"),
    density("rhoI", 1e-3, "kg m", "rotary inertia per length"),
    Parameter("angle", np.pi / 2, "rad", "set angle of the arm"),
    Parameter("t_move", 1.5, "s", "duration of the set point's rest-to-rest move", low=0),
    Parameter("kp", 20.0, "N m/rad", "proportional gain (stiffness of the virtual spring)", low=0),
    Parameter("kd", 5.0, "N m s/rad", "derivative gain (damping injected at the hub)", low=0),
    Parameter("ki", 0.5, "N m/(rad s)", "integral gain (controller=pid)", low=0),
    Parameter("controller", "pd", "", "PD as a virtual spring and damper, the same law in Python, PID, or none "
              "(external: the hub moment is an input port)", choices=("pd", "law", "pid", "external")),
]


def build(p, comm):
    arm = System(integrator=p["integrator"], comm=comm)

    # ## The arm: a straight beam along x, pinned at the hub
    model = PlanarBeam(p["rhoA"], p["rhoI"], quadratic(EA=p["EA"], GA=p["GA"], EI=p["EI"]))
    external = p["controller"] == "external"     # the hub moment: an input port driven from outside
    beam = arm.add("beam", model, shape=straight((0.0, 0.0), (p["L"], 0.0)), n_elements=p["n_elements"],
                   supports=[Support("left", "pinned")],
                   loads=[Load("omega", 0.0, "left", "hub moment")] if external else ())

    # ## The controller at the hub: between the ground's frame and the hub's section angle
    r = rest_to_rest(0.0, p["angle"], 0.0, p["t_move"])
    if p["controller"] == "pd":
        arm.connect(pd_control(p["kp"], p["kd"], r), ground((0.0, 0.0)), beam.start, name="hub")
    elif p["controller"] == "pid":
        arm.connect(pid_control(p["kp"], p["ki"], p["kd"], r), ground((0.0, 0.0)), beam.start, name="hub")
    elif p["controller"] == "law":
        def law(t, phi, omega):
            return -p["kp"] * (phi - r(t)) - p["kd"] * omega
        arm.connect(control_law(law), ground((0.0, 0.0)), beam.start, name="hub")

    # ## What to record: the tip, its angle from the hub, its distance from the hub's tangent
    arm.marker("tip", beam.end)

    def tip(system):
        body = system.body("beam")
        x = nodal(body, "r")[1]
        phi0 = nodal(body, "phi")[1][0, 0]
        tip = x[-1] - x[0]
        normal = np.array([-np.sin(phi0), np.cos(phi0)])
        return {"tip_angle": float(np.arctan2(tip[1], tip[0])), "hub_angle": float(phi0),
                "tip_deflection": float(tip @ normal)}
    arm.record(tip)
    return arm


scene = Scene("robot-arm-control", "flexible arm turned to a set angle by PD control at the hub "
              "(a virtual spring and damper: passive)", parameters, build,
              notes="tip_angle reaches `angle`; tip_deflection (the vibration) decays once the set point rests.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
