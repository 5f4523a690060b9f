# # A chain of many short links falling from horizontal
#
# The classic many-body benchmark: a chain of N rigid links (default 16;
# 1000 with --set n_links=1000) of total length L and total mass M, pinned
# to the ground at one end, lies straight along x at rest and falls under
# gravity (-z).  Each link is a thin uniform rod (length l = L/N, radius r = slenderness l):
# a director-based 3D rigid body (forms/rigid_body.py) with principal
# moments J_1 = m r^2/2 about its axis d1 and J_2 = J_3 = m (l^2/12 + r^2/4).
# Neighbouring links share their end points by a revolute joint about the
# links' d2 (= y, forms/joints.py: 5 conditions), the first link turns
# about the y axis of the ground: a planar N-pendulum of compound links,
# written in 3D coordinates.
#
# Every joint condition is quadratic in the directors' coordinates, H is
# quadratic (1/2 m |v|^2 + 1/2 sum E_i |w_i|^2) and gravity is an input
# (a load on v, its work the `supplied` column), so the midpoint rule gives
#
#     H_{n+1} - H_n = supplied_step          (to round-off)
#
# and every joint's gap g(q) = 0 and each link's d_i . d_j = delta_ij hold to
# round-off for all time (`constraint_residual`, `orthonormality`).
# Independent check (tests/models/test_many_scenes.py): the same chain in
# minimal coordinates (the N link angles), integrated by scipy's solve_ivp.
#
# What to look at: the free end `tip_x, tip_z` whipping round as the chain
# swings through the vertical, H - supplied (constant), `constraint_residual`.
#
# Run it:  rodfem run chain-1000 --out results/chain
#          rodfem run chain-1000 --set n_links=1000 --set t_end=0.2 --out results/chain-1000

import sys

from rodfem import Load, System
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.core.joints import ground
from rodfem.demos._multibody import orthonormality, rod_inertia
from rodfem.forms import joints
from rodfem.forms.rigid_body import RigidBody

parameters = [p for p in common(n_elements=1, dt=0.005, t_end=1.0) if p.name not in ("n_elements", "section")] + [
    Parameter("n_links", 16, "", "number of links", low=1, high=100000),
    stiffness("L", 1.0, "m", "length of the chain"),
    stiffness("mass", 1.0, "kg", "mass of the chain"),
    Parameter("slenderness", 0.05, "", "radius / length of a link (its inertia about its own axis)", low=0,
              high=0.49, low_open=True),
    Parameter("g", 9.81, "m/s^2", "gravity, acting in -z", low=0),
]


def build(p, comm):
    N, L = p["n_links"], p["L"]
    l, m = L / N, p["mass"] / N
    # (full Newton at every size: at 1000 links, 35,000 unknowns, rodfem would reuse the Jacobian over
    # iterations; that chord Newton fails here now and then, and the solver then falls back to a
    # pivoting LU for the rest of the run: 123 ms per step against 93 with full Newton; under mpirun each
    # link is built whole on one rank: many small bodies, distribute=True)
    chain = System(integrator=p["integrator"], comm=comm, newton_options={"snes_lag_jacobian": 1}, distribute=True)
    model = RigidBody(m, rod_inertia(m, l, p["slenderness"] * l))

    # ## The links, straight along x, at rest, each with its weight as an input
    links = [chain.add(f"link{k}", model, initial=RigidBody.initial(((k + 0.5) * l, 0.0, 0.0)),
                       loads=[Load("v", [0.0, 0.0, -m * p["g"]], "domain", f"gravity link{k}")] if p["g"] > 0 else [])
             for k in range(N)]

    # ## Revolute joints about y: the ground pivot at the origin, then end to end
    hinge = joints.revolute(axis=1)
    chain.join(hinge, ground((0.0, 0.0, 0.0)), links[0].point((-0.5 * l, 0.0, 0.0)), name="pivot")
    for k in range(1, N):
        chain.join(hinge, links[k - 1].point((0.5 * l, 0.0, 0.0)), links[k].point((-0.5 * l, 0.0, 0.0)),
                   name=f"hinge{k}")
    chain.marker("tip", links[-1].point((0.5 * l, 0.0, 0.0)))
    chain.record(lambda s: {"orthonormality": orthonormality(system=s)})
    return chain


scene = Scene("chain-1000", "a chain of rigid links on revolute joints, pinned at one end, falling from horizontal",
              parameters, build,
              notes="Midpoint rule: H - supplied constant and the joints' gaps at round-off; "
                    "--set n_links=1000 for the classic benchmark.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
