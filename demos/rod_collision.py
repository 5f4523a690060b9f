# # Two rods colliding crosswise: rod-rod contact with momentum and energy kept exactly
#
# Two straight elastic rods (3D Cosserat rods, forms/cosserat_rod.py) of length L = 0.5, radius
# r = 0.01, density rho = 1750 and Young's modulus E = 3e5 (the rod-collision case of the issue
# tracker, after PyElastica's rod-rod contact examples) cross at right angles: rod a along x above,
# rod b along y below, a gap of `gap` between their surfaces, and move towards each other at the
# relative speed V = 0.1 m/s.  They touch, bounce off, and fly apart.  Nothing else acts: no
# gravity, no support.
#
# ## The contact (forms/rod_contact.py, rodfem/core/bodycontact.py)
#
# The gap of two segments of the centrelines is their distance less r_a + r_b; the stored energy
# is the cubic penalty k/3 <-g>^3 summed over the segment pairs (the closest points of the two
# segments: a crossing is found wherever along the segments it lies).  Its discrete gradient keeps
# the momenta: the forces on the two rods are equal and opposite with no net moment, so
#
#   * the total linear and angular momentum (columns p_x, ..., L_z) are constant to round-off;
#   * H (kinetic + strain + contact energy) is constant to round-off with the discrete gradient
#     (`balance_error`: H_{n+1} - H_n, nothing supplied or dissipated).
#
# The penalty k is chosen so that a rigid-body impact would penetrate `penetration`:
# 1/2 m_eff V^2 = k d^3 / 3 with 1/m_eff the rigid-body law's (below).  A crossing at nodes of both
# rods (the centres: always a node of the P2 centreline) is counted by four segment pairs, so its
# penetration is 4^(-1/3) of that.  On a fine mesh (segments shorter than the contact zone
# sqrt(2 R d) = sqrt(4 r d)) the segment pairs in the zone share the contact (`zone`): the
# stiffness does not grow with the number of elements.
#
# ## Friction (`mu` > 0, forms/rod_contact.py)
#
# With `mu` the rods rub: regularized Coulomb friction (forms/contact.py's `Coulomb`, mu_s = mu_k = mu)
# at the tubes' contact point, against the relative slip of the two rods' material points there;
# `slide` gives them a relative velocity along x (along rod a, across rod b).  The friction acts on each
# rod as a force at its centreline and a couple on its cross-section (the arm from the centreline to the
# contact point): rod b, rubbed across its axis, spins up.  The forces are equal and opposite and the
# force-couple pairs have no net moment, so the total linear AND angular momentum stay constant to
# round-off (touch.Mf, the friction's net moment, is zero to round-off); the friction's work is the
# column `dissipated` (H - supplied + dissipated constant to round-off).  The *_rigid columns stay the
# frictionless answer.
#
# ## The rigid-body answer (frictionless, elastic)
#
# Rod b crosses rod a at the distance `offset_a` from a's centre (along a), rod a crosses b at
# `offset_b` from b's centre.  For rigid rods the contact impulse J along z follows from the
# effective mass 1/m_eff = 2/m + offset_a^2 / I + offset_b^2 / I (I = m L^2/12 + rhoJ L the moment
# of inertia about a transverse axis through the centre) and elastic restitution:
#
#     J = 2 m_eff V,   p_a,z = -m V/2 + J,   p_b,z = m V/2 - J,
#     L_a,y = -offset_a J,   L_b,x = -offset_b J          (about the origin: also offset_b p_a,z and -offset_a p_b,z)
#
# With the rods crossing at their centres the velocities are exchanged.  A flexible rod keeps part
# of the energy as vibration: stiff rods (E large against the contact's stiffness and duration)
# approach the rigid answer, the columns `pz_a`, `pz_b`, `Ly_a`, `Lx_b` against `pz_a_rigid`, ...
#
# Run it:  rodfem run rod-collision --out results/rod-collision
#          rodfem run rod-collision --set E=1e10 --set offset_a=0.1 --out results/rod-collision-stiff
#          rodfem run rod-collision --set mu=0.3 --set slide=0.1 --out results/rod-collision-friction

