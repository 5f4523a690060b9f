# # The capstan: a string pulled over a fixed cylinder with Coulomb friction
#
# A string (forms/string.py: no bending stiffness at all, the exact setting of the capstan
# equation; a rod of tiny bending stiffness would add a bending moment at the tangent points that
# the formula ignores) is wrapped over a fixed drum: the cylinder of radius R about the y axis
# (forms/contact.py: `Cylinder`), the wrap angle theta.  Its left end hangs down with the dead load
# T1 (the "holding" side, a constant force along the left span); its right end is pulled along
# the right span by a prescribed motion (a driven spherical joint to the ground), its speed
# rising smoothly from 0 to V over t_ramp and held.  While the pull is small the string sticks on
# the drum (it creeps, the friction being regularized); once the tension on the pulled side
# reaches the capstan limit the whole string slides over the drum at the speed V, and then
#
#     T2 / T1 = e^(mu theta)          (Euler 1762, Eytelwein 1808: 2.566 for mu = 0.3, theta = pi)
#
# ## Where this comes from (and what the discrete string does)
#
# A string on a drum carries the tension T(phi); the drum pushes with the normal force T / R per
# unit (current) length and friction mu T / R resists the slip, so dT/dphi = mu T while it slides,
# T2 = T1 e^(mu theta).  The discrete string touches the drum at its nodes (the contact is
# lumped there): a node where the string turns by the angle a carries the normal force
# N = (T_i + T_{i+1}) sin(a/2) and friction mu N, so T_{i+1} / T_i = (1 + mu sin(a/2)) / (1 - mu sin(a/2))
# and the ratio over theta / a nodes is e^(mu theta) (1 + O(a^2)) -- second order in the elements.
# More precisely, the balance along the drum's tangent at a node gives
# T_{i+1} (e_out . t + mu e_out . n) = T_i (e_in . t + mu e_in . n) for the unit chords e_in, e_out, the
# tangent t and the outward normal n there: `discrete_ratio` multiplies these factors over the polygon
# of t = 0, about e^(mu theta) (1 + mu theta (1 + mu^2) a^2 / 12) (+0.19 % at the default 48 elements).
#
# ## The model of friction, stated
#
# Regularized Coulomb friction (forms/contact.py: f_t = -mu N v_t / sqrt(|v_t|^2 + eps^2), with
# mu_s = mu_k = mu): below the slip velocity eps the law is a viscous damper (mu N / eps), above
# it the Coulomb force mu N.  Sliding at the speed V the coefficient is mu V / sqrt(V^2 + eps^2):
# the ratio approaches e^(mu theta) for V >> eps (eps = 1e-4 m/s against V = 2 cm/s: a relative
# 1e-5 in mu), and is e^(mu theta V / sqrt(V^2 + eps^2)) for any eps (`ratio_regularized`: with
# eps = 1 cm/s the friction is 0.89 of the Coulomb force: 2.322 instead of 2.566).  The normal
# contact is the cubic penalty k/3 <-g>^3 of the gap g to the drum's
# surface (the string's radius r off its centreline); k is chosen so that the largest line load
# of the sliding string, T1 e^(mu theta) / R, penetrates `penetration`: below it everywhere.
#
# The string is damped a little (Kelvin-Voigt, retardation time tau_kv = 1 ms): the implicit
# midpoint rule does not damp the axial and contact vibrations the steps do not resolve (the
# string's axial waves cross a span in 0.6 ms), and undamped they ring on top of the tensions
# (+-3 % in T2/T1); the viscous stress of the sliding string, tau_kv EA d_t eps ~ 1e-4 N, is far
# below the tensions.
#
# ## What is exact
#
# With the discrete gradient, H (the string's kinetic and strain energy and the contact energy)
# obeys H_{n+1} - H_n + dissipated = supplied to round-off every step: `supplied` is the work of
# the dead load and of the pull (the driven joint's -lambda . (g_p(t_{n+1}) - g_p(t_n))),
# `dissipated` the friction's work and the string's viscous loss, >= 0 in every step.
#
# What to look at (history columns): `T1`, `T2` the tensions of the two free spans (the string's
# axial force, the mean over the span's elements), `ratio` = T2 / T1 against `ratio_exact`
# = e^(mu theta) (plot ratio against t: it rises from 1 while the string sticks and levels off at
# the capstan limit once it slides) and `ratio_regularized`; `pull.lambda1`, `_2`, `_3` the force
# holding the pulled end (|lambda| / T1: the end reactions' ratio); `slip` the speed of the string's
# middle node over the drum; `string.drum.N` the total normal force, `string.drum.Ft_x`, ... the
# total friction force and `string.drum.penetration` the largest penetration.
#
# Run it:  rodfem run capstan --out results/capstan
#          rodfem run capstan --set theta=90 --set mu=0.1 --out results/capstan-quarter

