# # Heat wave along a sagging string: a flux port at one end, gravity on the whole
#
# A thermoelastic string (forms/thermoelastic_string.py) of reference length L,
# pinned at both ends at `stretch` times its length along x, released at rest
# under gravity (a 'domain' load rhoA g (0, 0, -1) on v): it sags and swings.
# At t = 0 a heat flux Q (W) starts to flow into the end s = 0 (a `HeatFlux`
# port, forms/heat_ports.py); the end s = L is insulated.
#
# The heat conduction is Fourier's law along the reference arc length s
# (material description), so without thermal expansion (alpha = 0, the default)
# the entropy balance theta d_t eta = d_s (kappa d_s theta), eta = c ln(theta/theta0),
# is the linear heat equation c d_t theta = kappa d_ss theta, whatever the string
# does: the temperature profile is the Fourier solution of demos/heat_conduction.py
# (start=flux, `exact`), while the string sags.  The discrete temperature of this
# scene is that of the straight string of heat-conduction to round-off (the
# motion does not enter the alpha = 0 thermal rows) and converges to the exact
# solution with order 2 in space.  With alpha > 0 the string's stretching
# heats or cools it (the thermoelastic term -beta theta d_t m(C) in c d_t theta):
# the profile departs from the heat equation's in proportion to alpha.
#
# Energy bookkeeping: both ports supply work, gravity's work and the heat;
# `heat_supplied` (the heat meter, forms/heat_ports.py) is the heat, Q t to
# round-off, and supplied - heat_supplied is gravity's work; H - supplied stays
# constant to round-off (discrete gradient).
#
# Run it:  rodfem run heat-wave-string --out results/heat-wave-string

import sys

import numpy as np

from rodfem import Load, Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.demos.hanging_cable import material_parameters
from rodfem.demos.heat_conduction import exact
from rodfem.demos.heated_bar import thermal_parameters, thermoelastic_model
from rodfem.forms.heat_ports import HeatFlux

parameters = common(n_elements=32, dt=1e-3, t_end=0.05, integrator="discrete-gradient", frames=10) + \
    material_parameters(material="logarithmic", EA=100.0) + thermal_parameters(alpha=0.0, c=1.0, kappa=1.0) + [
    stiffness("L", 1.0, "m", "reference (unstretched) length"),
    Parameter("stretch", 1.02, "", "distance between the pinned ends / L (> 0)", low=0, low_open=True),
    Parameter("g", 9.81, "m/s^2", "gravity, acting in -z", low=0),
    Parameter("Q", 100.0, "W", "heat flux into the end s = 0"),
]


def profile(p, s, t):
    """The heat equation's temperature theta(s, t) under the flux Q into s = 0 (demos/heat_conduction.py)."""
    return exact({**p, "start": "flux"}, s, t)


def reference(p):
    """The end temperatures at t_end (alpha = 0 only: the linear heat equation)."""
    if p["alpha"] != 0 or p["kappa"] == 0:
        return None
    left, right = profile(p, [0.0, p["L"]], p["t_end"])
    return {"temperature_left": float(left), "temperature_right": float(right),
            "scale": float(abs(left - right)) or 1.0}


def build(p, comm):
    a = p["stretch"]
    initial = {"r": lambda x: np.vstack([a * x[0], 0 * x[0], 0 * x[0]]),
               "theta": lambda x: np.full(x.shape[1], p["theta0"])}
    loads = [HeatFlux(value=p["Q"], where="left", name="heater")]
    if p["g"] > 0:
        loads.append(Load("v", [0.0, 0.0, -p["rhoA"] * p["g"]], "domain", "gravity"))
    return Problem(thermoelastic_model(p), p["L"], p["n_elements"], loads=loads, initial=initial,
                   supports=[Support("left", "pinned"), Support("right", "pinned")],
                   integrator=p["integrator"], comm=comm)


scene = Scene("heat-wave-string", "thermoelastic string heated at one end by a flux port while it sags under "
              "gravity: the temperature against the 1D heat equation's exact solution", parameters, build,
              reference=reference, reference_is_static=False,
              notes="temperature_left/right against the exact Fourier solution (alpha = 0; see the demo's comments).")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
