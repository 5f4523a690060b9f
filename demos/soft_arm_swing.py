# # A soft arm swung by a chamber and a tendon (dynamics, energy balance)
#
# The silicone arm of soft-arm-pneumatic (Dragon Skin 10, L = 0.1755, outer
# radius 8 mm, three chambers of radius 2 mm at 5 mm) hangs from its clamped
# base at the origin along -z, under gravity; it starts at rest in its static
# equilibrium (stretched by its own weight).  One chamber (the one at 270
# degrees) and one tendon, running in the wall on the same side (at 6.5 mm),
# act in turn, fast compared with the arm's first period (~1 s):
#
#   * 0 - t_on: the chamber pressure rises smoothly to p_max: the arm bends
#     away from the chamber and lifts its tip against gravity;
#   * t_on - 2 t_on: the pressure drops back to zero -- the arm swings;
#   * 2 t_on - 3 t_on: the tendon tension rises to tau_max and pulls the arm
#     to the other side; it stays on until 4 t_on and is then released
#     (over t_on);
#   * then the arm swings freely (no damping in the model).
#
# Both actuators are ports (forms/actuators.py), gravity is the third:
# every step H_{n+1} - H_n = h (p Vdot - tau ldot + gravity . v), so
# energy.png shows H, the supplied work and H - supplied = H(0) to
# round-off; the history also records the chamber volume and the tendon
# length.  Any combination of chambers and tendons can be put on one arm in
# the same way.
#
# Run it:  rodfem run soft-arm-swing --out results/soft-arm-swing

import sys

import numpy as np

from rodfem import Load, Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Scene, common, density, stiffness
from rodfem.demos._actuated import smoothstep, soft_arm_parameters, soft_arm_section, soft_arm_stiffness, soft_rod
from rodfem.demos._rod3d import NEWTON, straight
from rodfem.forms import actuators

# hanging: d1 = -e_z (the axis), d2 = e_x, d3 = d1 x d2 = -e_y
DIRECTORS = (np.array([0.0, 0.0, -1.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, -1.0, 0.0]))
ANGLE = np.deg2rad(270.0)   # chamber and tendon: at -d3 = +e_y

parameters = common(n_elements=12, dt=0.005, t_end=3.0) + soft_arm_parameters() + [
    density("p_max", 40e3, "Pa", "peak gauge pressure in the chamber"),
    density("tau_max", 0.3, "N", "peak tendon tension"),
    stiffness("tendon_offset", 6.5e-3, "m", "distance of the tendon from the axis"),
    stiffness("t_on", 0.25, "s", "duration of each switching phase"),
    density("g", 9.81, "m/s^2", "gravity, acting in -z"),
]


def pressure(p):
    T, P = p["t_on"], p["p_max"]
    return lambda t: P * (smoothstep(t, 0.0, T) - smoothstep(t, T, 2 * T))


def tension(p):
    T, tau = p["t_on"], p["tau_max"]
    return lambda t: tau * (smoothstep(t, 2 * T, 3 * T) - smoothstep(t, 4 * T, 5 * T))


def build(p, comm):
    _, _, Ac = soft_arm_section(p)
    _, _, rhoA, _ = soft_arm_stiffness(p)
    loads = []
    if p["p_max"] != 0:
        loads.append(actuators.Chamber(pressure(p), actuators.on_circle(p["chamber_offset"], ANGLE),
                                       radius=p["R_out"], area=Ac, name="chamber"))
    if p["tau_max"] != 0:
        loads.append(actuators.Tendon(tension(p), actuators.on_circle(p["tendon_offset"], ANGLE),
                                      radius=p["R_out"], name="tendon"))
    if p["g"] != 0:
        loads.append(Load("v", [0.0, 0.0, -rhoA * p["g"]], "domain", "gravity"))
    return Problem(soft_rod(p, statics=False), p["L"], p["n_elements"], loads=loads,
                   supports=[Support("left", "clamped")], initial=hanging(p), integrator=p["integrator"],
                   comm=comm, newton_options=NEWTON)


def hanging(p):
    """The static equilibrium of the hanging arm under gravity (exact in P2 x DG1): axial force
    N_1 = q (L - s), q = rhoA g, so r(s) = -(s + q (L s - s^2/2) / EA) e_z; at rest."""
    (EA, _, _), _, rhoA, _ = soft_arm_stiffness(p)
    q, L = rhoA * p["g"], p["L"]
    init = straight((0.0, 0.0, 0.0), DIRECTORS)
    init["r"] = lambda x: np.vstack([0 * x[0], 0 * x[0], -(x[0] + q * (L * x[0] - x[0] ** 2 / 2) / EA)])
    init["N"] = lambda x: np.vstack([q * (L - x[0]), 0 * x[0], 0 * x[0]])
    return init


scene = Scene("soft-arm-swing", "hanging silicone arm swung by a pneumatic chamber and a tendon in turn, under "
              "gravity (dynamics; the energy balance of three ports)", parameters, build,
              notes="H excludes the gravity potential: gravity, the chamber and the tendon are inputs, their "
                    "work is the column 'supplied'; H - supplied stays H(0).")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