import sys

import numpy as np

from rodfem import Load, System, ground
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.demos._multibody import nodal
from rodfem.errors import ParameterError
from rodfem.forms import joints
from rodfem.forms.contact import Contact, Coulomb, Cylinder, stiffness_for
from rodfem.forms.string import String, kelvin_voigt
from rodfem.forms.string_materials import logarithmic

parameters = common(n_elements=48, dt=0.01, t_end=1.5, integrator="discrete-gradient") + [
    Parameter("theta", 180.0, "deg", "wrap angle of the string on the drum", low=0, high=180, low_open=True),
    Parameter("mu", 0.3, "", "friction coefficient (static = kinetic)", low=0),
    stiffness("eps", 1e-4, "m/s", "regularization velocity of the friction law (viscous below it)"),
    stiffness("R", 0.1, "m", "radius of the drum"),
    stiffness("r", 0.002, "m", "radius of the string"),
    stiffness("span", 0.2, "m", "length of each free span (left and right of the drum) at t = 0"),
    stiffness("T1", 1.0, "N", "dead load on the left (holding) end"),
    stiffness("V", 0.02, "m/s", "speed at which the right end is pulled (after the ramp)"),
    stiffness("t_ramp", 0.5, "s", "the pulling speed rises smoothly from 0 to V over t_ramp"),
    stiffness("EA", 1000.0, "N", "axial stiffness of the string (logarithmic law)"),
    stiffness("rhoA", 0.01, "kg/m", "mass per length of the string"),
    Parameter("tau_kv", 1e-3, "s", "Kelvin-Voigt retardation time of the string (0: undamped)", low=0),
    stiffness("penetration", 1e-4, "m", "penetration of the drum under the largest line load T1 e^(mu theta) / R "
              "(sets the penalty k)"),
]


def capstan_ratio(p):
    """e^(mu theta), the Euler-Eytelwein ratio T2 / T1 of a string sliding over the drum."""
    return float(np.exp(p["mu"] * np.radians(p["theta"])))


def regularized_ratio(p):
    """e^(mu_eff theta) with the regularized law's coefficient at the slip V: mu V / sqrt(V^2 + eps^2)."""
    mu = p["mu"] * p["V"] / np.hypot(p["V"], p["eps"])
    return float(np.exp(mu * np.radians(p["theta"])))


def discrete_ratio(p, mu=None):
    """T2 / T1 of the discrete string sliding over the drum in the polygon of t = 0 (the module's
    node balance T_{i+1} (e_out . t + mu e_out . n) = T_i (e_in . t + mu e_in . n) at each node on
    the drum, quasi-static, frictionless spans), with mu the regularized coefficient by default."""
    mu = p["mu"] * p["V"] / np.hypot(p["V"], p["eps"]) if mu is None else mu
    nodes, _, _ = path(p)
    n_s, n_a, _ = layout(p)
    ratio = 1.0
    for i in range(n_s, n_s + n_a + 1):
        x = nodes[[0, 2], i]
        n = x / np.linalg.norm(x)                      # outward normal (in the x-z plane)
        t = np.array([n[1], -n[0]])                    # the tangent towards the pulled end (phi decreasing)
        e_in = nodes[[0, 2], i] - nodes[[0, 2], i - 1]
        e_out = nodes[[0, 2], i + 1] - nodes[[0, 2], i]
        e_in, e_out = e_in / np.linalg.norm(e_in), e_out / np.linalg.norm(e_out)
        ratio *= (e_in @ t + mu * (e_in @ n)) / (e_out @ t + mu * (e_out @ n))
    return float(ratio)


