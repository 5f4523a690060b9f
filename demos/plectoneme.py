# # Plectoneme: a rod twisted at one end buckles, coils around itself and keeps its link
#
# A straight elastic rod (3D Cosserat rod, forms/cosserat_rod.py) of length L = 1, radius r = 0.025,
# mass 1 kg, E = 1e6 and G = E/1.5 (PyElastica's E/(1 + nu) with nu = 0.5), after PyElastica's PlectonemesCase
# (examples/RodContactCase/RodSelfContact/PlectonemesCase): the end s = 0 is clamped; the end s = L is
# turned about the rod's axis (x) at a constant rate, one turn every `turn_time` seconds, for `turns`
# turns, then held.  That end stays on the axis and keeps its tangent along it, but slides freely along
# it (no axial force), so the rod pulls it in as it coils.  A mass-proportional damping (Rayleigh's
# alpha = 2/s: PyElastica's AnalyticalLinearDamper with its damping constant 2/(rho A)) slows the rod;
# it hardly touches the fast torsional and bending waves (damping ratio alpha/(2 omega)) that the snaps
# and the contacts excite and the midpoint rule keeps, so a Kelvin-Voigt damping of retardation time
# tau_kv = 0.01 s takes them out (damping ratio tau_kv omega/2: 0.57 for the first torsional mode,
# omega = pi sqrt(GJ/rhoJ_1)/L = 114/s; while the end turns at a constant rate its viscous torque is
# tau_kv/t of the elastic one after the time t, 0.5 % after 2 s).  The rod starts with a stress-free
# imperfection of amplitude `imperfection` (z = delta sin^2(pi s/L)), which picks the direction it
# buckles in.
#
# Twisted beyond about one turn (Greenhill: the torque 2.86 pi EI/L of a clamped rod without tension,
# which twists it by M L/GJ = 1.07 turns) the straight rod buckles into a loop; the loop tightens until
# the rod touches itself and, turned further, winds around itself: a plectoneme.  Self-contact
# (forms/rod_contact.py: the cubic penalty k/3 <-g>^3 of the gap between the tube's segments, pairs
# closer than pi r along the rod left out) keeps the rod from passing through itself.
#
# ## The link Lk = Tw + Wr (rodfem/analysis/linking.py)
#
# Both ends lie on the axis with their tangents along it, so the rod, its ends extended along the axis
# and closed far away, is a closed ribbon (centreline and the director d2).  Its link cannot change
# unless the rod passes through itself or through the axis' extensions beyond its ends (the closure).
# Self-contact stops the first (and a step that could carry two segments through each other is refused
# and split: rodfem/core/bodycontact.py, `BodyContacts.crossing`); the wall the rod is clamped in (the
# plane x = -r, a penalty contact of the tube, forms/contact.py) stops it swinging round behind the
# clamp, through the axis x < 0: without it the 10-turn plectoneme does so at 9.3 turns (Lk drops by 2
# in a step whose contact pairs all keep a certified clearance of 0.7 R, while the rod passes 0.2 mm
# from the axis behind the clamp).  So the Calugareanu-White relation
#
#     Lk = Tw + Wr = turns imposed (so far)
#
# holds at all times: Tw = (1/2 pi) int (t x d2) . d2' ds the twist (the discrete parallel transport of
# d2 along the polygon through the nodes), Wr the Gauss double integral of the closed polygon (exact per
# segment pair; the far closure contributes O(L/far)).  Fuller's formula relative to the straight rod
# would do only until the rod folds back (the tangent reaching -e_x): a plectoneme does.  Columns Tw, Wr,
# Lk, Lk_imposed and Lk_error = Lk - Lk_imposed (a jump by 2 would be a crossing).  Before buckling
# Wr = 0 and Tw carries all; after, twist converts to writhe.  With --set contact=off the rod passes
# through itself and Lk jumps.
#
# ## The balance
#
# The turned end is a joint to a ground frame that turns (rodfem/core/joints.py, `MovingGround`, with
# the prismatic pair of forms/joints.py along the axis): its reactions supply the work of the turning
# exactly (column `supplied`), the damping's loss is `dissipated`, the contact's energy is in H
# (`self.energy`), so with the discrete gradient H_n - H_0 - supplied + dissipated = 0 to round-off
# (`balance_error` per step).  `self.penetration` is the largest overlap of the tube with itself.
#
# Run it:  rodfem run plectoneme --out results/plectoneme           (2 turns in 4 s: 250 steps, about 25 s)
#          rodfem run plectoneme --set turns=10 --set n_elements=50 --set t_end=25 --set newton_atol=1e-7 \
#                    --out results/plectoneme-10

