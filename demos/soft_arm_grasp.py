# # A soft tendon arm wraps itself around a pole and holds on (contact and friction)
#
# A soft arm (a 3D Cosserat rod, forms/cosserat_rod.py: length L = 0.5 m, a solid circular section
# of radius r = 1 cm, E = 10 MPa, nu = 0.5, rho = 1000 kg/m^3, Kelvin-Voigt damping tau_kv = 0.1 s:
# its first mode, 7 rad/s, damped with the ratio 0.35) stands
# upright along +z, its base welded to the ground at the origin (a rigid joint: its reactions are
# the columns `base.lambda1`..`6`).  Beside it stands a fixed pole: the cylinder of radius R about
# the y axis through (R + r + gap, 0, 0), so that the arm's base touches the pole's left side.  One
# tendon (forms/actuators.py: a port with input the tension tau, output -dl/dt) runs along the
# arm's +x side at `offset` from the axis; its tension rises smoothly to tau over t_ramp and is held.
# Free, the tendon would curl the arm to the curvature kappa0 = tau offset / EI (a circle); the
# tension is chosen (`curl`) so that kappa0 = curl / (R + r), tighter than the pole: the arm
# wraps over the pole (L / (R + r) = 4.5 rad of it) and presses on it, the way an octopus arm or a
# soft gripper grasps (curl = 1.5: tau = 14.7 N).  The pole stands on a smooth table, the x-z plane, on which the arm lies:
# the table carries the weight (along -y) without friction, so gravity does not enter.
#
# ## The contact (forms/contact.py)
#
# The arm touches the pole along its length: the cubic penalty k/3 <-g>^3 of the gap between the
# arm's surface and the pole (k: the line load tau / (R + r) of the tendon's tension bent round the
# pole penetrates `penetration`), integrated with the discrete gradient, and regularized Coulomb
# friction (mu, eps) at the surface point of the section that faces the pole (the arm rolls onto
# the pole: friction acts on its spin too).  The contact forces are outputs: `arm.pole.N` the total
# normal force, `arm.pole.Fn_x, _y, _z` its vector, `arm.pole.Ft_x, ...` the friction force, and
# `arm.pole.penetration` the largest penetration.
#
# ## What can be checked
#
#   * the balance H_{n+1} - H_n + dissipated = supplied to round-off every step (H: kinetic, elastic
#     and contact energy; supplied: the tendon's work; dissipated: the dashpots' and
#     the friction's, each >= 0 in every step);
#   * the penetration stays below the stated `penetration` at rest (1e-3 m, a tenth of r: a soft
#     arm is squeezed); the arm slams onto the pole when its curvature reaches the pole's (the
#     whole wrap touches at once, at t = 0.75 s), and then penetrates up to 1.7 times it;
#   * once the arm has settled (the damping takes out the motion) the forces on it balance:
#     base reaction + contact (normal and friction) = 0 -- the tendon's forces are internal (its
#     virtual work tau dl vanishes for a rigid motion of the arm).  `force_balance(row)` gives the
#     residual |F_base + F_contact| from a history row, and the grip |F_contact|.  The contact
#     columns are the state's, psi'(g) and the friction law at x_{n+1}: they ring at the step rate
#     on the contact vibration the steps do not resolve (and the implicit midpoint rule does not
#     damp), so compare their mean over a window (the last second: a residual of 0.13 % without
#     friction, 1.4 % with it, of a grip of 4.7 N).
#
# The friction is regularized (eps = 1 cm/s): at rest the arm creeps round the pole at a slip of
# order eps, and the regularized law carries no force at zero slip -- once settled, the pole's force
# is mostly normal.
#
# Run it:  rodfem run soft-arm-grasp --out results/soft-arm-grasp
#          rodfem run soft-arm-grasp --set mu=0 --out results/grasp-frictionless

import sys

import numpy as np

from rodfem import System, ground
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, density, stiffness
from rodfem.demos._rod3d import NEWTON, smooth_ramp, straight
from rodfem.forms import actuators, cosserat_rod, joints
from rodfem.forms.contact import Contact, Coulomb, Cylinder, stiffness_for
from rodfem.io.sections import Section

# upright: d1 = e_z (the axis), d2 = e_x (towards the pole), d3 = e_y (along the pole)
DIRECTORS = (np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))

