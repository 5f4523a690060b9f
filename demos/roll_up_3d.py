# # Roll-up of a cantilever (3D Cosserat rod, static)
#
# A straight rod of length L along x, clamped at s = 0, is bent by an end
# moment about e3 that rises to 2 pi EI/L.  The exact solution is a full
# circle of radius L/(2 pi) in the xy-plane: the tip returns to the clamp.
# (Simo & Vu-Quoc 1986; the planar version is roll-up-2d.)
#
# With --set material=stiffening (bending stiffens up to the locking
# curvature kappa_lock, forms/rod_materials.py) the moment that closes the
# circle is EI kappa / sqrt(1 - kappa^2/kappa_lock^2), kappa = 2 pi/L (the
# material's Legendre transform, computed by the scene): the circle is the same.
#
# The moment is either spatial (m = M e3, fixed in space) or body-fixed
# (M_B = M e3 on the directors: m = M d3).  Here d3 = e3 stays, so both give
# the same circle, but through different input maps <m, 1/2 sum d_i x w_i>.
#
# Statics through the time integrator: with zero densities every midpoint
# step is the equilibrium of the midpoint state under the load at t_{n+1/2}.
# The load follows a smooth ramp with zero rate and acceleration at t_end,
# so the final state is the equilibrium up to O(h^3) in the load step.
#
# Run it:  rodfem run roll-up-3d --out results/roll-up-3d

import sys

import numpy as np

from rodfem import Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.demos._rod3d import NEWTON, end_moment, material, material_parameters, rod, smooth_ramp, straight

EI = 500.0
parameters = common(n_elements=8, dt=0.02, t_end=1.0) + [
    stiffness("L", 10.0, "m", "length"),
    Parameter("moment_frame", "spatial", "", "the end moment is fixed in space or in the body",
              choices=("spatial", "body")),
] + material_parameters(EA=1e4, GA=1e4, GJ=EI, EI=EI, rhoA=0.0, rhoJ=(0.0, 0.0, 0.0),
                      kappa_lock=0.8)


def build(p, comm):
    # The full moment 2 pi EI_3 / L closes the circle (EI_3 = 1/C_M3).
    if p["C_M3"] == 0:
        from rodfem.errors import ParameterError
        raise ParameterError("parameter 'C_M3' must be > 0 here: a rod that cannot bend cannot roll up")
    moment = np.array([0.0, 0.0, closing_moment(p)])
    loads = [end_moment(smooth_ramp(moment, p["t_end"]), p["moment_frame"])]
    initial = straight((0.0, 0.0, 0.0), np.eye(3))
    return Problem(rod(p), p["L"], p["n_elements"], loads=loads, supports=[Support("left", "clamped")],
                   initial=initial, integrator=p["integrator"], comm=comm, newton_options=NEWTON)


def closing_moment(p):
    """The end moment M_3 that bends the rod to the curvature 2 pi/L: 2 pi EI_3/L for the linear law,
    else the material's Legendre transform (numerically: M_3 with dW*/dM_3 = 2 pi/L; for
    'stiffening' the closed form EI kappa / sqrt(1 - kappa^2/kappa_lock^2))."""
    if p["material"] == "linear":
        return 2 * np.pi / (p["C_M3"] * p["L"])
    kappa = 2 * np.pi / p["L"]
    if p["material"] == "stiffening" and kappa >= p["kappa_lock"]:
        from rodfem.errors import ParameterError
        raise ParameterError(f"parameter 'kappa_lock' must be > 2 pi/L = {kappa:g} here: the rod locks before "
                             "it closes the circle")
    return float(material(p).stresses([0.0, 0.0, 0.0, 0.0, 0.0, kappa])[5])


def reference(p):
    """Exact circle at t_end: the tip is back at the clamp (0, 0, 0)."""
    return {"tip_x": 0.0, "tip_y": 0.0, "tip_z": 0.0, "scale": p["L"]}


scene = Scene("roll-up-3d", "cantilever rolled into a full circle by an end moment 2 pi EI/L (3D rod, static)",
              parameters, build, reference=reference)

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
