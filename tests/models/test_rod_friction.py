"""Friction between rods (forms/rod_contact.py's `friction`, rodfem/core/bodycontact.py) against independent
answers: a short rod sliding across a clamped rod under gravity decelerates as a block on a rough table
(a = mu_k g, stopping distance v0^2 / (2 mu_k g)); pulled below the static threshold it creeps at the
regularized law's slip eps r / sqrt(1 - r^2) (r = pull / (mu_s N)), above it it accelerates at
(pull - mu_k N) / m; two free rods rubbing keep their total linear momentum to round-off, their angular
momentum changes by exactly the friction couples' moment, H - supplied + dissipated is exact and the
friction never does positive work; the contact's matrix pattern grown at once gives the history of the
pattern grown entry by entry; bad input; mpirun -n 2 = serial."""

import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI
from processes import assert_same_rows, script_on_ranks
from scipy.optimize import brentq
from test_rod_contact import hairpin

from rodfem import Load, Support, System, run
from rodfem.core.bodycontact import BodyContacts, close_pairs
from rodfem.demos.rod_collision import scene, solid_rod, straight
from rodfem.errors import InputError
from rodfem.fem.jit import compile_forms
from rodfem.forms import cosserat_rod
from rodfem.forms.contact import Coulomb, stiffness_for
from rodfem.forms.rod_contact import RodContact
from rodfem.forms.string import String
from rodfem.forms.string_materials import logarithmic

G, R_TUBE, RHO = 9.81, 0.01, 1750.0
FRICTION = Coulomb(mu_s=0.4, mu_k=0.2, eps=2e-4, v_s=1e-3)


BAR, BAR_E = 0.05, 1e10   # the crossbars: short and stiff (the friction bends them sideways: a spring under a)


def block_on_rods(v0=0.0, pull=0.0, friction=FRICTION, La=0.1):
    """Rod a (length La, along x, 2 elements) lies across two clamped rods b, c (along y, 4 elements each, at
    x = -+3 La/8 from a's centre) under gravity, moving along its own axis x at v0 and pulled along x by the
    force `pull` (a fraction of mu_s W): it slides lengthwise, so the friction's couples (about y) are carried
    by the two crossbars (their normal forces shift), not turned into spin -- a block on a table.  The
    crossings are in the middles of a's segments (they move along a as it slides: a crossing that passed a
    node of a would meet the neighbouring segment's end, forms/rod_contact.py) and at b's and c's middle
    nodes.  Returns (system, mass of a)."""
    model = solid_rod(1e9)
    m = model.rhoA * La
    W = m * G
    k = stiffness_for(W, 1e-4)
    # (the stiff bars: the residual's round-off ~1.5e-12)
    s = System(integrator="discrete-gradient", newton_options={"snes_atol": 2e-12, "snes_max_it": 40})
    z = 2 * R_TUBE - 0.5e-4   # at rest: four segment pairs (two at each crossbar) carry W
    a = s.add("a", model, La, 2, initial=straight((0, 0, z), (1, 0, 0), (0, 0, 1), (v0, 0, 0), La),
              loads=[Load("v", [pull * FRICTION.mu_s * W / La, 0.0, -model.rhoA * G], "domain", "weight")])
    for name, x in (("b", -3 * La / 8), ("c", 3 * La / 8)):
        bar = s.add(name, solid_rod(BAR_E), BAR, 2, initial=straight((x, 0, 0), (0, 1, 0), (1, 0, 0), (0, 0, 0), BAR),
                    supports=[Support("left"), Support("right")])
        s.contact(RodContact(k, R_TUBE, friction=friction), a, bar, name=f"rub_{name}")
    s.record(bottom("a"))
    return s, m


def bottom(name):
    """A recorder (System.record) of the column a0_x: the mean x over the body's nodes of its sections' bottom
    points r - r d2 (serial).  It slides as the contact points do: the centreline's nodes also swing as the rod
    rocks on its two supports (the pull and the friction at the bottom make a couple)."""
    def columns(system):
        body = system.bodies[name].body
        r, d2 = (body.space.nodal(body.x1, f)[1] for f in ("r", "d2"))
        return {"a0_x": float(np.mean(r[:, 0] - R_TUBE * d2[:, 0]))}
    return columns