parameters = common(n_elements=10, dt=0.02, t_end=3.0, integrator="discrete-gradient") + [
    stiffness("L", 0.5, "m", "length of the arm"),
    stiffness("radius", 0.01, "m", "radius of the arm's (solid, circular) section"),
    stiffness("E", 1e7, "Pa", "Young's modulus"),
    Parameter("nu", 0.5, "", "Poisson's ratio (G = E / (2 (1 + nu)))", low=0, high=0.5),
    stiffness("rho", 1000.0, "kg/m^3", "density"),
    Parameter("tau_kv", 0.1, "s", "Kelvin-Voigt retardation time of the arm (viscous resultants tau_kv (EA, GA, "
              "GA, GJ, EI, EI) x strain rates)", low=0),
    stiffness("R", 0.09, "m", "radius of the pole"),
    density("gap", 0.002, "m", "gap between the arm's surface and the pole at t = 0"),
    stiffness("offset", 0.008, "m", "distance of the tendon from the arm's axis (inside the section)"),
    Parameter("curl", 1.5, "", "the tendon's tension curls the free arm to the curvature curl / (R + radius)",
              low=0, low_open=True),
    stiffness("t_ramp", 1.0, "s", "the tension rises smoothly over t_ramp, then is held"),
    Parameter("mu", 0.3, "", "friction coefficient between arm and pole (static = kinetic)", low=0),
    stiffness("eps", 1e-2, "m/s", "regularization velocity of the friction law"),
    stiffness("penetration", 1e-3, "m", "penetration of the pole under the line load tau / (R + radius) (sets the "
              "penalty k)"),
]


def section(p):
    """K_se = (EA, GA, GA), K_bt = (GJ, EI, EI), rhoA, rhoJ = (2 rho I, rho I, rho I) of the solid disc."""
    A, I = np.pi * p["radius"] ** 2, np.pi * p["radius"] ** 4 / 4
    E, G = p["E"], p["E"] / (2 * (1 + p["nu"]))
    return (E * A, G * A, G * A), (G * 2 * I, E * I, E * I), p["rho"] * A, (2 * p["rho"] * I, p["rho"] * I,
                                                                          p["rho"] * I)


def tension(p):
    """tau = kappa0 EI / offset with kappa0 = curl / (R + radius)."""
    _, K_bt, _, _ = section(p)
    return p["curl"] / (p["R"] + p["radius"]) * K_bt[1] / p["offset"]


def arm_model(p):
    K_se, K_bt, rhoA, rhoJ = section(p)
    C_N, C_M = [1 / k for k in K_se], [1 / k for k in K_bt]
    kv = cosserat_rod.kelvin_voigt(p["tau_kv"], C_N, C_M) if p["tau_kv"] > 0 else None
    arm = cosserat_rod.CosseratRod(rhoA, rhoJ, C_N, C_M, damping=kv)
    arm.section = Section.round(p["radius"])
    return arm


def force_balance(row):
    """(|F_base + F_contact|, |F_contact|) from a history row: the residual of the forces on the arm (zero
    at rest; the base's force on the arm is (lambda1, lambda2, lambda3), the weld's multipliers) and the
    grip, the magnitude of the pole's force (normal and friction) on the arm."""
    contact = np.array([row[f"arm.pole.Fn_{c}"] + row[f"arm.pole.Ft_{c}"] for c in "xyz"])
    base = np.array([row[f"base.lambda{i}"] for i in (1, 2, 3)])
    return float(np.linalg.norm(base + contact)), float(np.linalg.norm(contact))


def build(p, comm):
    if p["offset"] >= p["radius"]:
        from rodfem.errors import ParameterError
        raise ParameterError(f"parameter 'offset' must be in (0, radius = {p['radius']:g}) (got {p['offset']:g})")
    tau = tension(p)
    loads = [actuators.Tendon(smooth_ramp(tau, p["t_ramp"]), actuators.straight(actuators.on_circle(p["offset"], 0.0)),
                              radius=p["radius"], name="tendon")]
    Rw = p["R"] + p["radius"]
    pole = Contact(Cylinder((Rw + p["gap"], 0.0, 0.0), (0.0, 1.0, 0.0), p["R"]),
                   stiffness_for(tau / Rw, p["penetration"]), radius=p["radius"], name="pole",
                   friction=Coulomb(p["mu"], p["mu"], eps=p["eps"], v_s=1.0))
    system = System(integrator=p["integrator"], comm=comm, newton_options={**NEWTON, "snes_atol": 1e-11})
    arm = system.add("arm", arm_model(p), p["L"], p["n_elements"], loads=loads,
                     initial=straight((0.0, 0.0, 0.0), DIRECTORS), contacts=[pole])
    system.join(joints.rigid, ground((0.0, 0.0, 0.0), np.column_stack(DIRECTORS)), arm.start, name="base")
    system.marker("tip", arm.end)
    return system


scene = Scene("soft-arm-grasp", "a soft tendon arm wraps itself around a fixed pole and holds on: contact with "
              "friction, the contact forces as outputs", parameters, build,
              notes="force_balance(row) = |base reaction + contact force| (zero at rest); the tendon's forces "
                    "are internal.  Discrete gradient: balance to round-off, dissipation >= 0 every step.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
