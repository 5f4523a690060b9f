# # Heated beam: free thermal expansion and clamped thermal force of a planar beam
#
# A straight thermoelastic planar beam (forms/thermoelastic_beam.py) of reference
# length L along x, at the uniform temperature theta0 + dtheta.  The free energy
#
#     psi(Gamma, kappa, theta) = W(Gamma, kappa) - EA alpha (theta - theta0) Gamma_1
#                                + c (theta - theta0 - theta ln(theta/theta0))
#
# gives the axial force N_1 = dW/dGamma_1 - EA alpha (theta - theta0).  Two closed forms:
#
# * `ends=clamped`: both ends clamped at the reference length (Gamma = 0):
#   N_1 = -EA alpha dtheta (compression when heated), exactly.
# * `ends=free`: no support; N_1 = 0 at dW/dGamma_1 = EA alpha dtheta: for hooke
#   Gamma_1 = alpha dtheta, the length L (1 + alpha dtheta) -- Delta L = alpha L dtheta
#   exactly, the law of this energy; for log-axial the stretch 1/(1 - alpha dtheta).
#
# Either state is a discrete equilibrium (uniform temperature: no heat flows, uniform
# force), so the run stays at rest and `arc_length`, `mean_axial_force` keep their
# closed forms.  `ends=free start=reference` releases the free beam from its reference
# length: it vibrates axially about the expanded length, with H (kinetic + internal
# energy) conserved to round-off and the expansion cooling it (thermoelastic effect).
# `Q` feeds a heat flux (W) into the left end through a HeatFlux port
# (forms/heat_ports.py): the history's `heat_supplied` is its integral Q t.
#
# Run it:  rodfem run heated-beam --set ends=clamped --out results/heated-beam

import sys

import numpy as np

from rodfem import Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, density, stiffness
from rodfem.demos._planar import MATERIALS, material_parameters
from rodfem.demos.heated_bar import thermal_parameters
from rodfem.forms.heat_ports import HeatFlux
from rodfem.forms.thermoelastic_beam import ThermoelasticBeam

parameters = common(n_elements=10, dt=0.01, t_end=0.1, integrator="discrete-gradient", frames=10) + \
    material_parameters() + thermal_parameters() + [
    stiffness("EA", 100.0, "N", "axial stiffness"),
    stiffness("GA", 100.0, "N", "shear stiffness"),
    stiffness("EI", 1.0, "N m^2", "bending stiffness"),
    density("rhoA", 1.0, "kg/m", "mass per length"),
    density("rhoI", 0.01, "kg m", "rotary inertia per length"),
    stiffness("L", 1.0, "m", "reference (unstretched) length"),
    Parameter("dtheta", 50.0, "K", "uniform temperature rise theta - theta0 (> -theta0)"),
    Parameter("Q", 0.0, "W", "heat flux into the left end (a HeatFlux port)"),
    Parameter("ends", "free", "", "free: no support; clamped: both ends clamped at the reference length",
              choices=("free", "clamped")),
    Parameter("start", "expanded", "", "free beam: start at its stress-free length (expanded) or at L (reference)",
              choices=("expanded", "reference")),
]


def free_stretch(p):
    """The stretch 1 + Gamma_1 of the stress-free free beam at theta0 + dtheta (hooke: 1 + alpha dtheta,
    log-axial: 1/(1 - alpha dtheta))."""
    a = p["alpha"] * p["dtheta"]
    return 1.0 + a if p["material"] == "hooke" else 1.0 / (1.0 - a)


def reference(p):
    """The closed forms: clamped N_1 = -EA alpha dtheta at length L; free (expanded) N_1 = 0 at L free_stretch."""
    if p["ends"] == "clamped":
        return {"arc_length": p["L"], "mean_axial_force": -p["EA"] * p["alpha"] * p["dtheta"], "scale": p["L"]}
    if p["start"] == "expanded":
        return {"arc_length": p["L"] * free_stretch(p), "mean_axial_force": 0.0, "scale": p["L"]}
    return None


def build(p, comm):
    from rodfem.errors import ParameterError
    if not p["dtheta"] > -p["theta0"]:
        raise ParameterError(f"parameter 'dtheta' must be > -theta0 = {-p['theta0']:g} K (got {p['dtheta']:g})")
    if p["material"] == "log-axial" and not p["alpha"] * p["dtheta"] < 1:
        raise ParameterError(f"parameter 'dtheta' must be < 1/alpha = {1 / p['alpha']:g} K for log-axial "
                             f"(got {p['dtheta']:g})")
    model = ThermoelasticBeam(p["rhoA"], p["rhoI"], MATERIALS[p["material"]](p["EA"], p["GA"], p["EI"]),
                              p["alpha"], p["c"], p["kappa"], p["theta0"], degree=p["degree"])
    stretch = free_stretch(p) if p["ends"] == "free" and p["start"] == "expanded" else 1.0
    theta = p["theta0"] + p["dtheta"]
    initial = {"r": lambda x: np.vstack([stretch * x[0], 0 * x[0]]),
               "theta": lambda x: np.full(x.shape[1], theta)}
    supports = [Support("left", "clamped"), Support("right", "clamped")] if p["ends"] == "clamped" else []
    loads = [HeatFlux(value=p["Q"], where="left", name="heater")] if p["Q"] != 0 else []
    return Problem(model, p["L"], p["n_elements"], supports=supports, initial=initial, loads=loads,
                   integrator=p["integrator"], comm=comm)


scene = Scene("heated-beam", "thermoelastic planar beam at a uniform temperature rise: free expansion (free) "
              "or thermal axial force -EA alpha dtheta (clamped)", parameters, build, reference=reference,
              reference_is_static=False,
              notes="arc_length and mean_axial_force against the closed forms (see the demo's comments).")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
