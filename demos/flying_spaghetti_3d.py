# # Flying spaghetti (3D Cosserat rod)
#
# A free rod of length L = 10 lies straight from (0, 8, 0) to (6, 0, 0).  At
# the (6, 0, 0) end a force F = (8, 0, 0) and a body-fixed moment act for
# t <= 2.5 and then stop.  Data of the reference code (cardillo's
# flying_spaghetti example, after Kinon, Betsch & Eugster 2025): EA = GA =
# 1e4, GJ = 200, EI = 100, rhoA = 1, rhoJ = diag(10, 10, 10).
#
# Two variants (parameter `variant`):
# * planar:  M_B = (0, 0, M) about d3 = e3: the rod tumbles in the xy-plane
#            (compare with flying-spaghetti-2d);
# * spatial: M_B = (M, 0, 0) about the axis d1, a torsional moment; with the
#            in-plane force it throws the rod out of its plane.
# Fz adds an out-of-plane end force.
#
# After t = 2.5 no load acts: H, p and L (history.csv columns H, p_x..p_z,
# L_x..L_z) must stay constant, and H_{n+1} - H_n = h y.u holds every step.
#
# Run it:  rodfem run flying-spaghetti-3d --set variant=spatial --out results/flying-spaghetti-3d

import sys

import numpy as np

from rodfem import Load, Problem, constant_in_time
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common
from rodfem.demos._rod3d import NEWTON, end_moment, material_parameters, rod, straight

parameters = common(n_elements=10, dt=0.1, t_end=15.0) + [
    Parameter("variant", "planar", "", "body-fixed end moment about d3 (planar) or about the axis d1 (spatial)",
              choices=("planar", "spatial")),
    Parameter("Fx", 8.0, "N", "end force, x"),
    Parameter("Fy", 0.0, "N", "end force, y"),
    Parameter("Fz", 0.0, "N", "end force, z (out of plane)"),
    Parameter("M", -80.0, "N m", "end moment (body-fixed)"),
    Parameter("t_load", 2.5, "s", "the end load acts for t <= t_load", low=0),
] + material_parameters(EA=1e4, GA=1e4, GJ=200.0, EI=100.0, rhoA=1.0, rhoJ=(10.0, 10.0, 10.0))

START, END = np.array([0.0, 8.0, 0.0]), np.array([6.0, 0.0, 0.0])
LENGTH = float(np.linalg.norm(END - START))


def build(p, comm):
    # Directors: d1 along the rod, d3 = e3 out of the plane, d2 = d3 x d1.
    d1, d3 = (END - START) / LENGTH, np.array([0.0, 0.0, 1.0])
    directors = (d1, np.cross(d3, d1), d3)
    # The ports at s = L: the force pairs with v(L), the body-fixed moment
    # with the angular velocity 1/2 sum d_i x w_i at L.
    axis = 2 if p["variant"] == "planar" else 0
    M_B = np.zeros(3)
    M_B[axis] = p["M"]
    loads = [Load("v", constant_in_time([p["Fx"], p["Fy"], p["Fz"]], until=p["t_load"]), "right", "end force"),
             end_moment(constant_in_time(M_B, until=p["t_load"]), "body")]
    return Problem(rod(p), LENGTH, p["n_elements"], loads=loads, initial=straight(START, directors),
                   integrator=p["integrator"], comm=comm, newton_options=NEWTON)


scene = Scene("flying-spaghetti-3d", "free rod tumbling after an end force and a body-fixed (bending or torsional) moment",
              parameters, build)

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