import sys

import numpy as np

from rodfem import Support, System, ground
from rodfem.analysis.linking import link
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.errors import ParameterError
from rodfem.forms import cosserat_rod
from rodfem.forms.contact import Contact, Plane
from rodfem.forms.joints import prismatic
from rodfem.forms.rod_contact import RodContact

parameters = common(n_elements=12, dt=0.02, t_end=5.0, integrator="discrete-gradient", frames=51) + [
    stiffness("L", 1.0, "m", "length"),
    stiffness("r", 0.025, "m", "radius (solid circular section)"),
    stiffness("mass", 1.0, "kg", "mass of the rod"),
    stiffness("E", 1e6, "Pa", "Young's modulus"),
    stiffness("G", 1e6 / 1.5, "Pa", "shear modulus (PyElastica's case: E / 1.5)"),
    stiffness("turns", 2.0, "", "number of turns imposed on the end s = L"),
    stiffness("turn_time", 2.0, "s", "time per turn (the end turns at 2 pi / turn_time)"),
    Parameter("alpha", 2.0, "1/s", "mass-proportional damping rate (force -alpha rho v; 0: none)", low=0),
    Parameter("tau_kv", 0.01, "s", "Kelvin-Voigt retardation time (viscous stresses tau_kv x stiffness x strain rate; 0: none)",
              low=0),
    Parameter("imperfection", 1e-2, "m", "amplitude of the stress-free initial shape z = delta sin^2(pi s/L)"),
    stiffness("k_contact", 5e7, "N/m^2", "self-contact penalty k of psi(g) = k/3 <-g>^3 per contact point"),
    stiffness("penetration", 1e-3, "m", "design penetration d (the contact zone sqrt(4 r d) shares a contact)"),
    Parameter("newton_atol", 1e-11, "", "Newton's absolute tolerance |F| (the residual's round-off floor grows with the "
              "contact forces: 1e-7 for the 10-turn case)", low=0, low_open=True),
    Parameter("contact", "on", "", "off: no self-contact (the rod passes through itself; for comparison)",
              choices=("on", "off")),
    Parameter("wall", "on", "", "off: no wall at the clamp (the rod may swing round behind the clamp; for comparison)",
              choices=("on", "off")),
    stiffness("k_wall", 1e10, "N/m^3", "the clamp's wall: penalty k of psi(g) = k/3 <-g>^3 per unit length"),
]


def section(p):
    """(rhoA, rhoJ, C_N, C_M) of the round section."""
    r, E, G = p["r"], p["E"], p["G"]
    A, I = np.pi * r**2, np.pi * r**4 / 4
    rhoA = p["mass"] / p["L"]
    rho = rhoA / A
    C_N, C_M = [1 / (E * A), 1 / (G * A), 1 / (G * A)], [1 / (2 * G * I), 1 / (E * I), 1 / (E * I)]
    return rhoA, (2 * rho * I, rho * I, rho * I), C_N, C_M


def angle(p):
    """theta(t): the end's angle, 2 pi t / turn_time up to `turns` turns, then held."""
    total, rate = 2 * np.pi * p["turns"], 2 * np.pi / p["turn_time"]
    return lambda t: min(rate * t, total)


def turning_frame(p):
    """The ground frame at (L, 0, 0) turned about x by theta(t): motion(t) = (x, R(t))."""
    theta, x = angle(p), np.array([p["L"], 0.0, 0.0])

    def motion(t):
        c, s = np.cos(theta(t)), np.sin(theta(t))
        return x, np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    return motion


def initial(p):
    """The stress-free imperfect rod r = (s, 0, delta sin^2(pi s/L)), d1 its unit tangent, d2 = e_y."""
    L, delta = p["L"], p["imperfection"]

    def tangent(x):
        t = np.vstack([np.ones_like(x[0]), 0 * x[0], delta * np.pi / L * np.sin(2 * np.pi * x[0] / L)])
        return t / np.linalg.norm(t, axis=0)

    def zero(x):
        return np.zeros((3, x.shape[1]))
    e2 = lambda x: np.vstack([0 * x[0], 1 + 0 * x[0], 0 * x[0]])   # noqa: E731
    return {"r": lambda x: np.vstack([x[0], 0 * x[0], delta * np.sin(np.pi * x[0] / L) ** 2]), "v": zero,
            "d1": tangent, "d2": e2, "d3": lambda x: np.cross(tangent(x).T, e2(x).T).T,
            "w1": zero, "w2": zero, "w3": zero}


