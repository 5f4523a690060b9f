# # Rod to helix (Harsch, Capobianco & Eugster 2021)
#
# A straight rod, clamped at s = 0, is bent by a body-fixed end moment into
# a helix of radius R0 = 10 and height 50 with two coils.  With pitch
# parameter c = h / (2 pi R0 n) the rod has length L = sqrt(1 + c^2) R0 2 pi n
# = 135.2 and the helix has constant curvature kappa = 1/(R0 (1 + c^2)) (about
# d3) and torsion tau = c kappa (about the axis d1).  The end moment
#
#     M_B = (GJ tau, 0, EI kappa)       (components on d1, d2, d3)
#
# makes this helix the exact static solution (GJ = EI for E = 1, G = 1/2 and
# a circular section, so M_B is parallel to the strain vector K = (tau, 0, kappa)).
# The tip moves from (0, -10, 0) to (0, -10, 50).
#
# The circular cross-section has radius L / (2 slenderness), slenderness
# 1e1 ... 1e4: a locking element would lose accuracy as EA L^2 / EI grows.
# A pure-moment static problem does not depend on the unit of force: the
# scene divides all stiffnesses and the moment by EI, so that the residual
# rows (moments ~ EI kappa and strain rates ~ kappa) stay of the same size
# at every slenderness and Newton's absolute tolerance keeps its meaning.
#
# Statics through the integrator (zero densities), smooth load ramp over [0, t_end].
#
# Run it:  rodfem run helix-3d --set slenderness=1e4 --out results/helix-3d

import sys

import numpy as np

from rodfem import Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.demos._rod3d import NEWTON, end_moment, smooth_ramp, straight
from rodfem.forms.cosserat_rod import CosseratRod
from rodfem.io.sections import Section

R0, HEIGHT, COILS = 10.0, 50.0, 2
C = HEIGHT / (2 * np.pi * R0 * COILS)
LENGTH = np.sqrt(1 + C**2) * R0 * 2 * np.pi * COILS
KAPPA = 1 / (R0 * (1 + C**2))

parameters = common(n_elements=16, dt=1 / 32, t_end=1.0) + [
    Parameter("slenderness", 1e2, "", "L / (2 radius) of the circular cross-section", low=1),
    stiffness("E", 1.0, "Pa", "Young's modulus"),
    stiffness("G", 0.5, "Pa", "shear modulus (G = E/2 makes GJ = EI)"),
    Parameter("constraint", "none", "", "strains switched off (compliance 0)",
              choices=("none", "inextensible", "shear-rigid", "kirchhoff")),
]


def build(p, comm):
    radius = LENGTH / (2 * p["slenderness"])
    A, I = np.pi * radius**2, np.pi * radius**4 / 4
    EA, GA, GJ, EI = p["E"] * A, p["G"] * A, p["G"] * 2 * I, p["E"] * I
    scale = 1 / EI                                   # force unit: EI / (1 m^2)
    C_N = np.array([1 / EA, 1 / GA, 1 / GA]) / scale
    if p["constraint"] in ("inextensible", "kirchhoff"):
        C_N[0] = 0.0
    if p["constraint"] in ("shear-rigid", "kirchhoff"):
        C_N[1:] = 0.0
    C_M = np.array([1 / GJ, 1 / EI, 1 / EI]) / scale
    rod = CosseratRod(0.0, (0.0, 0.0, 0.0), C_N, C_M)
    rod.section = Section.round(radius)              # what surface/ and the pictures draw
    moment = scale * KAPPA * np.array([GJ * C, 0.0, EI])
    d1 = np.array([1.0, 0.0, C]) / np.sqrt(1 + C**2)
    directors = (d1, np.array([0.0, 1.0, 0.0]), np.array([-C, 0.0, 1.0]) / np.sqrt(1 + C**2))
    initial = straight((0.0, -R0, 0.0), directors)
    return Problem(rod, LENGTH, p["n_elements"], loads=[end_moment(smooth_ramp(moment, p["t_end"]), "body")],
                   supports=[Support("left", "clamped")], initial=initial, integrator=p["integrator"],
                   comm=comm, newton_options=NEWTON)


def reference(p):
    """The exact helix: tip at (0, -R0, height)."""
    return {"tip_x": 0.0, "tip_y": -R0, "tip_z": HEIGHT, "scale": LENGTH}


scene = Scene("helix-3d", "straight rod bent into a two-coil helix by a body-fixed end moment (Harsch et al. 2021)",
              parameters, build, reference=reference)

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
