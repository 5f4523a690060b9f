# # A rod rolling (or sliding) down an inclined plane with Coulomb friction
#
# After PyElastica's friction validation case (Gazzola et al., R Soc Open Sci 5 (2018) 171628,
# DOI 10.1098/rsos.171628, Sec. on rolling friction): a straight elastic rod (3D Cosserat rod,
# forms/cosserat_rod.py) of length L = 1, radius R = 0.025, mass m = 1, E = 1e9, lies across a
# plane inclined by alpha, its axis horizontal, and is released from rest under gravity
# g = 9.80665.  The plane touches the rod's surface along its whole length (forms/contact.py: a
# cubic penalty energy of the gap, integrated with the discrete gradient) with regularized Coulomb
# friction (mu_s = 0.4, mu_k = 0.2).  Friction acts at the surface point facing the plane, so it
# both holds the rod back and spins it about its axis.
#
# ## The analytic answer (a solid cylinder, I = m R^2 / 2 about its axis)
#
# Down the slope the rod feels m g sin(alpha) and the friction force F; F R spins it:
#
#     m a = m g sin(alpha) - F,        I omega' = F R.
#
# Rolling (no slip, a = R omega'):  F = m g sin(alpha) / 3, a = 2/3 g sin(alpha).  This needs
# F <= mu_s N = mu_s m g cos(alpha), i.e. tan(alpha) <= 3 mu_s (= 1.2: alpha <= 50.19 deg).  Then
#
#     E_trans = 1/2 m (a t)^2,   E_rot = 1/2 I (a t / R)^2 = E_trans / 2,
#
# and E_trans + E_rot = m g sin(alpha) (a t^2 / 2): the whole drop of potential energy, nothing lost.
# Sliding (tan(alpha) > 3 mu_s): F = mu_k m g cos(alpha) (the slip v - R omega then grows at
# g (sin(alpha) - 3 mu_k cos(alpha)) > 0, so it never sticks again):
#
#     a = g (sin(alpha) - mu_k cos(alpha)),   omega' = 2 mu_k g cos(alpha) / R,
#     E_trans = 1/2 m (a t)^2,   E_rot = 1/2 I (omega' t)^2 = m (mu_k g cos(alpha) t)^2.
#
# The rod starts in its static normal equilibrium: pressed into the plane by
# delta0 = sqrt(rhoA g cos(alpha) / k) (k of the penalty, chosen so that the rod's weight per
# length penetrates `penetration`), so no bounce is set off.
#
# ## What the model does (and does not)
#
# Friction is regularized (f = -mu N v_t / sqrt(|v_t|^2 + eps^2), with mu blended from mu_s at
# rest to mu_k above the Stribeck velocity v_s): a rolling rod creeps at a slip of order eps, and
# loses about eps F^2/(mu N) per unit time -- with eps = 2e-4 m/s 5e-5 of its energy in 0.5 s at
# alpha = 30 deg.  The regularized law is a stiff damper on the slip (rate lambda ~ 3 mu g cos(alpha)/eps);
# the implicit midpoint rule rings on it unless h lambda is small (a few), hence dt = 1e-4.
# With the discrete gradient the balance H_{n+1} - H_n + dissipated = supplied (H including the
# contact energy, `supplied` gravity's work) holds to round-off every step, and each step's
# friction work is >= 0.
#
# What to look at: E_trans, E_rot and their analytic values E_trans_exact, E_rot_exact; the
# contact's normal force `incline.N` (= m g cos(alpha)), friction force `incline.Ft_x, _y, _z`,
# the largest penetration `incline.penetration`, and `dissipated` (zero while rolling, up to the
# regularization).
#
# Run it:  rodfem run rolling-rod-incline --out results/rolling-rod-incline
#          rodfem run rolling-rod-incline --set alpha=60 --out results/sliding-rod

import sys

import numpy as np
import ufl

from rodfem import Load, Problem
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.fem.jit import compile_forms
from rodfem.forms import cosserat_rod
from rodfem.forms.contact import Contact, Coulomb, Plane, stiffness_for
from rodfem.io.sections import Section

parameters = common(n_elements=4, dt=1e-4, t_end=0.5, integrator="discrete-gradient") + [
    Parameter("alpha", 30.0, "deg", "inclination of the plane", low=0, high=89),
    stiffness("L", 1.0, "m", "length of the rod"),
    stiffness("R", 0.025, "m", "radius of the rod (solid circular section)"),
    stiffness("mass", 1.0, "kg", "mass of the rod"),
    stiffness("E", 1e9, "Pa", "Young's modulus"),
    Parameter("poisson", 0.5, "", "Poisson's ratio (shear modulus E / (2 (1 + poisson)))", low=0, high=0.5),
    Parameter("mu_s", 0.4, "", "static friction coefficient", low=0),
    Parameter("mu_k", 0.2, "", "kinetic friction coefficient (<= mu_s)", low=0),
    stiffness("eps", 2e-4, "m/s", "regularization velocity of the friction law"),
    stiffness("v_s", 1e-2, "m/s", "Stribeck velocity: mu goes from mu_s (rest) to mu_k (sliding) over it"),
    stiffness("penetration", 2.5e-5, "m", "penetration of the plane under the rod's weight (sets the penalty k)"),
    Parameter("g", 9.80665, "m/s^2", "gravity"),
]