import sys

import numpy as np

from rodfem import System
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.fem.jit import compile_forms
from rodfem.forms import cosserat_rod
from rodfem.forms.contact import Coulomb
from rodfem.forms.rod_contact import RodContact

parameters = common(n_elements=8, dt=5e-4, t_end=0.06, integrator="discrete-gradient") + [
    stiffness("L", 0.5, "m", "length of each rod"),
    stiffness("r", 0.01, "m", "radius of each rod (solid circular section)"),
    stiffness("rho", 1750.0, "kg/m^3", "density"),
    stiffness("E", 3e5, "Pa", "Young's modulus"),
    Parameter("poisson", 0.5, "", "Poisson's ratio (shear modulus E / (2 (1 + poisson)))", low=0, high=0.5),
    stiffness("V", 0.1, "m/s", "relative speed of approach (each rod moves at V/2)"),
    stiffness("gap", 1e-3, "m", "initial gap between the rods' surfaces"),
    Parameter("offset_a", 0.0, "m", "where rod b crosses rod a, from a's centre (|offset_a| < L/2)"),
    Parameter("offset_b", 0.0, "m", "where rod a crosses rod b, from b's centre (|offset_b| < L/2)"),
    stiffness("penetration", 1e-3, "m", "penetration of a rigid-body impact (sets the penalty k)"),
    Parameter("contact", "on", "", "off: no contact (the rods pass through each other; for comparison)",
              choices=("on", "off")),
    Parameter("mu", 0.0, "", "Coulomb friction coefficient between the rods (0: frictionless)", low=0),
    Parameter("slide", 0.0, "m/s", "relative sliding speed along x (rod a at +slide/2, rod b at -slide/2)"),
]


def section(p):
    """(m, rhoA, rhoJ, I) of a rod: mass, line density, rotary inertia per length, transverse moment of inertia."""
    A, Isec = np.pi * p["r"] ** 2, np.pi * p["r"] ** 4 / 4
    rhoA = p["rho"] * A
    rhoJ = (p["rho"] * 2 * Isec, p["rho"] * Isec, p["rho"] * Isec)
    m = rhoA * p["L"]
    return m, rhoA, rhoJ, m * p["L"] ** 2 / 12 + rhoJ[1] * p["L"]


def rigid(p):
    """The rigid-body answer after the impact: p_a,z, p_b,z, L_a,y, L_b,x and the impulse J."""
    m, _, _, inertia = section(p)
    m_eff = 1.0 / (2.0 / m + (p["offset_a"] ** 2 + p["offset_b"] ** 2) / inertia)
    J = 2.0 * m_eff * p["V"]
    return {"pz_a": -0.5 * m * p["V"] + J, "pz_b": 0.5 * m * p["V"] - J,
            "Ly_a": -p["offset_a"] * J, "Lx_b": -p["offset_b"] * J, "J": J, "m_eff": m_eff}


def contact_stiffness(p):
    """k with 1/2 m_eff V^2 = k d^3 / 3 at d = penetration."""
    return 1.5 * rigid(p)["m_eff"] * p["V"] ** 2 / p["penetration"] ** 3


def straight(centre, axis, normal, velocity, L):
    """Initial values of a straight rod of length L centred at `centre` along `axis` (d2 = normal), translating."""
    axis, normal = np.asarray(axis, float), np.asarray(normal, float)
    start = np.asarray(centre, float) - 0.5 * L * axis
    directors = [axis, normal, np.cross(axis, normal)]
    initial = {"r": lambda x: start[:, None] + np.outer(axis, x[0]),
               "v": lambda x: np.outer(velocity, np.ones(x.shape[1]))}
    for i, d in enumerate(directors):
        initial[f"d{i + 1}"] = lambda x, d=d: np.outer(d, np.ones(x.shape[1]))
        initial[f"w{i + 1}"] = lambda x: np.zeros((3, x.shape[1]))
    return initial


