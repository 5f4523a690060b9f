# # A soft arm with two tendons falls over under gravity (dynamics, Kelvin-Voigt damping)
#
# The tendon benchmark that soromox, SoRoSim and PyElastica were compared on
# (Stölzle et al., tud-phi/soromox, paper_results/
# secIVa_benchmarking_sequential_cpu): a soft arm of two 0.3 m links -- here
# one rod, L = 0.6 m -- with a solid circular section of radius r = 0.03 m,
# E = 1 MPa, nu = 0.5 (G = E/3), rho = 1000 kg/m^3, clamped at its base at
# the origin and standing upright along +z, gravity -9.81 e_z.  Two tendons
# run its full length at 0.02 m from the axis, one along each axis of the
# section (d2 = e_x and d3 = e_y at the base), with a constant tension of
# 1 N each from t = 0; T = 3 s.  The arm's own weight (q = rho A g = 27.7 N/m)
# is above the buckling load of an upright clamped column (7.84 EI/L^3 =
# 23.1 N/m): the tendons' bending tips it, and it falls over towards the
# diagonal between them (x = y by symmetry) and swings down.
#
# Damping.  soromox writes Kelvin-Voigt damping as stresses D xi_dot with
# D = eta diag(J, 3I, 3I, 3A, A, A) (torsion, bending, axial, shear) and
# eta = 1e4 Pa s.  Here the dashpots are native (forms/damping.py,
# docs/guide/damping.md): viscous resultants tau_kv diag(EA, GA, GA, GJ, EI,
# EI) times the strain rates.  With E = 3G these are the same matrix when
#
#     tau_kv = eta / G = 3 eta / E = 0.03 s,
#
# and every mode is damped with the ratio zeta_k = tau_kv omega_k / 2 (the
# arm's first cantilever mode without gravity, omega_1 = 4.63 rad/s:
# zeta_1 = 0.069).
#
# Ports and balance.  The tendons (forms/actuators.py: input the tension,
# output -dl/dt) and gravity are inputs; H is the kinetic plus elastic energy.
# Every step H_{n+1} - H_n = h y.u - h d_n: the work supplied (column
# 'supplied', the tendons' -tau (l_{n+1} - l_n) plus gravity's) minus the
# exact dissipation of the dashpots (column 'dissipated'); 'balance_error'
# stays at round-off (1e-12 of max|H|).
#
# Checks (tests/models/test_tendon_arm_dynamic.py, docs/guide/
# tendon-arm-dynamic.md): the tip converges in dt, n_elements and adaptive
# mode; the long-time limit is the static equilibrium of the same loads
# (`rodfem static`, and the strong-form shooting solution
# forms/actuators.py shooting_statics, followed from g = 0 to 9.81); the
# first mode decays with zeta_1 = tau_kv omega_1 / 2.  The published tip
# histories of the three codes are in the soromox repository (data/
# end_effector_position_tendon_driven_*.csv and the PyElastica/SoRoSim files
# beside them); they are not reproduced here.
#
# Run it:  rodfem run tendon-arm-dynamic --out results/tendon-arm-dynamic
#          rodfem run tendon-arm-dynamic --set adaptive=true --set rtol=1e-4

import sys

import numpy as np

from rodfem import Load, Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, density, stiffness
from rodfem.demos._damping import damping
from rodfem.demos._rod3d import NEWTON, straight
from rodfem.forms import actuators, cosserat_rod
from rodfem.io.sections import Section

# upright: d1 = e_z (the axis), d2 = e_x, d3 = e_y (soromox's local x, y, z)
DIRECTORS = (np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))

parameters = common(n_elements=12, dt=0.01, t_end=3.0, integrator="discrete-gradient") + [
    stiffness("L", 0.6, "m", "length of the arm"),
    stiffness("radius", 0.03, "m", "radius of the (solid, circular) section"),
    stiffness("E", 1e6, "Pa", "Young's modulus"),
    Parameter("nu", 0.5, "", "Poisson's ratio (G = E / (2 (1 + nu)))", low=0, high=0.5),
    density("rho", 1000.0, "kg/m^3", "density"),
    density("g", 9.81, "m/s^2", "gravity, acting in -z"),
    Parameter("tau_kv", 0.03, "s", "Kelvin-Voigt retardation time: viscous resultants tau_kv (EA, GA, GA, GJ, EI, "
              "EI) x strain rates (soromox's eta = 1e4 Pa s: tau_kv = eta/G = 0.03 s; 0: none)", low=0),
    Parameter("rayleigh_alpha", 0.0, "1/s", "Rayleigh mass-proportional damping: force -alpha rho v on every mass "
              "(0: none)", low=0),
    stiffness("offset", 0.02, "m", "distance of the two tendons from the axis"),
    density("tension1", 1.0, "N", "tension of the tendon along d2 (local y), constant from t = 0"),
    density("tension2", 1.0, "N", "tension of the tendon along d3 (local z), constant from t = 0"),
]


