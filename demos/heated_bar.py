# # Heated bar: free thermal expansion and clamped thermal stress
#
# A straight thermoelastic string (forms/thermoelastic_string.py) of reference
# length L along x, at the uniform temperature theta0 + dtheta.  The free energy
#
#     psi(C, theta) = W(C) - EA alpha (theta - theta0) (C - 1)/2 + c (theta - theta0 - theta ln(theta/theta0))
#
# gives the tension N = [2 W'(C) - EA alpha (theta - theta0)] sqrt(C).  Two closed forms:
#
# * `ends=clamped`: both ends pinned at the reference length (C = 1, W'(1) = 0):
#   N = -EA alpha dtheta (compression when heated), exactly.
# * `ends=free`: no support; the stress-free strain solves 2 W'(C) = EA alpha dtheta,
#   for kirchhoff (C - 1)/2 = alpha dtheta: the length L sqrt(1 + 2 alpha dtheta)
#   = L (1 + alpha dtheta) + O(dtheta^2), i.e. Delta L = alpha L dtheta to first order.
#
# Either state is a discrete equilibrium: with the uniform temperature no heat flows,
# the tension is uniform and the momentum rows balance node by node, so the run
# stays at rest (v = 0 to solver tolerance) and the history shows `arc_length`
# and `mean_tension` at their closed forms for every t.  `ends=free start=reference`
# releases the free bar from its reference length instead: it vibrates about the
# stress-free length (no damping: the temperature stays uniform), with H (kinetic +
# internal energy) conserved to round-off.
#
# Run it:  rodfem run heated-bar --set ends=clamped --out results/heated-bar

import sys

import numpy as np

from rodfem import Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.demos.hanging_cable import material_parameters
from rodfem.forms.string_materials import MATERIALS
from rodfem.forms.thermoelastic_string import ThermoelasticString, stress_free_strain


def thermal_parameters(alpha=1e-3, c=1.0, kappa=0.1, theta0=300.0):
    """The thermal parameters of a thermoelastic string scene."""
    return [
        Parameter("alpha", alpha, "1/K", "thermal expansion coefficient", low=0),
        stiffness("c", c, "J/(K m)", "heat capacity per reference length"),
        Parameter("kappa", kappa, "W m/K", "thermal conductivity x cross-section area", low=0),
        stiffness("theta0", theta0, "K", "reference temperature (stress-free at C = 1)"),
    ]


def thermoelastic_model(p):
    return ThermoelasticString(MATERIALS[p["material"]](EA=p["EA"]), p["rhoA"], p["alpha"], p["c"], p["kappa"],
                               p["theta0"])


parameters = common(n_elements=10, dt=0.01, t_end=0.1, integrator="discrete-gradient", frames=10) + \
    material_parameters(material="kirchhoff", EA=100.0) + thermal_parameters() + [
    stiffness("L", 1.0, "m", "reference (unstretched) length"),
    Parameter("dtheta", 50.0, "K", "uniform temperature rise theta - theta0 (> -theta0)"),
    Parameter("ends", "free", "", "free: no support; clamped: both ends pinned at the reference length",
              choices=("free", "clamped")),
    Parameter("start", "expanded", "", "free bar: start at its stress-free length (expanded) or at L (reference)",
              choices=("expanded", "reference")),
]


def free_strain(p):
    """C of the stress-free free bar at theta0 + dtheta."""
    return stress_free_strain(MATERIALS[p["material"]](EA=p["EA"]), p["EA"] * p["alpha"], p["dtheta"])


def reference(p):
    """The closed forms: clamped N = -EA alpha dtheta at length L; free (expanded) N = 0 at
    L sqrt(C_free) (kirchhoff: L sqrt(1 + 2 alpha dtheta))."""
    if p["ends"] == "clamped":
        return {"arc_length": p["L"], "mean_tension": -p["EA"] * p["alpha"] * p["dtheta"], "scale": p["L"]}
    if p["start"] == "expanded":
        return {"arc_length": p["L"] * np.sqrt(free_strain(p)), "mean_tension": 0.0, "scale": p["L"]}
    return None


def build(p, comm):
    if not p["dtheta"] > -p["theta0"]:
        from rodfem.errors import ParameterError
        raise ParameterError(f"parameter 'dtheta' must be > -theta0 = {-p['theta0']:g} K (got {p['dtheta']:g})")
    theta = p["theta0"] + p["dtheta"]
    stretch = np.sqrt(free_strain(p)) if p["ends"] == "free" and p["start"] == "expanded" else 1.0
    initial = {"r": lambda x: np.vstack([stretch * x[0], 0 * x[0], 0 * x[0]]),
               "theta": lambda x: np.full(x.shape[1], theta)}
    supports = [Support("left", "pinned"), Support("right", "pinned")] if p["ends"] == "clamped" else []
    return Problem(thermoelastic_model(p), p["L"], p["n_elements"], supports=supports, initial=initial,
                   integrator=p["integrator"], comm=comm)


scene = Scene("heated-bar", "thermoelastic bar at a uniform temperature rise: free expansion (free) or "
              "thermal stress -EA alpha dtheta (clamped)", parameters, build, reference=reference,
              reference_is_static=False,
              notes="arc_length and mean_tension against the closed forms (see the demo's comments).")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
