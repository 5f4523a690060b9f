# # Viscoelastic 3D cantilever: a tip wrench, then free (damped) vibration
#
# The dynamic cantilever of Herrmann & Kotyczka (2024), also used by Kinon,
# Eugster & Betsch for their viscoelastic director rod: a thin aluminium rod
# (L = 1 m, circular section of radius 2 mm, E = 72 GPa, nu = 0.35,
# rho = 2850 kg/m^3) clamped at s = 0 along x, no gravity.  A tip wrench in
# the rod's own frame acts during t in [0, 0.05] s (a torque about the axis
# d1 and a force on d2 and d3), then the rod vibrates freely until
# T = 0.3 s, with h = 1 ms.
#
# The rod is inextensible and shear-rigid, as the Kirchhoff beam of Herrmann & Kotyczka (2024), doi 10.1016/j.cma.2024.117367: the
# compliances C_N of the equilibrium branch are ZERO (N is the multiplier of
# d_t Gamma = 0).  Torsion and bending are elastic (E, G = E/(2(1 + nu)))
# plus one Maxwell branch on the moments M (compliance form, forms/
# cosserat_rod.py): a spring of modulus E1 (G1 = E1/(2(1 + nu)) in torsion)
# in series with a dashpot of relaxation time tau1.  E1 = 0 is the elastic
# rod (no branch, no internal variable).  No branch acts on N: with zero
# strain rates it would stay zero.
#
# What to look at: after the load, H decreases by exactly the dissipated
# energy (history column `dissipated`), step by step to solver tolerance:
# H + dissipated - supplied is constant (energy.png).
#
# Not from the sources: the time profile of the wrench (Herrmann & Kotyczka's "profile 4"
# of their toolbox is not public); here a smooth pulse sin^2(pi t / t_load)
# with the peak values of their wrench 0.5 [0.5 0 0 0 2 2] (torque 0.25 N m
# about d1, force 1 N on d2 and on d3, body frame) -- also the order
# [moment; force] of that vector is inferred.  The Maxwell parameters of the
# published dissipative run are not known either: E1 = 0.1 E and tau1 = 0.05 s
# are this scene's choice (tau1 near 1/omega_1 of the first bending mode,
# where one branch damps that mode most).
#
# Kelvin-Voigt damping instead of (or beside) the branch: tau_kv = eta/E puts
# dashpots eta_i = tau_kv (GJ, EI, EI) on torsion and bending (docs/guide/
# damping.md); --set E1=0 --set tau_kv=1e-3 is a Kelvin-Voigt rod.
#
# Run it:  rodfem run viscoelastic-cantilever-3d --out results/viscoelastic-cantilever-3d
#          rodfem run viscoelastic-cantilever-3d --set E1=0 --out results/cantilever-3d-elastic

import sys

import numpy as np

from rodfem import Load, Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, relaxation_time, stiffness
from rodfem.demos._damping import damping, damping_parameters
from rodfem.demos._rod3d import NEWTON, end_moment, straight
from rodfem.forms import cosserat_rod
from rodfem.io.sections import Section

parameters = common(n_elements=8, dt=1e-3, t_end=0.3) + [
    stiffness("L", 1.0, "m", "length"),
    stiffness("radius", 2e-3, "m", "radius of the circular cross-section"),
    stiffness("E", 7.2e10, "Pa", "Young's modulus (equilibrium branch)"),
    Parameter("nu", 0.35, "", "Poisson's ratio (G = E/(2(1 + nu)))", low=0, high=0.5),
    stiffness("rho", 2850.0, "kg/m^3", "density"),
    Parameter("E1", 7.2e9, "Pa", "Maxwell branch modulus (0: elastic rod)", low=0),
    relaxation_time("tau1", 0.05, "Maxwell branch relaxation time (inf: a parallel spring)"),
    Parameter("M1", 0.25, "N m", "peak tip torque about the axis d1 (body frame)"),
    Parameter("F2", 1.0, "N", "peak tip force on d2 (body frame)"),
    Parameter("F3", 1.0, "N", "peak tip force on d3 (body frame)"),
    stiffness("t_load", 0.05, "s", "the wrench acts for t <= t_load (a sin^2 pulse)"),
] + damping_parameters()


def section(p):
    """A, I (= I_2 = I_3), J = 2 I of the circular section and G."""
    A = np.pi * p["radius"] ** 2
    I = np.pi * p["radius"] ** 4 / 4
    return A, I, 2 * I, p["E"] / (2 * (1 + p["nu"]))


def rod(p):
    """Inextensible, shear-rigid rod (C_N = 0), elastic in torsion and bending, plus the Maxwell branch
    and the Kelvin-Voigt / Rayleigh damping (tau_kv, rayleigh_alpha)."""
    A, I, J, G = section(p)
    branches = []
    if p["E1"] > 0:
        G1 = p["E1"] / (2 * (1 + p["nu"]))
        branches.append(cosserat_rod.maxwell(p["tau1"], C_M=(1 / (G1 * J), 1 / (p["E1"] * I), 1 / (p["E1"] * I))))
    C_N, C_M = (0.0, 0.0, 0.0), (1 / (G * J), 1 / (p["E"] * I), 1 / (p["E"] * I))
    rod = cosserat_rod.CosseratRod(p["rho"] * A, (p["rho"] * J, p["rho"] * I, p["rho"] * I), C_N=C_N, C_M=C_M,
                                   branches=branches, damping=damping(p, cosserat_rod.rayleigh, C_N, C_M))
    rod.section = Section.round(p["radius"])   # what surface/ and the pictures draw
    return rod


def pulse(value, t_load):
    """u(t) = value sin^2(pi t / t_load) for t <= t_load, 0 after (smooth, zero at both ends)."""
    value = np.asarray(value, dtype=float)
    return lambda t: value * np.sin(np.pi * t / t_load) ** 2 if t <= t_load else 0 * value


def body_force(u, xm, w):
    """Pairing of a body-fixed force F_B: the spatial force sum_i F_B,i d_i (midpoint directors) on v."""
    f = sum((u[i] * xm[d] for i, d in enumerate(cosserat_rod.DIRECTORS)), 0 * xm["v"])
    return f[0] * w["v"][0] + f[1] * w["v"][1] + f[2] * w["v"][2]


def build(p, comm):
    loads = [end_moment(pulse([p["M1"], 0.0, 0.0], p["t_load"]), "body", name="tip torque"),
             Load("v", pulse([0.0, p["F2"], p["F3"]], p["t_load"]), "right", "tip force (body)", pairing=body_force)]
    return Problem(rod(p), p["L"], p["n_elements"], loads=loads, supports=[Support("left", "clamped")],
                   initial=straight((0.0, 0.0, 0.0), np.eye(3)), integrator=p["integrator"], comm=comm,
                   newton_options=NEWTON)


scene = Scene("viscoelastic-cantilever-3d",
              "inextensible 3D cantilever (Herrmann & Kotyczka): tip wrench, then vibration damped by a Maxwell branch on M",
              parameters, build,
              notes="E1 = 0: the elastic rod. H + dissipated - supplied is conserved.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
