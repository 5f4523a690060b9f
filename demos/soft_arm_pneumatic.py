# # Soft robotic arm driven by three pneumatic chambers (Kinon, Eugster & Betsch 2026, example 04)
#
# A straight silicone arm of length L = 0.1755 stands along +z, clamped at
# its base z = 0.  Three chambers run along it, 120 degrees apart at the
# angles theta_i = 30, 150, 270 degrees of the cross-section plane
# (d2 = e_x, d3 = e_y).  Kinon, Eugster & Betsch (CMA 458 (2026)
# 118966) drives them with
#
#     p_i(t) = (a(t)/2) (1 + cos(phi(t) - theta_i)),
#
# a(t) rising as sin^2 to its amplitude over 0.5 s, phi(t) = pi (1 - cos(pi
# (t - 0.5)/3)) running once from 0 to 2 pi in 3 s, then a(t) back to zero
# (the published input file, LisaLatussek/PHMultiBodySystems @98acbf24,
# fitted in demos/_actuated.py).  The tip then sweeps a circle and returns.
#
# Each chamber is a power port (forms/actuators.py): input the gauge
# pressure p_i, output the rate of its volume
#     V_i = A int_0^L (1 + Gamma_1 + y_b K_2 - y_a K_3) ds,
# which is linear in the strains: the pressure adds N_1 = p A (elongation)
# and M = p A y x e_1 (bending AWAY from the chamber) to the rod's resultants.
# Since sum p_i = 3a/2 and sum p_i y_i = (3a/4) e (cos phi, sin phi) do not
# depend on phi, the axial force and the bending moment have constant size:
# in the quasi-static limit the tip runs on a horizontal circle whose radius
# and height are those of a circular arc (forms/actuators.py, closed forms).
#
# Unpublished data, chosen here (demos/_actuated.py): Dragon Skin 10 silicone
# (E = 0.152 MPa, nu = 0.5, rho = 1070), outer radius 8 mm, chambers of radius
# 2 mm at 5 mm from the axis, |a| = 50 kPa.  Published circle: radius 0.092-
# 0.093 at height 0.1466-0.1477 (4.4 % elongation, 64 degrees of bending);
# with these choices the quasi-static circle has radius 0.0841 at height
# 0.1530 (3.8 %, 58 degrees).  Sign: the paper's a = -50 elongates the arm,
# so its p is minus the gauge pressure; here a > 0 is the gauge pressure.
# The published tip leads the angle phi, ours trails it by 180 degrees (an
# inflated chamber bends the arm away from itself); the paper's offset
# convention is not published, the circle is the same.
#
# Modes: 'static' (default) -- densities zero, every step an equilibrium
# (load stepping); the same pressures along the same path, but with C^2
# time laws whose second rates vanish where they start (the published sin^2
# and 1 - cos would leave an alternating O(dt^2) error in load-stepped
# statics, see demos/_actuated.py); 'dynamic' -- the published time law and
# the arm's inertia: this soft arm's first bending period is ~1.1 s, so the
# 0.5 s ramp makes it swing about the circle (no damping in the model).
# Gravity (-z) is off by default: this arm is too soft to stand upright
# (q L^3 / EI = 22 for its weight q per length, above the critical 7.84
# of a standing column under its own weight).
#
# Run it:  rodfem run soft-arm-pneumatic --out results/soft-arm-pneumatic
#          rodfem run soft-arm-pneumatic --set mode=dynamic --set dt=0.005

import sys

import numpy as np

from rodfem import Load, Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, density, stiffness
from rodfem.demos._actuated import (
    CHAMBER_ANGLES,
    chamber_pressures,
    soft_arm_parameters,
    soft_arm_section,
    soft_arm_stiffness,
    soft_rod,
)
from rodfem.demos._rod3d import NEWTON, smooth_ramp, straight
from rodfem.forms import actuators

