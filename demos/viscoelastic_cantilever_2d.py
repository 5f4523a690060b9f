# # Viscoelastic planar cantilever: load, release, damped vibration
#
# The scene `cantilever-2d` (a steel strip 10 mm x 10 mm x 1 m, clamped at
# s = 0, a tip force until t_load, then free vibration) with one Maxwell
# branch (forms/viscoelastic.py) in parallel with the elastic beam: a spring
# of stiffnesses EA1, GA1, EI1 (default 0.1 x EA, GA, EI) in series with a
# dashpot of relaxation time tau1.  Every parameter of cantilever-2d is here
# too, with the same meaning; EA, GA, EI are the equilibrium (long-term)
# stiffnesses, EA + EA1, ... the instantaneous ones.
#
# The branch's elastic strains (Gamma_1, kappa_1) are internal variables of
# the PH system; the dashpot is its dissipation R = diag(1/(tau1 EA1),
# 1/(tau1 GA1), 1/(tau1 EI1)) >= 0.  The step's discrete balance is
#
#     H_{n+1} - H_n = -h d_n + h y.u,     h d_n >= 0,
#
# exact to solver tolerance for both integrators: the history column
# `dissipated` is sum h d_n, and `balance_error` includes it.
#
# What to look at: the first bending mode (omega_1 = 3.516 sqrt(EI/(rhoA L^4))
# = 52 rad/s with the default data) is damped most when tau1 ~ 1/omega_1
# (default tau1 = 0.02 s); with tau1 -> infinity the beam is elastic with
# stiffness EI + EI1, with tau1 -> 0 elastic with EI.  EA1 = GA1 = EI1 = 0
# gives back cantilever-2d exactly (no branch is built).  The branch spring
# is Hooke's law whatever `material` says.
#
# Run it:  rodfem run viscoelastic-cantilever-2d --set fy=-10 --out results/viscoelastic-cantilever-2d

import sys

import numpy as np

from rodfem import Load, Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, relaxation_time
from rodfem.demos import cantilever_2d
from rodfem.demos._damping import damping
from rodfem.demos._planar import MATERIALS
from rodfem.forms import planar_beam

_elastic = {q.name: q for q in cantilever_2d.parameters}


def branch_stiffness(name, of, doc):
    return Parameter(name, 0.1 * _elastic[of].default, _elastic[of].unit, doc + f" (0.1 x {of} by default; 0: none)",
                     low=0)


parameters = cantilever_2d.parameters + [
    branch_stiffness("EA1", "EA", "Maxwell branch axial stiffness"),
    branch_stiffness("GA1", "GA", "Maxwell branch shear stiffness"),
    branch_stiffness("EI1", "EI", "Maxwell branch bending stiffness"),
    relaxation_time("tau1", 0.02, "Maxwell branch relaxation time (inf: a parallel spring)"),
]


def beam(p):
    """The beam of cantilever-2d (with its Kelvin-Voigt / Rayleigh damping, if set) plus the Maxwell branch."""
    W = MATERIALS[p["material"]](p["EA"], p["GA"], p["EI"])
    branch = planar_beam.maxwell(p["tau1"], EA=p["EA1"], GA=p["GA1"], EI=p["EI1"])
    kv = damping(p, planar_beam.rayleigh, p["EA"], p["GA"], p["EI"])
    return planar_beam.PlanarBeam(p["rhoA"], p["rhoI"], W, degree=p["degree"], branches=[branch], damping=kv)


def build(p, comm):
    loads = [Load("v", cantilever_2d.tip_force(p), "right", "tip force")]
    if p["g"] != 0:
        loads.append(Load("v", [0.0, -p["rhoA"] * p["g"]], "domain", "gravity"))
    initial = {"r": lambda x: np.vstack([x[0], 0 * x[0]])}
    return Problem(beam(p), p["L"], p["n_elements"], loads=loads, supports=[Support("left", "clamped")],
                   initial=initial, integrator=p["integrator"], comm=comm)


scene = Scene("viscoelastic-cantilever-2d",
              "cantilever-2d with one Maxwell branch (EA1, GA1, EI1, tau1): damped vibration after the load",
              parameters, build,
              notes="EA1 = GA1 = EI1 = 0: cantilever-2d itself. H + dissipated - supplied is conserved.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