def section(p):
    """K_se = (EA, GA, GA), K_bt = (GJ, EI, EI), rhoA, rhoJ = (2 rho I, rho I, rho I) of the solid disc."""
    A, I = np.pi * p["radius"] ** 2, np.pi * p["radius"] ** 4 / 4
    E, G = p["E"], p["E"] / (2 * (1 + p["nu"]))
    return (E * A, G * A, G * A), (G * 2 * I, E * I, E * I), p["rho"] * A, (2 * p["rho"] * I, p["rho"] * I,
                                                                          p["rho"] * I)


def routing(p, i):
    """Tendon i (0: along d2, 1: along d3), straight, at `offset` from the axis."""
    return actuators.straight(actuators.on_circle(p["offset"], i * np.pi / 2))


def rod(p):
    """The CosseratRod of the arm with its Kelvin-Voigt (tau_kv) and Rayleigh (alpha) damping."""
    K_se, K_bt, rhoA, rhoJ = section(p)
    C_N, C_M = [1 / k for k in K_se], [1 / k for k in K_bt]
    kv = damping(p, cosserat_rod.rayleigh, C_N, C_M)
    arm = cosserat_rod.CosseratRod(rhoA, rhoJ, C_N, C_M, damping=kv)
    arm.section = Section.round(p["radius"])        # what surface/ and the pictures draw
    return arm


def build(p, comm):
    _, _, rhoA, _ = section(p)
    loads = [actuators.Tendon(p[f"tension{i + 1}"], routing(p, i), radius=p["radius"], name=f"tendon{i + 1}")
             for i in range(2) if p[f"tension{i + 1}"] != 0]
    if p["g"] != 0:
        loads.append(Load("v", [0.0, 0.0, -rhoA * p["g"]], "domain", "gravity"))
    return Problem(rod(p), p["L"], p["n_elements"], loads=loads, supports=[Support("left", "clamped")],
                   initial=straight((0.0, 0.0, 0.0), DIRECTORS), integrator=p["integrator"], comm=comm,
                   newton_options=NEWTON)


def static_tip(p, near, steps=100):
    """The tip at the static equilibrium of the same loads (the run's long-time limit), from the strong-form
    shooting solution (RK4 in s, forms/actuators.py shooting_statics).  Upright is an equilibrium too
    (unstable: the weight is above the buckling load); Newton starts from the base moment
    G(0) = int r x f ds of the centreline `near` (points along s, e.g. the end of a run), which selects
    the fallen branch."""
    K_se, K_bt, rhoA, _ = section(p)
    f = np.array([0.0, 0.0, -rhoA * p["g"]])
    near = np.asarray(near, float)
    ds = p["L"] / (len(near) - 1)
    moments = np.cross(near, f)
    G0 = ds * (moments.sum(axis=0) - (moments[0] + moments[-1]) / 2)
    tendons = [(p[f"tension{i + 1}"], routing(p, i)) for i in range(2) if p[f"tension{i + 1}"] != 0]
    _, r, _ = actuators.shooting_statics(K_se, K_bt, p["L"], tendons=tendons, force=f,
                                         R0=np.column_stack(DIRECTORS), steps=steps, G0=G0)
    return r[-1]


scene = Scene("tendon-arm-dynamic", "soft arm (L = 0.6 m, E = 1 MPa) with two tendons (1 N each) falling over "
              "under gravity, Kelvin-Voigt damping (the soromox / SoRoSim / PyElastica tendon benchmark)",
              parameters, build,
              notes="H excludes the gravity potential: gravity and the tendons are inputs ('supplied'); the "
                    "dashpots' exact dissipation is 'dissipated'.  tau_kv = eta/G converts soromox's "
                    "D = eta diag(J, 3I, 3I, 3A, A, A).")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