def roller(v0, r_a=R_TUBE, tube=False, La=0.1, friction=FRICTION):
    """Rod a (length La, radius r_a, along y, 2 elements; a solid section, or a thin-walled tube's rotary
    inertia rhoA r_a^2 about its axis) lies across the clamped rod b (radius R_TUBE, along x, 4 elements)
    under gravity, translating along x at v0 without spin: it slides across b and spins up about its own
    axis.  Returns (system, mass of a, its moment of inertia about its axis, the arm rho at rest)."""
    A, Isec = np.pi * r_a**2, np.pi * r_a**4 / 4
    E = 1e9
    rhoJ = ((RHO * A * r_a**2, 0.5 * RHO * A * r_a**2, 0.5 * RHO * A * r_a**2) if tube
            else (2 * RHO * Isec, RHO * Isec, RHO * Isec))
    model = cosserat_rod.CosseratRod(RHO * A, rhoJ, [1 / (E * A), 3 / (E * A), 3 / (E * A)],
                                     [3 / (E * 2 * Isec), 1 / (E * Isec), 1 / (E * Isec)])
    m = model.rhoA * La
    W = m * G
    k = stiffness_for(W, 1e-4)
    s = System(integrator="discrete-gradient", newton_options={"snes_atol": 1e-13, "snes_max_it": 40})
    d = r_a + R_TUBE - 1e-4 / np.sqrt(2)   # at rest: two segment pairs of a (meeting at its middle node) carry W
    a = s.add("a", model, La, 2, initial=straight((0.2 / 16, 0, d), (0, 1, 0), (0, 0, 1), (v0, 0, 0), La),
              loads=[Load("v", [0.0, 0.0, -model.rhoA * G], "domain", "weight")])
    b = s.add("b", solid_rod(E), 0.2, 4, initial=straight((0, 0, 0), (1, 0, 0), (0, 0, 1), (0, 0, 0), 0.2),
              supports=[Support("left"), Support("right")])
    s.contact(RodContact(k, r_a, radius_b=R_TUBE, friction=friction), a, b, name="rub")
    return s, m, rhoJ[0] * La, r_a * d / (r_a + R_TUBE)


def motion(name):
    """A recorder (System.record) of the body `name`'s linear momentum name.p_x and its angular momentum about
    its centre of mass name.Lc_x, _y, _z (serial; the forms compiled at the first call)."""
    forms = {}

    def columns(system):
        body = system.bodies[name].body
        if not forms:
            x = body.space.split(body.x1)
            rhoA = body.model.rhoA
            ufl_forms = dict(body.momentum_forms(x), m=rhoA * body.dx)
            ufl_forms.update({f"c_{c}": rhoA * x["r"][i] * body.dx for i, c in enumerate("xyz")})
            forms.update(compile_forms(ufl_forms))
        val = {k: fem.assemble_scalar(f) for k, f in forms.items()}
        c, p = (np.array([val[f"{q}_{a}"] / (val["m"] if q == "c" else 1.0) for a in "xyz"]) for q in "cp")
        Lc = np.array([val[f"L_{a}"] for a in "xyz"]) - np.cross(c, p)
        return {f"{name}.p_x": p[0], **{f"{name}.Lc_{a}": Lc[i] for i, a in enumerate("xyz")}}
    return columns