# d1 = e_z (the axis), d2 = e_x, d3 = e_y: the chamber at angle theta sits at (cos theta, sin theta) in x, y
DIRECTORS = (np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))

parameters = common(n_elements=8, dt=0.02, t_end=4.0) + soft_arm_parameters() + [
    Parameter("mode", "static", "", "static: load stepping with zero densities; dynamic: with inertia",
              choices=("static", "dynamic")),
    Parameter("amplitude", 50e3, "Pa", "gauge pressure amplitude |a| of the programme (may be < 0: suction)"),
    stiffness("t_ramp", 0.5, "s", "the amplitude rises (and falls) over t_ramp"),
    stiffness("t_circle", 3.0, "s", "one turn of the pressure angle phi"),
    density("g", 0.0, "m/s^2", "gravity, acting in -z (the default arm buckles under its own weight)"),
]


def chambers(p):
    _, _, Ac = soft_arm_section(p)
    pressures = chamber_pressures(p["amplitude"], CHAMBER_ANGLES, p["t_ramp"], p["t_circle"],
                                  smooth=p["mode"] == "static")
    return [actuators.Chamber(pi, actuators.on_circle(p["chamber_offset"], th), radius=p["R_out"], area=Ac,
                              name=f"chamber{i + 1}")
            for i, (pi, th) in enumerate(zip(pressures, CHAMBER_ANGLES))]


def build(p, comm):
    statics = p["mode"] == "static"
    loads = chambers(p) if p["amplitude"] != 0 else []
    if p["g"] != 0:
        _, _, rhoA, _ = soft_arm_stiffness(p)
        weight = np.array([0.0, 0.0, -rhoA * p["g"]])
        loads.append(Load("v", smooth_ramp(weight, p["t_ramp"]) if statics else weight, "domain", "gravity"))
    return Problem(soft_rod(p, statics), p["L"], p["n_elements"], loads=loads, supports=[Support("left", "clamped")],
                   initial=straight((0.0, 0.0, 0.0), DIRECTORS), integrator=p["integrator"], comm=comm,
                   newton_options=NEWTON)


def quasi_static_tip(p, t):
    """The exact quasi-static tip at time t (no gravity): the circular arc of the chambers' pressures."""
    K_se, K_bt, _, _ = soft_arm_stiffness(p)
    _, _, Ac = soft_arm_section(p)
    pressures = chamber_pressures(p["amplitude"], CHAMBER_ANGLES, p["t_ramp"], p["t_circle"],
                                  smooth=p["mode"] == "static")
    ch = [(pi(t), Ac, actuators.on_circle(p["chamber_offset"], th)) for pi, th in zip(pressures, CHAMBER_ANGLES)]
    Gamma, K = actuators.uniform_equilibrium(K_se, K_bt, chambers=ch)
    R0 = np.column_stack(DIRECTORS)
    return actuators.uniform_centreline(Gamma, K, [p["L"]], R0=R0)[0][-1]


def circle(p):
    """(radius, height) of the quasi-static tip circle (full amplitude, no gravity)."""
    tip = quasi_static_tip(p, p["t_ramp"])
    return float(np.hypot(tip[0], tip[1])), float(tip[2])


def reference(p):
    """Static mode without gravity: the exact tip at t_end (a circular arc)."""
    if p["mode"] != "static" or p["g"] != 0:
        return None
    tip = quasi_static_tip(p, p["t_end"])
    return {"tip_x": tip[0], "tip_y": tip[1], "tip_z": tip[2], "scale": p["L"]}


scene = Scene("soft-arm-pneumatic",
              "silicone arm, three pneumatic chambers sweep the tip once around a circle (Kinon et al. 2026, example 04)",
              parameters, build, reference=reference,
              notes="Chambers are ports (input gauge pressure, output dV/dt); the columns volume_chamber1..3 "
                    "are their volumes.  Published tip circle: radius 0.092, height 0.147.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