def solid_rod(E, r=0.01, rho=1750.0, poisson=0.5):
    """The Cosserat rod of a solid circular section of radius r, density rho, Young's modulus E and
    G = E / (2 (1 + poisson)): line density rho A, rotary inertia rho (2I, I, I), compliances
    1/(EA), 1/(GA), 1/(GA) and 1/(2GI), 1/(EI), 1/(EI) (A = pi r^2, I = pi r^4 / 4)."""
    A, Isec = np.pi * r**2, np.pi * r**4 / 4
    G = E / (2 * (1 + poisson))
    return cosserat_rod.CosseratRod(rho * A, (rho * 2 * Isec, rho * Isec, rho * Isec),
                                    [1 / (E * A), 1 / (G * A), 1 / (G * A)], [1 / (G * 2 * Isec), 1 / (E * Isec), 1 / (E * Isec)])


def build(p, comm):
    from rodfem.errors import ParameterError
    L, r, V = p["L"], p["r"], p["V"]
    for name in ("offset_a", "offset_b"):
        if not abs(p[name]) < 0.5 * L:
            raise ParameterError(f"parameter '{name}' must be in (-L/2, L/2) = ({-0.5 * L:g}, {0.5 * L:g}) (got {p[name]:g})")
    rod = solid_rod(p["E"], r, p["rho"], p["poisson"])
    # ## The two rods: a along x (centre at y = offset_b), b along y (centre at x = offset_a)
    z = r + 0.5 * p["gap"]
    system = System(integrator=p["integrator"], comm=comm, newton_options={"snes_atol": 1e-12, "snes_max_it": 40})
    a = system.add("a", rod, L, p["n_elements"],
                   initial=straight((0.0, p["offset_b"], z), (1, 0, 0), (0, 1, 0), (0.5 * p["slide"], 0.0, -0.5 * V), L))
    b = system.add("b", rod, L, p["n_elements"],
                   initial=straight((p["offset_a"], 0.0, -z), (0, 1, 0), (0, 0, 1), (-0.5 * p["slide"], 0.0, 0.5 * V), L))
    # ## The contact: columns touch.N (normal force), touch.Fn_x, _y, _z (on rod a), touch.penetration
    if p["contact"] == "on":
        friction = Coulomb(p["mu"]) if p["mu"] > 0 else None
        system.contact(RodContact(contact_stiffness(p), r, zone=np.sqrt(4 * r * p["penetration"]), friction=friction),
                       a, b, name="touch")
    system.record(momenta(p))
    return system


def momenta(p):
    """A recorder: each rod's momentum p_z and angular momentum about the origin (L_y of a, L_x of b),
    and the rigid-body answer."""
    compiled = {}
    answer = rigid(p)

    def columns(system):
        if not compiled:
            forms = {}
            for name in ("a", "b"):
                body = system.body(name)
                for k, f in body.momentum_forms(body.space.split(body.x1)).items():
                    forms[f"{k}_{name}"] = f
            compiled.update(compile_forms(forms))
        value = {k: system.assemble(f) for k, f in compiled.items()}
        out = {"pz_a": value["p_z_a"], "pz_b": value["p_z_b"], "Ly_a": value["L_y_a"], "Lx_b": value["L_x_b"]}
        # the rigid answer's angular momenta about the origin: spin plus the centre's r x p
        out.update({"pz_a_rigid": answer["pz_a"], "pz_b_rigid": answer["pz_b"],
                    "Ly_a_rigid": answer["Ly_a"], "Lx_b_rigid": answer["Lx_b"]})
        return out
    return columns


scene = Scene("rod-collision", "two elastic rods crossing at right angles collide and bounce off (rod-rod "
              "contact): momentum and energy exact, stiff rods against the rigid-body impulse law",
              parameters, build,
              notes="Total p, L constant to round-off; discrete gradient: H constant to round-off; pz_a, pz_b, "
                    "Ly_a, Lx_b approach their *_rigid columns as E grows.  With mu > 0: p and L constant to "
                    "round-off (touch.Mf = 0: the friction's forces and section couples balance), rod b spins "
                    "up, H - supplied + dissipated constant to round-off.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
