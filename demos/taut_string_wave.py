# # Taut string: a transverse pulse travelling at the wave speed
#
# A string of reference length L is stretched uniformly by the factor
# `stretch` (lambda_0) and pinned at both ends, r(0) = 0, r(L) = lambda_0 L e_x.
# Its tension is N = 2 W'(lambda_0^2) lambda_0 (the material decides; for
# kirchhoff N = EA/2 (lambda_0^3 - lambda_0)).  A small Gaussian bump
# w(s) = a exp(-(s - s_0)^2 / (2 sigma^2)) in y starts with the velocity
# -c_s w'(s), so that a single pulse runs towards s = L.
#
# ## The wave speed, and which one
#
# Linearise about r = lambda_0 s e_x with a small transverse displacement w(s, t):
# the contact force n = S d_s r has the transverse part S d_s w, with
# S = 2 W'(lambda_0^2) = N / lambda_0, so rhoA w_tt = S w_ss.  rhoA is mass per
# REFERENCE length, hence
#
#     c_s = sqrt(S / rhoA) = sqrt(N / (rhoA lambda_0))     in the reference coordinate s,
#     c   = lambda_0 c_s  = sqrt(N / mu),  mu = rhoA / lambda_0   in space (x = lambda_0 s).
#
# c = sqrt(N/mu) is the textbook sqrt(tension / mass per length) with the
# mass per length of the STRETCHED string, mu.  (With the reference density,
# sqrt(N/rhoA) would be off by the factor sqrt(lambda_0): 4.9 % at the
# default lambda_0 = 1.1, which the test tells apart.)  The pulse crosses the
# length (L/2 in s by default) in t_end = 0.5 L / c_s; `speeds` gives c.
#
# Run it:  rodfem run taut-string-wave --out results/taut-string-wave

import sys

import numpy as np

from rodfem import Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.demos._damping import damping_parameters
from rodfem.demos.hanging_cable import material_parameters, string_model
from rodfem.forms.string import MATERIALS

parameters = common(n_elements=100, dt=2e-3, t_end=0.16, integrator="discrete-gradient", frames=20) + \
    material_parameters(material="kirchhoff", EA=100.0) + [
    stiffness("L", 1.0, "m", "reference (unstretched) length"),
    Parameter("stretch", 1.1, "", "pre-stretch lambda_0 = distance of the pins / L", low=1, low_open=True, high=10),
    Parameter("amplitude", 1e-3, "m", "height a of the Gaussian pulse"),
    stiffness("width", 0.05, "m", "standard deviation sigma of the pulse (in s)"),
    Parameter("s0", 0.25, "m", "initial centre of the pulse (in s)", low=0),
] + damping_parameters()


def speeds(p):
    """(N, c_s, c): tension, reference-coordinate and spatial transverse wave speeds."""
    lam = p["stretch"]
    N = MATERIALS[p["material"]](EA=p["EA"]).tension(lam)
    c_s = np.sqrt(N / (p["rhoA"] * lam))
    return N, c_s, lam * c_s


def build(p, comm):
    lam, a, sig, s0 = p["stretch"], p["amplitude"], p["width"], p["s0"]
    N, c_s, c = speeds(p)
    if not N > 0:
        from rodfem.errors import ParameterError
        raise ParameterError(f"parameter 'stretch': the material {p['material']} has no tension at "
                             f"lambda_0 = {lam:g} (N = {N:g})")

    def bump(s):
        return a * np.exp(-((s - s0) ** 2) / (2 * sig ** 2))

    initial = {
        "r": lambda x: np.vstack([lam * x[0], bump(x[0]), 0 * x[0]]),
        # w(s, t) = bump(s - c_s t):  v_y = -c_s bump'(s)
        "v": lambda x: np.vstack([0 * x[0], c_s * (x[0] - s0) / sig ** 2 * bump(x[0]), 0 * x[0]]),
    }
    # both ends pinned at their initial positions (0 and lambda_0 L e_x); no load
    problem = Problem(string_model(p), p["L"], p["n_elements"], initial=initial,
                      supports=[Support("left", "pinned"), Support("right", "pinned")],
                      integrator=p["integrator"], comm=comm)
    return problem


scene = Scene("taut-string-wave", "pre-stretched string pinned at both ends; a transverse pulse runs at sqrt(N/mu)",
              parameters, build,
              notes="c = sqrt(N/mu), mu = rhoA/stretch the mass per stretched length (see the demo's comments).")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