def geometry(p):
    """The plane's normal n, the down-slope direction e, and gravity (vectors)."""
    a = np.radians(p["alpha"])
    n = np.array([np.sin(a), 0.0, np.cos(a)])
    e = np.array([np.cos(a), 0.0, -np.sin(a)])
    return n, e, np.array([0.0, 0.0, -p["g"]])


def analytic(p, t):
    """(E_trans, E_rot, regime) of a solid cylinder released at rest on the incline at time t."""
    a, g, m = np.radians(p["alpha"]), p["g"], p["mass"]
    if np.tan(a) <= 3 * p["mu_s"]:
        acc = 2.0 / 3.0 * g * np.sin(a)
        E_trans = 0.5 * m * (acc * t) ** 2
        return E_trans, 0.5 * E_trans, "rolling"
    acc = g * (np.sin(a) - p["mu_k"] * np.cos(a))
    return 0.5 * m * (acc * t) ** 2, m * (p["mu_k"] * g * np.cos(a) * t) ** 2, "sliding"


def contact_stiffness(p):
    rhoA = p["mass"] / p["L"]
    return stiffness_for(rhoA * p["g"], p["penetration"])


def build(p, comm):
    L, R, m, E = p["L"], p["R"], p["mass"], p["E"]
    if p["mu_k"] > p["mu_s"]:
        from rodfem.errors import ParameterError
        raise ParameterError(f"parameter 'mu_k' must be in [0, mu_s = {p['mu_s']:g}] (got {p['mu_k']:g})")
    rhoA = m / L
    A, I = np.pi * R**2, np.pi * R**4 / 4
    G = E / (2 * (1 + p["poisson"]))
    # ## The rod: a solid circular section, rhoJ = (rhoA R^2/2, rhoA R^2/4, rhoA R^2/4)
    rhoJ = (rhoA * R**2 / 2, rhoA * R**2 / 4, rhoA * R**2 / 4)
    rod = cosserat_rod.CosseratRod(rhoA, rhoJ, [1 / (E * A), 1 / (G * A), 1 / (G * A)],
                                   [1 / (G * 2 * I), 1 / (E * I), 1 / (E * I)])
    rod.section = Section.round(R)                   # what surface/ and the pictures draw
    # ## The plane and the rod's start: axis d1 = e_y across the slope, d2 = n, in normal equilibrium
    n, e, gravity = geometry(p)
    k = contact_stiffness(p)
    delta0 = np.sqrt(rhoA * p["g"] * np.cos(np.radians(p["alpha"])) / k)
    d1, d2 = np.array([0.0, 1.0, 0.0]), n
    directors = [d1, d2, np.cross(d1, d2)]
    start = (R - delta0) * n - 0.5 * L * d1
    initial = {"r": lambda x: start[:, None] + np.outer(d1, x[0]), "v": lambda x: np.zeros((3, x.shape[1]))}
    for i, d in enumerate(directors):
        initial[f"d{i + 1}"] = lambda x, d=d: np.outer(d, np.ones(x.shape[1]))
        initial[f"w{i + 1}"] = lambda x: np.zeros((3, x.shape[1]))
    incline = Contact(Plane(n), k, radius=R, name="incline",
                      friction=Coulomb(p["mu_s"], p["mu_k"], eps=p["eps"], v_s=p["v_s"]))
    problem = Problem(rod, L, p["n_elements"], loads=[Load("v", rhoA * gravity, "domain", "gravity")],
                      initial=initial, integrator=p["integrator"], comm=comm, contacts=[incline],
                      newton_options={"snes_atol": 1e-10, "snes_max_it": 40})
    problem.record(energies(p))
    return problem


def energies(p):
    """A recorder: E_trans = |int rhoA v ds|^2 / (2 m) (the centre of mass), E_rot = int 1/2 sum m_i |w_i|^2 ds
    (the spin), and their analytic values at t."""
    compiled = {}

    def columns(problem):
        if not compiled:
            X = problem.space.split(problem.x1)
            masses = problem.model.masses
            dx = problem.dx
            forms = {f"p{i}": problem.model.rhoA * X["v"][i] * dx for i in range(3)}
            forms["rot"] = sum(0.5 * float(mi) * ufl.inner(X[w], X[w]) for mi, w in zip(masses, cosserat_rod.RATES)) * dx
            compiled.update(compile_forms(forms))
        momentum = np.array([problem.assemble(compiled[f"p{i}"]) for i in range(3)])
        # the state x_{n+1} is at t_n + h, except in the first row (the initial state, at t = 0)
        t = problem.t + problem.dt if compiled.setdefault("rows", 0) else problem.t
        compiled["rows"] += 1
        exact_trans, exact_rot, _ = analytic(p, t)
        return {"E_trans": float(momentum @ momentum) / (2 * p["mass"]), "E_rot": problem.assemble(compiled["rot"]),
                "E_trans_exact": exact_trans, "E_rot_exact": exact_rot}
    return columns


scene = Scene("rolling-rod-incline", "an elastic rod rolling or sliding down an inclined plane with Coulomb "
              "friction (PyElastica's friction validation): kinetic energies against the analytic solution",
              parameters, build,
              notes="Rolls while tan(alpha) <= 3 mu_s (alpha <= 50.2 deg), slides above; discrete gradient: balance "
                    "to round-off, friction work >= 0 every step.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
