# # Tendon-driven continuum robot (Rucker & Webster 2011), statics
#
# The reference robot of Rucker & Webster (IEEE T-RO 27(6), 2011) as set up in
# Till's ContinuumRobotExamples (01_Statics/05_Tendon_Robot and
# 06_Tendon_Robot_Variants): a spring-steel backbone, E = 200 GPa,
# G = 80 GPa, radius 1 mm, rho = 8000, L = 0.5, clamped at s = 0 and standing
# along +z; four tendons 90 degrees apart at 15.06 mm from the axis (through
# spacer discs), 15 N in the first one (on +x), gravity 9.81 along +x.
#
# Each tendon is a power port (forms/actuators.py): input its tension tau,
# output -dl/dt with l its length along the routing y(s) in the
# cross-section, l = int |phi' + (y_a d_2 + y_b d_3)'| ds.  It acts through
# the virtual work of tau l: the distributed wall forces of the routing and
# the force where it ends, as in Rucker & Webster's model -- not as a point
# load at the tip.  Routings: 'straight' (constant offset), 'helical' (one
# full turn over L, Till's Cpp_2 variant), 'converging' (offset (1 - s/L)
# 15.06 mm, onto the axis at the tip).
#
# Statics: zero densities, the tensions and gravity rise smoothly over
# [0, t_end] (load stepping; the final state is the equilibrium up to
# O(dt^4)).  A tendon whose tension is zero is not assembled.
#
# Check: an independent solution of the same model in strong form
# (forms/actuators.py shooting_statics: rod and tendons cut together,
# pointwise strains, RK4 in s) gives the reference tip; without gravity the
# straight and helical routings have closed forms (a circular arc with
# kappa = tau d / EI, axial strain -tau/EA; a helix).  With the defaults the
# tip ends at (0.18221, 0, 0.45323).
#
# Run it:  rodfem run tendon-arm --out results/tendon-arm
#          rodfem run tendon-arm --set routing=helical --set g=0

import functools
import sys

import numpy as np

from rodfem import Load, Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, density, stiffness
from rodfem.demos._rod3d import NEWTON, smooth_ramp, straight
from rodfem.forms import actuators
from rodfem.forms.cosserat_rod import CosseratRod
from rodfem.io.sections import Section

# d1 = e_z (the axis), d2 = e_x, d3 = e_y: tendon i at offset (cos, sin)(i pi/2) in (x, y), as in Till's code
DIRECTORS = (np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))

parameters = common(n_elements=16, dt=0.025, t_end=1.0) + [
    stiffness("L", 0.5, "m", "length"),
    stiffness("E", 200e9, "Pa", "Young's modulus"),
    stiffness("G", 80e9, "Pa", "shear modulus"),
    stiffness("radius", 1e-3, "m", "radius of the (solid, circular) backbone"),
    density("rho", 8000.0, "kg/m^3", "density (for gravity)"),
    density("g", 9.81, "m/s^2", "gravity, acting in +x"),
    stiffness("offset", 0.01506, "m", "distance of the tendons from the axis"),
    stiffness("disc_radius", 0.02, "m", "radius of the spacer discs (a tendon must lie inside)"),
    Parameter("routing", "straight", "", "tendon routing", choices=("straight", "helical", "converging")),
] + [density(f"tension{i + 1}", 15.0 if i == 0 else 0.0, "N", f"tension of tendon {i + 1} (at {90 * i} deg)")
     for i in range(4)]


def section(p):
    A, I = np.pi * p["radius"] ** 2, np.pi * p["radius"] ** 4 / 4
    return (p["E"] * A, p["G"] * A, p["G"] * A), (p["G"] * 2 * I, p["E"] * I, p["E"] * I), A


def routing(p, i):
    angle = i * np.pi / 2
    if p["routing"] == "helical":
        return actuators.helical(p["offset"], 2 * np.pi / p["L"], angle)
    if p["routing"] == "converging":
        return actuators.converging(actuators.on_circle(p["offset"], angle), p["L"])
    return actuators.straight(actuators.on_circle(p["offset"], angle))


def build(p, comm):
    K_se, K_bt, A = section(p)
    rod = CosseratRod(0.0, (0.0, 0.0, 0.0), [1 / k for k in K_se], [1 / k for k in K_bt])
    rod.section = Section.round(p["radius"])         # the backbone, drawn in surface/ and the pictures
    loads = [actuators.Tendon(smooth_ramp(p[f"tension{i + 1}"], p["t_end"]), routing(p, i), radius=p["disc_radius"],
                              name=f"tendon{i + 1}") for i in range(4) if p[f"tension{i + 1}"] != 0]
    if p["g"] != 0:
        loads.append(Load("v", smooth_ramp([p["rho"] * A * p["g"], 0.0, 0.0], p["t_end"]), "domain", "gravity"))
    return Problem(rod, p["L"], p["n_elements"], loads=loads, supports=[Support("left", "clamped")],
                   initial=straight((0.0, 0.0, 0.0), DIRECTORS), integrator=p["integrator"], comm=comm,
                   newton_options=NEWTON)


@functools.lru_cache(maxsize=16)
def _shooting(key):
    p = dict(key)
    K_se, K_bt, A = section(p)
    tendons = [(p[f"tension{i + 1}"], routing(p, i)) for i in range(4) if p[f"tension{i + 1}"] != 0]
    s, r, R = actuators.shooting_statics(K_se, K_bt, p["L"], tendons=tendons,
                                         force=(p["rho"] * A * p["g"], 0.0, 0.0), R0=np.column_stack(DIRECTORS),
                                         steps=200)
    return r[-1]


def reference(p):
    """The tip of the static equilibrium, from the strong-form shooting solution (RK4, 200 steps)."""
    tip = _shooting(tuple(sorted((k, v) for k, v in p.items())))
    return {"tip_x": tip[0], "tip_y": tip[1], "tip_z": tip[2], "scale": p["L"]}


scene = Scene("tendon-arm", "tendon-driven continuum robot of Rucker & Webster (2011): four tendons, 15 N in one, "
              "gravity; straight, helical or converging routing (statics)", parameters, build, reference=reference,
              notes="Tendons are ports (input tension, output -dl/dt); the columns length_tendon1.. are their "
                    "lengths.  Only tendons with nonzero tension are assembled.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