@pytest.mark.parametrize("r_a, tube", [(R_TUBE, False), (2 * R_TUBE, True)], ids=["solid", "tube-thicker"])
def test_a_rod_sliding_across_a_rod_spins_up_until_it_rolls(r_a, tube):
    """Rod a slides across the clamped rod b at v0 = 0.05 m/s without spin.  Friction at the tubes' contact
    point (a's bottom, the arm rho = r_a d / R below its axis) slows it and spins it up about its own axis
    until the point rolls.  The friction's impulse P gives m (v0 - v) = P and I omega = rho P whatever the
    friction law, so once the slip v - rho omega is gone v = v0 k / (1 + k), k = m rho^2 / I, and the energy
    lost is 1/2 m v0^2 / (1 + k): a solid rod (I = m r^2 / 2, k = 2) keeps 2/3 of its speed and loses 1/3 of
    its energy; a thin-walled tube (I = m r^2, k = 1) of twice b's radius keeps 1/2 and loses 1/2.  Measured
    (h = 0.25 ms): the first 1 ms decelerates at mu_k g; once rolling, the mean v and omega to 1e-4 and 4e-4
    (tolerance 2e-3), the rigid kinetic energy to 7e-5, the energy lost until the slip first vanishes to 1e-3."""
    v0, h = 0.05, 2.5e-4
    s, m, inertia, rho = roller(v0, r_a, tube)
    s.record(motion("a"))
    result = run(s, h, 0.025)
    k = m * rho**2 / inertia
    assert k == pytest.approx(1.0 if tube else 2.0, rel=1e-2)
    rolled = result.column("t") > 1.3 * v0 / ((1 + k) * FRICTION.mu_k * G)   # the slip falls at mu_k g (1 + k)
    v, omega = result.column("a.p_x") / m, result.column("a.Lc_y") / inertia   # (rolling along +x: spin about +y)
    assert np.abs(v[:5] - v0 + FRICTION.mu_k * G * result.column("t")[:5]).max() < 2e-2 * v0   # sliding: mu_k g
    # rolling: the means (the contact excites a's torsion: the section at the contact turns by ~1 % against the
    # rod's mean spin, and v, omega swap that much back and forth)
    assert v[rolled].mean() == pytest.approx(v0 * k / (1 + k), rel=2e-3)
    assert omega[rolled].mean() == pytest.approx(v0 * k / (1 + k) / rho, rel=2e-3)
    assert np.abs(m * v + inertia * omega / rho - m * v0).max() < 1e-3 * m * v0   # the impulses' invariant
    kinetic = 0.5 * m * v**2 + 0.5 * inertia * omega**2
    assert kinetic[rolled].mean() == pytest.approx(0.5 * m * v0**2 * k / (1 + k), rel=1e-3)
    lost = result.column("dissipated")   # when the slip first vanishes (later the torsion's slip adds a little)
    assert lost[np.argmax(v - rho * omega <= 0)] == pytest.approx(0.5 * m * v0**2 / (1 + k), rel=3e-3)
    assert np.diff(lost).min() >= 0
    assert result.max_balance_error <= 1e-12 * 0.5 * m * v0**2


def test_a_rod_sliding_lengthwise_across_two_rods_stops_like_a_block():
    """v0 = 0.05 m/s along its own axis: while sliding (v > 5 v_s) the velocity falls at mu_k g to 1.5 % (N
    oscillates about the weight: the rods ring), the rod stops after v0^2 / (2 mu_k g) = 0.64 mm to 1 % and
    then stays (|v| < 3 eps, the regularization's creep level); every step's friction work is <= 0 and the
    balance exact.  (Across one rod, sliding across its own axis, it would roll: the test above.)"""
    v0, mu, h = 0.05, FRICTION.mu_k, 1e-3
    s, m = block_on_rods(v0=v0)
    result = run(s, h, 0.035)
    t, x = result.column("t"), result.column("a0_x")
    v, tm = np.diff(x) / h, 0.5 * (t[1:] + t[:-1])
    sliding = v > 5 * FRICTION.v_s
    slope = np.polyfit(tm[sliding], v[sliding], 1)[0]
    assert slope == pytest.approx(-mu * G, rel=1.5e-2)
    assert x[-1] - x[0] == pytest.approx(v0**2 / (2 * mu * G), rel=1e-2)
    assert np.abs(v[tm > 0.03]).max() < 3 * FRICTION.eps
    its = result.column("newton_its")[1:]   # the friction's derivatives in Newton's matrix: few iterations,
    assert its[sliding].max() <= 4 and its.sum() <= 200   # more where the slip meets eps
    lost = np.diff(result.column("dissipated"))
    assert lost.min() >= 0 and lost.sum() > 0.9 * 0.5 * m * v0**2
    assert result.max_balance_error <= 1e-12 * 0.5 * m * v0**2


