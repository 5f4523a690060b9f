# Shared pieces of the actuated-arm demos (forms/actuators.py): the soft
# silicone arm with three pneumatic chambers (its section, material and
# parameters), the pressure programme of example 04 of Kinon, Eugster & Betsch (2026), and smooth
# switching functions for input histories.  (The scenes assemble only the
# actuators whose input is not zero.)
import numpy as np

from rodfem.app.scene import Parameter, density, stiffness
from rodfem.errors import ParameterError
from rodfem.forms.cosserat_rod import CosseratRod
from rodfem.io.sections import Section

# The soft arm.  Kinon, Eugster & Betsch (2026, example 04) publishes
# only the arm's length L = 0.1755, the chamber angles and the pressure
# programme (LisaLatussek/PHMultiBodySystems @98acbf24, results/
# example_04_soft_robotic_arm).  The rest is chosen here for a cast silicone
# arm of the usual kind (three cylindrical chambers around a solid core):
#   * Dragon Skin 10 MEDIUM (Smooth-On technical bulletin: 100 % modulus
#     22 psi = 0.152 MPa, specific gravity 1.07); E = 0.152 MPa, nearly
#     incompressible (nu = 0.5, G = E/3), rho = 1070 kg/m^3;
#   * outer radius 8 mm, chambers of radius 2 mm (A = 12.6 mm^2) with their
#     centres 5 mm off the axis (1 mm outer wall, 2.7 mm between chambers);
#   * the published amplitude |a| = 50 read as 50 kPa gauge pressure.
# The solid section (disc minus the three holes) carries EA, GA (no shear
# correction), EI (isotropic: the three holes have sum sin^2 = sum cos^2 =
# 3/2) and GJ = G (2 I) (polar moment); the mass is rho times the solid area.
SOFT_ARM = dict(L=0.1755, E=0.152e6, nu=0.5, rho=1070.0, R_out=8e-3, r_chamber=2e-3, chamber_offset=5e-3)
CHAMBER_ANGLES = (np.deg2rad(30.0), np.deg2rad(150.0), np.deg2rad(270.0))


def soft_arm_parameters(**defaults):
    d = {**SOFT_ARM, **defaults}
    return [
        stiffness("L", d["L"], "m", "length of the arm"),
        stiffness("E", d["E"], "Pa", "Young's modulus of the silicone (Dragon Skin 10: 0.152 MPa)"),
        Parameter("nu", d["nu"], "", "Poisson's ratio (G = E / (2 (1 + nu)))", low=0, high=0.5),
        density("rho", d["rho"], "kg/m^3", "density of the silicone"),
        stiffness("R_out", d["R_out"], "m", "outer radius of the arm"),
        stiffness("r_chamber", d["r_chamber"], "m", "radius of each (cylindrical) chamber"),
        stiffness("chamber_offset", d["chamber_offset"], "m", "distance of the chamber centres from the axis"),
    ]


def soft_arm_section(p, n_chambers=3):
    """(A, I, chamber area) of the solid section: a disc of radius R_out minus n chambers of radius
    r_chamber whose centres sit at chamber_offset, evenly spaced (I about any diameter)."""
    R, rc, e = p["R_out"], p["r_chamber"], p["chamber_offset"]
    if e + rc >= R:
        raise ParameterError(f"parameters 'chamber_offset' + 'r_chamber' must be < 'R_out' (got {e:g} + {rc:g} "
                             f">= {R:g}): the chambers would cut the outer wall")
    if 2 * e * np.sin(np.pi / n_chambers) <= 2 * rc:
        raise ParameterError(f"parameter 'r_chamber' = {rc:g} is too large for {n_chambers} chambers at "
                             f"offset {e:g}: they would overlap")
    Ac = np.pi * rc ** 2
    A = np.pi * R ** 2 - n_chambers * Ac
    I = np.pi * R ** 4 / 4 - n_chambers * (np.pi * rc ** 4 / 4 + Ac * e ** 2 / 2)
    return A, I, Ac


