# # Flexible four-bar mechanism under gravity
#
# Three steel beams joined by pins swing under their own weight.  The crank
# runs from the ground pivot (0, 0) to (2, 1), the coupler from (2, 1) to
# (3.5, 1), the rocker from (3.5, 1) to the ground pivot (2.5, 0).  Every
# pin shares the position of the two ends it joins and leaves their angles
# free.  Data of Kinon, Betsch & Eugster (Multibody Syst. Dyn. 2025), after
# Yu et al.: square section 0.05 m, E = 210 GPa, nu = 0.3, G = E/(2(1 + nu))
# with no shear correction, rho = 2710 kg/m^3, g = 9.81 m/s^2; at rest and
# straight at t = 0; h = 0.02, T = 10; 10/6/6 elements, 2 Gauss points.
#
# What to look at: `marker_x, marker_y` (the node at mid-span of the
# coupler, initially (2.75, 1)), the energy balance H_{n+1} - H_n = h y.u
# (gravity is the input: H - supplied stays constant), and
# `constraint_residual`, the largest gap |g(q)| of the two pins (round-off:
# the pin condition is linear in the positions).  The reactions of the pins
# are the columns `pin_crank_coupler.lambda1, 2` (forces in N).
#
# Run it:  rodfem run four-bar-2d --out results/four-bar-2d
#          rodfem run four-bar-2d --set E2=2.1e8 --set dt=0.005   (the softer coupler)

import sys

import numpy as np

from rodfem import Load, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, density, stiffness
from rodfem.core.system import System
from rodfem.errors import ParameterError
from rodfem.forms import joints
from rodfem.forms.planar_beam import PlanarBeam, quadratic, straight
from rodfem.io.sections import Section

parameters = common(n_elements=6, dt=0.02, t_end=10.0) + [
    stiffness("E", 2.1e11, "Pa", "Young's modulus of crank and rocker"),
    stiffness("E2", 2.1e11, "Pa", "Young's modulus of the coupler (2.1e8: the softer-middle-beam variant)"),
    Parameter("nu", 0.3, "", "Poisson's ratio (G = E / (2 (1 + nu)))", low=-1, high=0.5, low_open=True),
    stiffness("width", 0.05, "m", "side of the square cross-section"),
    density("rho", 2710.0, "kg/m^3", "mass density"),
    Parameter("g", 9.81, "m/s^2", "gravity, acting in -y"),
    Parameter("gauss_points", 2, "", "Gauss points per element (the authors' code: 2)", low=1, high=10),
]
# n_elements is the number of elements of the coupler and of the rocker; the
# crank gets 10/6 as many (10/6/6 by default), as in the authors' study.

CRANK = ((0.0, 0.0), (2.0, 1.0))
COUPLER = ((2.0, 1.0), (3.5, 1.0))
ROCKER = ((3.5, 1.0), (2.5, 0.0))


def beam(p, E):
    """A steel beam of the square section: EA, GA = G A (no shear correction), EI, rhoA, rhoI."""
    A, I = p["width"] ** 2, p["width"] ** 4 / 12
    G = E / (2 * (1 + p["nu"]))
    beam = PlanarBeam(p["rho"] * A, p["rho"] * I, quadratic(EA=E * A, GA=G * A, EI=E * I),
                      gauss_points=p["gauss_points"])
    beam.section = Section.rectangle(p["width"], p["width"])   # what surface/ and the pictures draw
    return beam


def build(p, comm):
    n = p["n_elements"]
    if n % 2:
        raise ParameterError(f"parameter 'n_elements' must be even (the coupler's mid-span is a node; got {n})")
    four_bar = System(integrator=p["integrator"], comm=comm)

    # ## The bodies: each beam straight between its two joints, with its weight as a load
    def add(name, ends, E, n_el, supports):
        rhoA = p["rho"] * p["width"] ** 2
        gravity = Load("v", [0.0, -rhoA * p["g"]], "domain", f"gravity {name}")
        return four_bar.add(name, beam(p, E), shape=straight(*ends), n_elements=n_el, loads=[gravity],
                            supports=supports)
    crank = add("crank", CRANK, p["E"], round(n * 10 / 6), [Support("left", "pinned")])
    coupler = add("coupler", COUPLER, p["E2"], n, [])
    rocker = add("rocker", ROCKER, p["E"], n, [Support("right", "pinned")])

    # ## The joints: pins between the beams (the ground pivots are the pinned supports above)
    four_bar.join(joints.pin, crank.end, coupler.start, name="pin_crank_coupler")
    four_bar.join(joints.pin, coupler.end, rocker.start, name="pin_coupler_rocker")

    # ## What to record: the coupler's mid-span node
    four_bar.marker("marker", coupler.at(0.5 * np.linalg.norm(np.subtract(*COUPLER))))
    return four_bar


scene = Scene("four-bar-2d", "flexible four-bar mechanism of three pinned steel beams swinging under gravity",
              parameters, build)

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