def creep(pull, W):
    """The regularized law's steady slip under the pull force pull mu_s W at N = W: -factor(W, v^2) v = pull mu_s W
    on the creeping branch (v < 5 eps)."""
    return brentq(lambda u: -FRICTION.factor(W, u * u) * u - pull * FRICTION.mu_s * W, 0.0, 5 * FRICTION.eps)


@pytest.mark.parametrize("pull", [0.5, 1.5], ids=["below-threshold", "above-threshold"])
def test_a_pulled_rod_sticks_below_mu_s_N_and_slides_above(pull):
    """At rest on the two clamped rods, pulled along its axis x by pull mu_s W.  Below the threshold (pull = 0.5) the rod
    creeps at the regularized law's steady slip (1.17e-4 m/s, eps-level) on average to 2 % (N rings by ~7 %
    about W, the creep is convex in N), never above 2 eps; above it (1.5) the friction drops to mu_k N and
    the rod accelerates at (1.5 mu_s - mu_k) g to 1 %."""
    s, m = block_on_rods(pull=pull)
    h = 1e-3
    result = run(s, h, 0.03)
    t, x = result.column("t"), result.column("a0_x")
    v, tm = np.diff(x) / h, 0.5 * (t[1:] + t[:-1])
    late = t >= 0.015
    if pull < 1:
        mean = (x[-1] - x[late][0]) / (t[-1] - t[late][0])
        assert mean == pytest.approx(creep(pull, m * G), rel=2e-2)
        assert np.abs(v[tm > 0.015]).max() < 2 * FRICTION.eps
    else:
        slope = np.polyfit(tm[tm > 0.015], v[tm > 0.015], 1)[0]
        assert slope == pytest.approx((pull * FRICTION.mu_s - FRICTION.mu_k) * G, rel=1e-2)
    assert np.diff(result.column("dissipated")).min() >= 0
    assert result.max_balance_error <= 1e-12 * max(np.abs(result.column("H")).max(), 1e-12)


def rub(system=False, **over):
    p = scene.values({"mu": 0.3, "slide": 0.1, "offset_a": 0.1, "offset_b": 0.05, "t_end": 0.03, "dt": 1e-3, **over})
    s = scene.build(p, MPI.COMM_WORLD)
    if MPI.COMM_WORLD.size == 1:
        s.record(motion("b"))
    result = run(s, p["dt"], p["t_end"])
    return (p, result, s) if system else (p, result)