def soft_arm_stiffness(p):
    """K_se = (EA, GA, GA), K_bt = (GJ, EI, EI), rhoA, rhoJ = (2 rho I, rho I, rho I)."""
    A, I, _ = soft_arm_section(p)
    E, G = p["E"], p["E"] / (2 * (1 + p["nu"]))
    return (E * A, G * A, G * A), (G * 2 * I, E * I, E * I), p["rho"] * A, (2 * p["rho"] * I, p["rho"] * I,
                                                                          p["rho"] * I)


def soft_rod(p, statics):
    """The CosseratRod of the soft arm (densities zero for statics)."""
    K_se, K_bt, rhoA, rhoJ = soft_arm_stiffness(p)
    if statics:
        rhoA, rhoJ = 0.0, (0.0, 0.0, 0.0)
    rod = CosseratRod(rhoA, rhoJ, [1 / k for k in K_se], [1 / k for k in K_bt])
    rod.section = Section.round(p["R_out"])          # what surface/ and the pictures draw
    return rod


def smoothstep(t, t0, t1):
    """0 before t0, 1 after t1, C^2 in between (10 x^3 - 15 x^4 + 6 x^5)."""
    if t1 <= t0:
        return 1.0 if t >= t0 else 0.0
    x = min(max((t - t0) / (t1 - t0), 0.0), 1.0)
    return x ** 3 * (10 - 15 * x + 6 * x ** 2)


def circle_programme(amplitude, t_ramp=0.5, t_circle=3.0, smooth=False):
    """The paper's pressure programme (fitted to the published input file to < 3e-4):
    a(t) = amplitude sin^2(pi t / (2 t_ramp)) on [0, t_ramp], amplitude while the angle
    phi(t) = pi (1 - cos(pi (t - t_ramp) / t_circle)) runs from 0 to 2 pi, then back down
    over t_ramp; returns (a, phi) as functions of t.

    smooth=True: the same pressures along the same path, but with C^2 time laws (smoothstep)
    whose first AND second rates vanish where they start and stop.  Load-stepped statics
    needs this: the midpoint rule puts the midpoint states in equilibrium, and the end states
    then carry an alternating error (-1)^n h^2 q''(0)/8 that a nonzero second rate at the start
    (sin^2, 1 - cos) excites and nothing damps (measured 3e-5 at the end of the static run with
    h = 0.02, 2.7e-4 at t = 0.5 with h = 0.025).
    """
    t_back = t_ramp + t_circle
    if smooth:
        def a(t):
            return amplitude * (smoothstep(t, 0.0, t_ramp) - smoothstep(t, t_back, t_back + t_ramp))

        def phi(t):
            return 2 * np.pi * smoothstep(t, t_ramp, t_back)
        return a, phi

    def a(t):
        if t <= t_ramp:
            return amplitude * np.sin(np.pi * t / (2 * t_ramp)) ** 2
        if t <= t_back:
            return amplitude
        return amplitude * np.sin(np.pi * max(t_back + t_ramp - t, 0.0) / (2 * t_ramp)) ** 2

    def phi(t):
        if t <= t_ramp:
            return 0.0
        if t <= t_back:
            return np.pi * (1 - np.cos(np.pi * (t - t_ramp) / t_circle))
        return 2 * np.pi
    return a, phi


def chamber_pressures(amplitude, angles=CHAMBER_ANGLES, t_ramp=0.5, t_circle=3.0, smooth=False):
    """p_i(t) = (a(t)/2) (1 + cos(phi(t) - theta_i)), one function per chamber angle theta_i."""
    a, phi = circle_programme(amplitude, t_ramp, t_circle, smooth)
    return [lambda t, th=th: 0.5 * a(t) * (1 + np.cos(phi(t) - th)) for th in angles]

