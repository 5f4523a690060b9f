# # Heat conduction along a string: the 1D heat equation's exact solutions
#
# A straight thermoelastic string (forms/thermoelastic_string.py) of length L, pinned at
# both ends at its reference length, with conductivity kappa (times the area) and heat
# capacity c per length.  Without thermal expansion (alpha = 0, the default here) the
# entropy balance theta d_t eta = -d_s q with eta = c ln(theta/theta0) is the linear heat
# equation
#
#     c d_t theta = kappa d_ss theta,     D = kappa / c,
#
# with two exact solutions:
#
# * `start=cosine`, insulated ends: theta = theta0 + A exp(-D pi^2 t / L^2) cos(pi s / L).
#   The string is isolated: H (the internal energy) is conserved to round-off and the
#   entropy grows by h int kappa (d_s theta/theta)^2 ds >= 0 every step.
# * `start=flux`: theta = theta0 at t = 0 and a heat flux Q into the end s = 0 (a
#   `HeatFlux` port, forms/heat_ports.py; input Q, output the end's temperature), the end
#   s = L insulated.  With x = s/L,
#
#       theta = theta0 + Q t / (c L) + (Q L / kappa) [ (1 - x)^2 / 2 - 1/6
#               - 2 sum_{n >= 1} exp(-n^2 pi^2 D t / L^2) cos(n pi x) / (n pi)^2 ],
#
#   (the series is the Fourier cosine series of the quadratic at t = 0, so theta(s, 0) =
#   theta0; -kappa d_s theta = Q at s = 0).  The mean temperature theta0 + Q t/(c L) is
#   the energy balance: exact to round-off in the discrete model.
#
# `reference(p)` gives the end temperatures at t_end (history columns temperature_left,
# temperature_right), so `rodfem study heat-conduction` measures the order in space
# (P1: 2) and in time (midpoint: 2).
#
# Run it:  rodfem run heat-conduction --out results/heat-conduction

import sys

import numpy as np

from rodfem import Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.demos.hanging_cable import material_parameters
from rodfem.demos.heated_bar import thermal_parameters, thermoelastic_model
from rodfem.forms.heat_ports import Convection, HeatFlux

parameters = common(n_elements=32, dt=1e-3, t_end=0.05, integrator="discrete-gradient", frames=10) + \
    material_parameters(material="kirchhoff", EA=100.0) + thermal_parameters(alpha=0.0, c=1.0, kappa=1.0) + [
    stiffness("L", 1.0, "m", "reference (unstretched) length"),
    Parameter("start", "flux", "", "cosine: initial cos(pi s/L) profile, insulated; flux: heat flux Q into s = 0",
              choices=("cosine", "flux")),
    Parameter("amplitude", 10.0, "K", "start=cosine: amplitude A of the initial profile (< theta0)", low=0),
    Parameter("Q", 100.0, "W", "start=flux: heat flux into the end s = 0"),
    Parameter("h_c", 0.0, "W/(m K)", "convection to an environment at theta0 (0: none; the exact solutions "
              "need 0)", low=0),
]


def exact(p, s, t, terms=2000):
    """theta(s, t) of the 1D heat equation (see the comments above)."""
    L, D, th0 = p["L"], p["kappa"] / p["c"], p["theta0"]
    s = np.asarray(s, dtype=float)
    x = s / L
    if p["start"] == "cosine":
        return th0 + p["amplitude"] * np.exp(-D * np.pi ** 2 * t / L ** 2) * np.cos(np.pi * x)
    n = np.arange(1, terms + 1)[:, None]
    series = np.sum(np.exp(-(n * np.pi) ** 2 * D * t / L ** 2) * np.cos(n * np.pi * x) / (n * np.pi) ** 2, axis=0)
    return th0 + p["Q"] * t / (p["c"] * L) + p["Q"] * L / p["kappa"] * ((1 - x) ** 2 / 2 - 1 / 6 - 2 * series)


def reference(p):
    """The end temperatures at t_end (only for alpha = 0, h_c = 0: the linear heat equation)."""
    if p["alpha"] != 0 or p["h_c"] != 0 or p["kappa"] == 0:
        return None
    left, right = exact(p, [0.0, p["L"]], p["t_end"])
    return {"temperature_left": float(left), "temperature_right": float(right),
            "scale": float(abs(left - right)) or 1.0}


def build(p, comm):
    if p["start"] == "cosine" and not p["amplitude"] < p["theta0"]:
        from rodfem.errors import ParameterError
        raise ParameterError(f"parameter 'amplitude' must be < theta0 = {p['theta0']:g} K (got {p['amplitude']:g})")
    initial = {"r": lambda x: np.vstack([x[0], 0 * x[0], 0 * x[0]]),
               "theta": lambda x: exact(p, x[0], 0.0) if p["start"] == "cosine" else np.full(x.shape[1], p["theta0"])}
    loads = [HeatFlux(value=p["Q"], where="left", name="heat")] if p["start"] == "flux" else []
    if p["h_c"] > 0:
        loads.append(Convection(value=p["theta0"], h_c=p["h_c"]))
    return Problem(thermoelastic_model(p), p["L"], p["n_elements"], loads=loads,
                   supports=[Support("left", "pinned"), Support("right", "pinned")], initial=initial,
                   integrator=p["integrator"], comm=comm)


scene = Scene("heat-conduction", "thermoelastic string pinned at both ends: heat conduction against the 1D heat "
              "equation's exact solution (cosine mode, or a heat flux port at one end)",
              parameters, build, reference=reference, reference_is_static=False,
              notes="temperature_left/right against the exact Fourier solution (see the demo's comments).")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