@pytest.mark.parametrize("rule", ["discrete-gradient", "midpoint"])
def test_two_free_rods_rubbing_keep_momentum_and_the_balance(rule):
    """The rod-collision scene with mu = 0.3 and the rods sliding across each other at 0.1 m/s: the friction
    acts (|F_t| reaches mu N to 2 %), the total momenta p and L stay at their initial values to round-off (the
    friction acts at the tubes' contact point: its forces and section couples have no net moment, touch.Mf = 0,
    and rod b spins up about its axis by the couples' angular impulse); every step's friction work is <= 0;
    with the discrete gradient H + dissipated is constant to round-off."""
    p, result = rub(integrator=rule)
    scale = 0.5 * RHO * np.pi * R_TUBE**2 * p["L"] * p["V"]
    for k in ("p_x", "p_y", "p_z"):
        assert np.abs(result.column(k) - result.rows[0][k]).max() <= 1e-14 * scale, k
    N, Ft = result.column("touch.N"), np.hypot(result.column("touch.Ft_x"), result.column("touch.Ft_y"))
    assert N.max() > 0 and Ft[np.argmax(N)] == pytest.approx(p["mu"] * N.max(), rel=2e-2)
    Mf = np.column_stack([result.column(f"touch.Mf_{c}") for c in "xyz"])
    L = np.column_stack([result.column(f"L_{c}") for c in "xyz"])
    assert np.abs(L - L[0]).max() <= 1e-13 * scale * p["L"]    # (the centrelines' force pair: 2e-5)
    assert np.abs(Mf).max() <= 1e-13 * scale * p["L"] / p["dt"]
    # rod b (along y) rubbed along x spins about its axis by the couples' angular impulse: -sum h rho Ft_x, the arm
    # rho = d / 2 = r - penetration / 2 (measured: to 3e-4; the arm r would give 2 % more)
    arm = R_TUBE - 0.5 * result.column("touch.penetration")
    impulse = -np.cumsum(p["dt"] * arm * result.column("touch.Ft_x"))
    assert result.column("b.Lc_y") == pytest.approx(impulse, rel=1e-3, abs=1e-3 * impulse[-1])
    assert impulse[-1] > 0.5 * p["mu"] * result.column("touch.N").max() * p["dt"] * R_TUBE
    assert result.column("newton_its").max() <= 4   # (the friction's derivatives in Newton's matrix: 2 to 3)
    lost = np.diff(result.column("dissipated"))
    assert lost.min() >= 0 and lost.max() > 0
    if rule == "discrete-gradient":
        assert result.max_balance_error <= 1e-12 * result.column("H").max()


def test_self_contact_with_friction_keeps_momentum_and_the_balance():
    """The hairpin of the self-contact test (one rod whose legs swing into each other) with mu = 0.5 between
    its legs: the legs touch (and rub as they bend), the linear and angular momentum stay at their initial
    values to round-off, the friction's work is never positive and H - supplied + dissipated is exact."""
    s, KE, k = hairpin(contact=False)
    s.contact(RodContact(k, R_TUBE, friction=Coulomb(0.5)), s.bodies["hairpin"], name="self")
    result = run(s, 8e-4, 0.064)
    assert result.column("self.N").max() > 0
    for key in ("p_x", "p_y", "p_z", "L_x", "L_y", "L_z"):
        assert np.abs(result.column(key) - result.rows[0][key]).max() <= 1e-14, key
    assert np.allclose(result.column("self.Ft_x"), 0.0)   # (self-contact: no force "on body a")
    lost = np.diff(result.column("dissipated"))
    assert lost.min() >= 0 and lost.max() > 0
    assert result.max_balance_error <= 1e-12 * KE


def test_a_string_rubbing_a_rod_keeps_p_and_the_balance_and_L_changes_by_the_string_arm():
    """A string (no section: friction at its centreline) crossing a free rod while sliding along it: only the
    rod takes a couple, so the pair's loads have the moment rho_s n x f (rho_s = r_s d / R, the string's share
    of the centrelines' distance): the total angular momentum changes by exactly h rub.Mf each step (Mf not 0),
    the linear momentum is constant to round-off, the friction's work is never positive and the balance is
    exact."""
    rhoA, V, r = 0.3, 0.5, 0.01
    s = System(integrator="discrete-gradient", newton_options={"snes_atol": 1e-12, "snes_max_it": 40})
    a = s.add("a", String(logarithmic(EA=50.0), rhoA), 0.5, 10,
              initial={"r": lambda x: np.vstack([x[0] - 0.25, 0 * x[0] + 0.013, 0 * x[0] + 0.011]),
                       "v": lambda x: np.vstack([0 * x[0] + 0.2, 0 * x[0], 0 * x[0] - V / 2])})
    b = s.add("b", solid_rod(1e7), 0.5, 6, initial=straight((0.017, 0, -0.011), (0, 1, 0), (0, 0, 1), (0, 0, V / 2), 0.5))
    k = 1.5 * (0.25 * rhoA * 0.5) * V**2 / 1e-3**3
    s.contact(RodContact(k, r, friction=Coulomb(0.3)), a, b, name="rub")
    h = 2e-4
    result = run(s, h, 0.01)
    assert result.column("rub.N").max() > 0
    scale = rhoA * 0.5 * V
    for key in ("p_x", "p_y", "p_z"):
        assert np.abs(result.column(key) - result.rows[0][key]).max() <= 1e-14 * scale, key
    Mf = np.column_stack([result.column(f"rub.Mf_{c}") for c in "xyz"])
    L = np.column_stack([result.column(f"L_{c}") for c in "xyz"])
    assert np.abs(Mf).max() > 1e-3 * r * 0.3 * result.column("rub.N").max()
    assert np.abs(np.diff(L, axis=0) - h * Mf[1:]).max() <= 1e-13 * scale * 0.5
    lost = np.diff(result.column("dissipated"))
    assert lost.min() >= 0 and lost.max() > 0
    assert result.max_balance_error <= 1e-12 * result.column("H").max()