def stretch(p, T):
    """The stretch lambda of the logarithmic string at the tension T: EA/2 (lambda - 1/lambda) = T."""
    a = T / p["EA"]
    return a + np.sqrt(a * a + 1.0)


def penalty(p):
    """k of the cubic penalty: the largest line load (per reference length) penetrates `penetration`."""
    T2 = p["T1"] * capstan_ratio(p)
    return stiffness_for(T2 * stretch(p, T2) / p["R"], p["penetration"])


def layout(p):
    """The mesh over the wrapped string: (n_s, n_a, h) -- n_s elements in each free span, n_a on the
    drum, the reference element length h.  The string at t = 0 is a polygon of equal chords
    lambda h (lambda: the stretch of T1) whose n_a + 1 nodes on the drum lie on a circle: the chord
    2 Rc sin(theta / (2 n_a)) = lambda h; each span is n_s chords long (`span` rounded to whole
    elements)."""
    n, theta = p["n_elements"], np.radians(p["theta"])
    arc = theta * (p["R"] + p["r"])
    n_a = max(int(round(n * arc / (arc + 2 * p["span"]))), 2)
    n_a += (n - n_a) % 2                       # the two spans alike
    n_s = (n - n_a) // 2
    if n_s < 2:
        raise ParameterError(f"parameter 'n_elements' must leave two elements per free span (got {n})")
    Rc = contact_radius(p, theta / n_a)
    h = 2 * Rc * np.sin(theta / (2 * n_a)) / stretch(p, p["T1"])
    return n_s, n_a, h


def contact_radius(p, angle):
    """The radius of the nodes on the drum in normal equilibrium at the tension T1: a node where the
    string turns by `angle` carries 2 T1 sin(angle/2) = k d^2 h (the contact lumped at the nodes, h the
    reference length of an element) -- solved together with h = 2 Rc sin(angle/2) / lambda."""
    k, lam, T1 = penalty(p), stretch(p, p["T1"]), p["T1"]
    Rc = p["R"] + p["r"]
    for _ in range(50):   # fixed point: d depends on h, h on Rc (a contraction: d << Rc)
        h = 2 * Rc * np.sin(angle / 2) / lam
        Rc = p["R"] + p["r"] - np.sqrt(2 * T1 * np.sin(angle / 2) / (k * h))
    return Rc


def path(p):
    """The node positions at t = 0 (a (3, n + 1) array, nodes in the order of s), the reference
    length L0 and the right span's direction: the left span straight down to the drum, the n_a
    chords on the drum from phi = pi to pi - theta (the nodes at the radius Rc), the right span along
    the drum's tangent there."""
    n_s, n_a, h = layout(p)
    theta, lam = np.radians(p["theta"]), stretch(p, p["T1"])
    Rc = contact_radius(p, theta / n_a)
    end = np.pi - theta
    out = np.array([np.sin(end), 0.0, -np.cos(end)])   # the right span's direction (the drum's tangent)
    phi = np.pi - theta * np.arange(n_a + 1) / n_a
    arc = Rc * np.vstack([np.cos(phi), 0 * phi, np.sin(phi)])
    ell = lam * h
    left = arc[:, :1] + np.outer([0.0, 0.0, -1.0], ell * np.arange(n_s, 0, -1))
    right = arc[:, -1:] + np.outer(out, ell * np.arange(1, n_s + 1))
    return np.hstack([left, arc, right]), (2 * n_s + n_a) * h, out