def check(p):
    if not abs(p["imperfection"]) < 0.1 * p["L"]:
        raise ParameterError(f"parameter 'imperfection' must be in (-L/10, L/10) = ({-0.1 * p['L']:g}, {0.1 * p['L']:g}) "
                             f"(got {p['imperfection']:g})")
    if not p["r"] < 0.1 * p["L"]:
        raise ParameterError(f"parameter 'r' must be < L/10 = {0.1 * p['L']:g} for a rod (got {p['r']:g})")
    per_segment = p["turns"] / (2 * p["n_elements"])
    if per_segment > 0.2:
        raise ParameterError(f"parameter 'n_elements' must be >= {int(np.ceil(p['turns'] / 0.4))} for {p['turns']:g} "
                             "turns (the twist between nodes must stay below 1/5 turn)")


def build(p, comm):
    check(p)
    rhoA, rhoJ, C_N, C_M = section(p)
    rayleigh = cosserat_rod.rayleigh(p["alpha"], p["tau_kv"], C_N, C_M) if p["alpha"] > 0 or p["tau_kv"] > 0 else None
    model = cosserat_rod.CosseratRod(rhoA, rhoJ, C_N, C_M, damping=rayleigh)
    system = System(integrator=p["integrator"], comm=comm,
                    newton_options={"snes_atol": p["newton_atol"], "snes_rtol": 1e-14, "snes_stol": 1e-13, "snes_max_it": 40})
    # ## The wall the rod is clamped in: the plane x = -r, which the tube of radius r touches at the clamp
    # (gap g = x of the centreline: columns rod.wall.energy, rod.wall.N, rod.wall.penetration, ...)
    wall = [Contact(Plane((1.0, 0.0, 0.0), (-p["r"], 0.0, 0.0)), p["k_wall"], radius=p["r"], name="wall")] \
        if p["wall"] == "on" else []
    rod = system.add("rod", model, p["L"], p["n_elements"], initial=initial(p), supports=[Support("left", "clamped")],
                     contacts=wall)
    # ## The turned end: prismatic along the turning frame's d1 (= x): turns with it, slides along x
    system.join(prismatic(0), ground((p["L"], 0.0, 0.0)), rod.end, name="twist", motion=turning_frame(p))
    # ## Self-contact: columns self.energy, self.N, self.penetration, ...
    if p["contact"] == "on":
        zone = np.sqrt(4 * p["r"] * p["penetration"])
        system.contact(RodContact(p["k_contact"], p["r"], zone=zone), rod, name="self")
    system.marker("end", rod.end)
    system.record(link_columns(rod, p))
    return system


def centreline(body, u):
    """The nodes' positions and d2 along the rod (gathered on every rank, sorted by s)."""
    S = body.space
    s, r = S.nodal(u, "r")
    _, d2 = S.nodal(u, "d2")
    parts = body.comm.allgather((s, r, d2)) if body.comm.size > 1 else [(s, r, d2)]
    s = np.concatenate([q[0] for q in parts])
    order = np.argsort(s)
    return np.concatenate([q[1] for q in parts])[order], np.concatenate([q[2] for q in parts])[order]


def link_columns(rod, p):
    """A recorder: Tw, Wr, Lk = Tw + Wr of the state x_{n+1}, the imposed turns theta(t)/2 pi and the error."""
    theta = angle(p)

    def columns(system):
        body = rod.body
        r, d2 = centreline(body, body.x1)
        Tw, Wr, Lk = link(r, d2)
        t = system.points.times[1]          # the time of x_{n+1}
        imposed = theta(t) / (2 * np.pi)
        return {"Tw": Tw, "Wr": Wr, "Lk": Lk, "Lk_imposed": imposed, "Lk_error": Lk - imposed}
    return columns


scene = Scene("plectoneme", "a rod clamped at one end and turned at the other buckles into a plectoneme with "
              "self-contact; Lk = Tw + Wr stays the imposed turns (after PyElastica's PlectonemesCase)",
              parameters, build,
              notes="Lk_error ~ 0 at all times (a crossing would make it jump by 2); balance_error ~ round-off "
                    "with the discrete gradient; self.penetration small against r.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