def test_the_pattern_grown_at_once_gives_the_same_history(monkeypatch):
    """The contact's entries added to the matrix pattern in one re-preallocation (`grow`) against PETSc
    inserting them as new nonzeros: the same history to the solver's tolerance (rubbing rods, 6 elements);
    with the pattern grown PETSc never reallocates (MatGetInfo's mallocs: 0), without it does."""
    _, grown, s = rub(system=True, n_elements=6, t_end=0.02)
    assert s.assembler.A.getInfo()["mallocs"] == 0
    monkeypatch.setattr(BodyContacts, "grow", lambda self: None)
    _, inserted, s = rub(system=True, n_elements=6, t_end=0.02)
    assert s.assembler.A.getInfo()["mallocs"] > 0
    for key in ("H", "dissipated", "L_y", "touch.N", "touch.Ft_x", "pz_a", "pz_b"):
        a, b = grown.column(key), inserted.column(key)
        assert np.abs(a - b).max() <= 1e-9 * max(np.abs(b).max(), 1e-12), key


def test_broad_phase_between_two_bodies_finds_every_overlap():
    """The two bodies' spheres in two k-d trees (no pair within one body visited): exactly the overlapping
    pairs of a brute force, for spheres of different sizes on the two sides."""
    rng = np.random.default_rng(3)
    a, b = rng.random((300, 3)), rng.random((200, 3))
    ra, rb = 0.01 + 0.01 * rng.random(300), 0.05 + 0.05 * rng.random(200)
    found = {tuple(p) for p in close_pairs(a, ra, b, rb)}
    brute = np.linalg.norm(a[:, None] - b[None], axis=2) <= ra[:, None] + rb[None]
    assert found == set(zip(*np.nonzero(brute))) and len(found) > 50


def test_bad_friction_is_refused_in_one_line():
    with pytest.raises(InputError, match="friction must be a Coulomb"):
        RodContact(1.0, 0.01, friction=0.3)
    with pytest.raises(InputError, match="mu_k must be in"):
        RodContact(1.0, 0.01, friction=Coulomb(0.2, 0.4))
    with pytest.raises(InputError, match="mu"):
        scene.values({"mu": -1.0})


SCRIPT = """
import json
from mpi4py import MPI
import rodfem
from rodfem.demos.rod_collision import scene
p = scene.values({"t_end": 0.02, "dt": 1e-3, "offset_a": 0.1, "offset_b": 0.05, "E": 1e8, "mu": 0.3, "slide": 0.1})
result = rodfem.run(scene.build(p, MPI.COMM_WORLD), p["dt"], p["t_end"])
if MPI.COMM_WORLD.rank == 0:
    row = result.rows[-1]
    row.pop("wall_time", None)
    print(json.dumps(row))
"""


@pytest.mark.mpi
def test_rubbing_rods_in_parallel_equal_serial():
    """Two rods rubbing (8 elements per rod over 2 ranks: velocities gathered with the positions, the friction's
    dissipation broadcast) under mpirun -n 2 write the serial history; the friction is on at the end."""
    serial, parallel = script_on_ranks(SCRIPT, timeout=600)
    assert serial["touch.N"] > 0 and serial["dissipated"] > 0
    assert_same_rows(serial, parallel)