def initial_position(nodes, h):
    """r(s) for the initial values: the node at s = i h is nodes[:, i] (P1: the nodes are the dofs)."""
    def r(x):
        i = np.rint(x[0] / h).astype(int)
        return nodes[:, np.clip(i, 0, nodes.shape[1] - 1)]
    return r


def pull(p, direction):
    """The driven joint's g_p(t) = -u(t) direction: the right end moved by u(t) along the span,
    u' = V (1 - cos(pi t / t_ramp)) / 2 for t < t_ramp, then V."""
    V, tr = p["V"], p["t_ramp"]

    def g(t):
        u = V / 2 * (t - tr / np.pi * np.sin(np.pi * t / tr)) if t < tr else V * (t - tr / 2)
        return -u * direction
    return g


def tensions(p, L0):
    """A recorder: T1, T2 (the mean tension of the elements inside the left and right span: the
    string's axial force N = EA/2 (lambda - 1/lambda) from the element's stretch), their ratio, the
    capstan ratio e^(mu theta) and the regularized law's, and the speed of the string's middle node
    (on the drum: its slip)."""
    n_s, _, h = layout(p)
    span0 = n_s * h                                # the spans' reference length
    ratio_exact, regularized = capstan_ratio(p), regularized_ratio(p)

    def columns(system):
        s, r = nodal(system.body("string"), "r")
        _, v = nodal(system.body("string"), "v")
        lam = np.linalg.norm(np.diff(r, axis=0), axis=1) / np.diff(s)
        N = p["EA"] / 2 * (lam - 1 / lam)
        mid = 0.5 * (s[1:] + s[:-1])
        # the inner 60 % of each span (material that stays in the span over the run)
        T1 = N[(mid > 0.2 * span0) & (mid < 0.8 * span0)].mean()
        T2 = N[(mid > L0 - 0.8 * span0) & (mid < L0 - 0.2 * span0)].mean()
        return {"T1": T1, "T2": T2, "ratio": T2 / T1, "ratio_exact": ratio_exact,
                "ratio_regularized": regularized, "slip": float(np.linalg.norm(v[len(v) // 2]))}
    return columns


def build(p, comm):
    nodes, L0, out = path(p)
    h = L0 / p["n_elements"]
    damping = kelvin_voigt(p["tau_kv"], p["EA"]) if p["tau_kv"] > 0 else None
    string = String(logarithmic(EA=p["EA"]), p["rhoA"], damping=damping)
    drum = Contact(Cylinder((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), p["R"]), penalty(p), radius=p["r"], name="drum",
                   friction=Coulomb(p["mu"], p["mu"], eps=p["eps"], v_s=1.0))
    system = System(integrator=p["integrator"], comm=comm, newton_options={"snes_atol": 1e-10, "snes_max_it": 40})
    # the left end: the dead load T1 down the left span (a force input; the string hangs on it)
    hold = Load("v", [0.0, 0.0, -p["T1"]], "left", "hold")
    cable = system.add("string", string, L0, p["n_elements"], loads=[hold],
                       initial={"r": initial_position(nodes, h)}, contacts=[drum])
    # the right end: pulled along the span by a driven spherical joint to the ground
    system.join(joints.spherical, ground(nodes[:, -1]), cable.end, name="pull", drive=pull(p, out))
    system.record(tensions(p, L0))
    return system


scene = Scene("capstan", "a string pulled over a fixed drum with Coulomb friction: the tension ratio of the "
              "sliding string against Euler-Eytelwein's e^(mu theta)", parameters, build,
              notes="ratio = T2/T1 of the free spans' tensions; ratio_exact = e^(mu theta) (2.566 for mu = 0.3, "
                    "theta = 180 deg); discrete gradient: balance to round-off, friction work >= 0 every step.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
