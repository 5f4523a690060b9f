# # Planar cantilever: load, release, vibrate
#
# A straight cantilever (clamped at s = 0) of a steel strip 10 mm x 10 mm x
# 1 m by default.  A tip force (fx, fy) acts until t_load (switched on over
# t_ramp, 0 = suddenly) and is then released, so the free vibration after a
# load can be studied; gravity g acts on the mass per length.
#
# The axial wave speed sqrt(EA/rhoA) = 5.2 km/s limits an explicit code to
# dt < L/(n c) = 2e-5 s at 10 elements; the midpoint rule runs at dt = 1e-3.
#
# Statics: set rhoA = rhoI = 0, t_ramp = t_load = t_end (a smooth ramp).
#
# Damping (docs/guide/damping.md): tau_kv = eta/E adds Kelvin-Voigt dashpots
# (viscous stresses tau_kv (EA, GA, EI) times the strain rates: mode k decays
# with the damping ratio tau_kv omega_k / 2), rayleigh_alpha a force
# -alpha rho v (ratio alpha / (2 omega_k)).
#
# Run it:  rodfem run cantilever-2d --set fy=-10 --out results/cantilever-2d
#          rodfem run cantilever-2d --set tau_kv=8e-4 --out results/cantilever-2d-damped

import sys

import numpy as np

from rodfem import Load, Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, density, stiffness
from rodfem.demos._damping import damping_parameters
from rodfem.demos._planar import beam, material_parameters

parameters = common(n_elements=10, dt=1e-3, t_end=1.0) + material_parameters() + [
    stiffness("L", 1.0, "m", "length"),
    stiffness("EA", 2.1e7, "N", "axial stiffness (E = 210 GPa, A = 1e-4 m^2)"),
    stiffness("GA", 6.73e6, "N", "shear stiffness (k G A, k = 5/6)"),
    stiffness("EI", 175.0, "N m^2", "bending stiffness (I = 8.33e-10 m^4)"),
    density("rhoA", 0.785, "kg/m", "mass per length"),
    density("rhoI", 6.54e-6, "kg m", "rotary inertia per length"),
    Parameter("g", 0.0, "m/s^2", "gravity, acting in -y"),
    Parameter("fx", 0.0, "N", "tip force, x"),
    Parameter("fy", -1.0, "N", "tip force, y"),
    Parameter("t_load", 0.25, "s", "the tip force acts for t <= t_load", low=0),
    Parameter("t_ramp", 0.0, "s", "the tip force rises linearly over [0, t_ramp]", low=0),
] + damping_parameters()


def tip_force(p):
    F = np.array([p["fx"], p["fy"]])

    def u(t):
        if t > p["t_load"]:
            return 0 * F
        return F * (min(t / p["t_ramp"], 1.0) if p["t_ramp"] > 0 else 1.0)
    return u


def build(p, comm):
    loads = [Load("v", tip_force(p), "right", "tip force")]
    if p["g"] != 0:
        loads.append(Load("v", [0.0, -p["rhoA"] * p["g"]], "domain", "gravity"))
    initial = {"r": lambda x: np.vstack([x[0], 0 * x[0]])}
    return Problem(beam(p), p["L"], p["n_elements"], loads=loads, supports=[Support("left", "clamped")],
                   initial=initial, integrator=p["integrator"], comm=comm)


def reference(p):
    """Euler-Bernoulli + shear static tip deflection under fy (linear theory).

    Only for the static set-up (rhoA = rhoI = 0, no gravity, fx = 0, the load
    still on at t_end); None otherwise, so that `rodfem study` uses a refined run.
    """
    static = p["rhoA"] == 0 and p["rhoI"] == 0 and p["g"] == 0 and p["fx"] == 0 and p["t_load"] >= p["t_end"]
    if not static:
        return None
    return {"tip_y": p["fy"] * (p["L"] ** 3 / (3 * p["EI"]) + p["L"] / p["GA"])}


scene = Scene("cantilever-2d", "clamped beam: tip force held until t_load, then free vibration; gravity optional",
              parameters, build, reference=reference)

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
