"""Contact between rods (forms/rod_contact.py, rodfem/core/bodycontact.py) against independent answers:
the segments' distance against a brute-force search, the broad phase against all pairs; the step's force
against its definition (work = the energy's change, no net force or moment); two rods crossing at right
angles (momentum and the energy balance to round-off; stiff rods against the rigid-body impulse law, the
error shrinking with the stiffness); a rod lying across two clamped rods (statics: the contact forces carry
its weight, split by the lever law); a hairpin whose legs swing into each other (self-contact: they stop,
penetrating less than the energy allows, and pass through each other without the contact); bad input;
mpirun -n 2 = serial."""

import numpy as np
import pytest
from mpi4py import MPI
from processes import script_on_ranks

from rodfem import Load, Support, System, ground, run
from rodfem.analysis.statics import solve
from rodfem.analysis.stepping import StepControl
from rodfem.core.bodycontact import Pairing, close_pairs, segment_spheres
from rodfem.core.components import potential
from rodfem.demos.rod_collision import rigid, scene, section, solid_rod, straight
from rodfem.errors import ConstraintError, InputError, NewtonFailure, ParameterError
from rodfem.forms.contact import stiffness_for
from rodfem.forms.rigid_body import PointMass
from rodfem.forms.rod_contact import RodContact, closest_points
from rodfem.forms.string import String
from rodfem.forms.string_materials import logarithmic

# -- geometry and the step's force, without a mesh ---------------------------------------------------

def test_segment_distance_against_a_brute_force_search():
    """The clamped closest points of random segment pairs (crossing, skew, nearly parallel, end-to-side)
    against the minimum over a 401 x 401 grid of the two parameters: never above it, at most the grid's
    resolution below it; n along the closest points' difference."""
    rng = np.random.default_rng(7)
    p0, p1, q0, q1 = (rng.normal(size=(40, 3)) for _ in range(4))
    q1[:5] = q0[:5] + (p1[:5] - p0[:5]) * 0.7 + 1e-9 * rng.normal(size=(5, 3))   # nearly parallel
    d, a, b, n = closest_points(p0, p1, q0, q1)
    t = np.linspace(0.0, 1.0, 401)
    for k in range(len(d)):
        x = p0[k] + t[:, None] * (p1[k] - p0[k])
        y = q0[k] + t[:, None] * (q1[k] - q0[k])
        grid = np.min(np.linalg.norm(x[:, None] - y[None], axis=2))
        scale = np.linalg.norm(p1[k] - p0[k]) + np.linalg.norm(q1[k] - q0[k])
        assert d[k] <= grid + 1e-12
        assert grid - d[k] <= (scale / 400) ** 2 / max(d[k], 1e-3) + 1e-12
        diff = (p0[k] + a[k] * (p1[k] - p0[k])) - (q0[k] + b[k] * (q1[k] - q0[k]))
        assert np.linalg.norm(diff) == pytest.approx(d[k], rel=1e-12)
        assert 0.0 <= a[k] <= 1.0 and 0.0 <= b[k] <= 1.0


class _Line:
    """A stand-in centreline for a Pairing used without bodies."""
    s = q = v = None


@pytest.mark.parametrize("rule", ["discrete-gradient", "midpoint"])
def test_the_step_force_does_the_energy_change_with_no_net_force_or_moment(rule):
    """For random steps of penetrating segment pairs (the contact starting, ending or lasting within the
    step): sum F . (X1 - X0) = V(X1) - V(X0) to round-off with the discrete gradient (not with the midpoint
    rule); the forces sum to zero and have no moment about the origin at the midpoint positions."""
    rng = np.random.default_rng(3)
    law = RodContact(1e6, 0.3)
    pair = Pairing(law, _Line(), _Line(), "test")
    X0 = rng.normal(size=(400, 4, 3)) * 0.5
    X1 = X0 + rng.normal(size=(400, 4, 3)) * 0.2 * rng.uniform(0, 1, size=(400, 1, 1)) ** 3
    F = pair.force(X0, X1, rule)
    d0, d1 = pair.distance(X0), pair.distance(X1)
    assert np.sum(d0 < pair.R) > 50 and np.sum((d0 < pair.R) != (d1 < pair.R)) > 5
    change = law.energy(d1, pair.R) - law.energy(d0, pair.R)
    work = np.einsum("nij,nij->n", F, X1 - X0)
    scale = np.maximum(law.energy(d0, pair.R) + law.energy(d1, pair.R), 1e-30)
    error = np.abs(work - change) / scale
    if rule == "discrete-gradient":
        assert error.max() <= 1e-11
    else:
        assert error.max() >= 1e-4
    Xm = 0.5 * (X0 + X1)
    size = np.abs(F).max(axis=(1, 2))[:, None]
    assert np.abs(F.sum(axis=1)).max() <= 1e-12 * size.max()
    moment = np.cross(Xm, F).sum(axis=1)
    assert np.all(np.abs(moment) <= 1e-11 * size * (1 + np.abs(Xm).max()))


def test_broad_phase_finds_every_overlap_and_stays_linear():
    """The spheres' pairs from the k-d tree equal all overlapping pairs found by the O(n^2) test; along a long
    straight rod of 10^4 segments the candidates are the neighbours only (about 2 per segment: linear)."""
    rng = np.random.default_rng(11)
    c, r = rng.uniform(0, 1, size=(400, 3)), rng.uniform(0.01, 0.06, size=400)
    found = {tuple(p) for p in close_pairs(c, r)}
    dist = np.linalg.norm(c[:, None] - c[None], axis=2)
    brute = {(i, j) for i in range(400) for j in range(i + 1, 400) if dist[i, j] <= r[i] + r[j]}
    assert found == brute and len(brute) > 100
    for n in (100, 10000):
        x = np.outer(np.linspace(0.0, 1.0, n + 1), [1.0, 0.0, 0.0])
        centres, radii = segment_spheres(x, grow=0.1 / n)
        assert len(close_pairs(centres, radii)) <= 2 * n


def test_self_contact_leaves_out_the_rods_own_neighbourhood():
    """A straight rod of segments much shorter than its radius has no contact with itself (its neighbours
    within pi r along it are left out), and neither has a half circle of radius 1.05 r (a fold whose ends are
    2.1 r apart); a coil whose turns are 1.5 r apart touches itself about once per segment."""
    law = RodContact(1.0, 0.01)
    for x in (np.outer(np.linspace(0.0, 0.2, 81), [1.0, 0.0, 0.0]),
              0.0105 * np.column_stack([np.cos(t := np.linspace(0, np.pi, 200)), np.sin(t), 0 * t])):
        line = _Line()
        line.s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(x, axis=0), axis=1))])
        pair = Pairing(law, line, None, "self")
        pairs = pair.candidates((x,), None, (0,))
        assert not np.any(pair.distance(pair.stack(x, None, pairs)) < pair.R) if len(pairs) else True
    t = np.linspace(0, 4 * np.pi, 400)
    x = np.column_stack([0.1 * np.cos(t), 0.1 * np.sin(t), 0.015 * t / (2 * np.pi)])
    line = _Line()
    line.s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(x, axis=0), axis=1))])
    pair = Pairing(law, line, None, "self")
    pairs = pair.candidates((x,), None, (0,))
    assert np.sum(pair.distance(pair.stack(x, None, pairs)) < pair.R) >= 150


def test_segment_pairs_sharing_the_contact_zone_converge_to_the_double_integral():
    """Two straight lines crossing at right angles, the centrelines R - p apart, cut into segments much shorter
    than the contact zone sqrt(2 R p): the weighted sum over the segment pairs (zone = sqrt(2 R p)) converges
    at first order to the double integral int int k/3 <R - |x(s) - y(t)|>^3 ds dt / zone^2 =
    2 pi k (R p^4/4 - p^5/5) / (3 zone^2) (closed form: polar coordinates about the crossing), not to
    a sum that grows with the number of pairs (1300 to 5000 of them)."""
    r, p = 0.01, 1e-3
    R = 2 * r
    zone = np.sqrt(2 * R * p)
    law = RodContact(1e6, r, zone=zone)
    exact = law.k / 3 * 2 * np.pi / zone**2 * (R * p**4 / 4 - p**5 / 5)
    errors = []
    for ell in (zone / 10, zone / 20, zone / 40):
        s = np.arange(int(round(0.1 / ell)) + 1) * ell
        xa = np.column_stack([s - s[-1] / 2 + 0.37 * ell, 0 * s, 0 * s + R - p])
        xb = np.column_stack([0 * s, s - s[-1] / 2 + 0.21 * ell, 0 * s])
        A, B = _Line(), _Line()
        A.s = B.s = s
        pair = Pairing(law, A, B, "zone")
        pairs = pair.candidates((xa,), (xb,), (0,))
        V = np.sum(pair.weights(pairs) * law.energy(pair.distance(pair.stack(xa, xb, pairs)), pair.R))
        errors.append(V / exact - 1)
    assert 0 < errors[2] <= 0.08 and errors[2] <= 0.6 * errors[1] <= 0.36 * errors[0]


# -- two rods crossing at right angles ------------------------------------------------------------

def collide(**over):
    p = scene.values(over)
    return p, run(scene.build(p, MPI.COMM_WORLD), p["dt"], p["t_end"])


@pytest.mark.parametrize("rule", ["discrete-gradient", "midpoint"])
def test_collision_keeps_momentum_and_energy(rule):
    """Two soft rods (E = 3e5, the crossing off both centres) collide and part: the total linear and angular
    momentum stay at their initial values to round-off under either rule; H (with the contact energy) is
    constant to round-off with the discrete gradient, not with the midpoint rule."""
    p, result = collide(integrator=rule, offset_a=0.1, offset_b=0.05, t_end=0.05, dt=1e-3)
    scale = rigid(p)["m_eff"] * p["V"] * p["L"]
    for k in ("p_x", "p_y", "p_z", "L_x", "L_y", "L_z"):
        assert np.abs(result.column(k) - result.rows[0][k]).max() <= 1e-14 * scale, k
    N = result.column("touch.N")
    assert N.max() > 0 and result.column("touch.penetration").max() > 0
    Fz = result.column("touch.Fn_z")[np.argmax(N)]   # on rod a, along z up to the lean of the bent rods
    assert 0.999 * N.max() <= Fz <= N.max() * (1 + 1e-12)
    if rule == "discrete-gradient":
        assert result.max_balance_error <= 1e-12 * max(result.column("touch.energy").max(), 1e-30) + 1e-15
    else:
        assert result.max_balance_error >= 1e-8


@pytest.mark.parametrize("offsets", [(0.0, 0.0), (0.1, 0.05)], ids=["centres", "off-centre"])
def test_stiff_rods_follow_the_rigid_body_impulse_law(offsets):
    """Frictionless and elastic, rigid rods exchange J = 2 m_eff V (centred: the velocities swap; off-centre:
    the rods also spin, L = -offset J).  The rods' momenta after the impact approach the rigid answer as E
    grows: within 3e-2 of J at E = 1e9, within 3e-4 at E = 1e10 (the rest: the rods turn during the impact),
    the error at least 10 times smaller."""
    errors = []
    for E in (1e9, 1e10):
        p, result = collide(E=E, offset_a=offsets[0], offset_b=offsets[1], t_end=0.06, dt=1e-3, n_elements=6)
        last = result.rows[-1]
        assert last["touch.N"] == 0.0     # apart again
        J = rigid(p)["J"]
        errors.append(max(abs(last[k] - last[k + "_rigid"]) / J for k in ("pz_a", "pz_b", "Ly_a", "Lx_b")))
    assert errors[1] <= 3e-4 and errors[0] <= 3e-2
    assert errors[1] <= errors[0] / 10


def test_strings_collide_with_the_same_contact():
    """The same law between two strings (no cross-section: the tubes of radius 0.01 about the P1 centrelines)
    crossing at right angles: they touch and part with the total momenta constant to round-off and H (with the
    contact energy) constant to round-off."""
    rhoA, V, r = 0.3, 0.5, 0.01
    s = System(integrator="discrete-gradient", newton_options={"snes_atol": 1e-12, "snes_max_it": 40})
    model = String(logarithmic(EA=50.0), rhoA)
    a = s.add("a", model, 0.5, 10, initial={"r": lambda x: np.vstack([x[0] - 0.25, 0 * x[0] + 0.013, 0 * x[0] + 0.011]),
                                            "v": lambda x: np.vstack([0 * x[0], 0 * x[0], 0 * x[0] - V / 2])})
    b = s.add("b", model, 0.5, 10, initial={"r": lambda x: np.vstack([0 * x[0] + 0.017, x[0] - 0.25, 0 * x[0] - 0.011]),
                                            "v": lambda x: np.vstack([0 * x[0], 0 * x[0], 0 * x[0] + V / 2])})
    k = 1.5 * (0.25 * rhoA * 0.5) * V**2 / 1e-3**3
    s.contact(RodContact(k, r), a, b, name="strings")
    result = run(s, 2e-4, 0.02)
    assert result.column("strings.N").max() > 0 and result.rows[-1]["strings.N"] == 0.0
    H = result.column("H")
    assert result.max_balance_error <= 1e-12 * H.max()
    for key in ("p_x", "p_y", "p_z", "L_x", "L_y", "L_z"):
        assert np.abs(result.column(key) - result.rows[0][key]).max() <= 1e-14 * rhoA * V, key
    assert result.rows[-1]["p_z"] == pytest.approx(0.0, abs=1e-15)


# -- a rod resting across two clamped rods (statics) -------------------------------------------

@pytest.mark.parametrize("xb,xc", [(-0.125, 0.125), (-0.125, 0.0625)], ids=["symmetric", "lever"])
def test_rod_resting_across_clamped_rods_carries_its_weight(xb, xc):
    """Rod a (along x, gravity) rests across the clamped-clamped rods b and c (along y at x = xb, xc); soft
    springs to the ground hold it horizontally and against spin (no force along z).  At rest the contact
    forces along z sum to the weight to 1e-9, and split as on a beam on two supports,
    F_b = W (x_c - x_cm) / (x_c - x_b), up to the cylinders' lean: O(R theta / lever) ~ 5e-4 (the symmetric
    case: W/2 each to 1e-7)."""
    L, r, g = 0.5, 0.01, 9.81
    model = solid_rod(1e9)
    W = model.rhoA * L * g
    k, d0 = stiffness_for(W / 2, 1e-4), 5e-5
    s = System(integrator="discrete-gradient")
    z = 2 * r - d0
    a = s.add("a", model, L, 8, initial=straight((0, 0, z), (1, 0, 0), (0, 1, 0), (0, 0, 0), L),
              loads=[Load("v", [0.0, 0.0, -model.rhoA * g], "domain", "gravity")])
    for name, x in (("b", xb), ("c", xc)):
        support = s.add(name, model, L, 8, initial=straight((x, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0, 0), L),
                        supports=[Support("left"), Support("right")])
        s.contact(RodContact(k, r), a, support, name=f"on_{name}")

    def separation(p, q, p0, q0):
        return q.x - p.x
    ks, ez = 1e4, np.array([0.0, 0.0, 1.0])
    s.connect(potential(separation, lambda xi: 0.5 * ks * (xi[0] ** 2 + xi[1] ** 2)), ground((-L / 2, 0, z)), a.start)
    s.connect(potential(separation, lambda xi: 0.5 * ks * xi[1] ** 2), ground((L / 2, 0, z)), a.end)
    s.connect(potential(lambda p, q, p0, q0: [q.d[1] @ ez], lambda xi: 0.5 * ks * xi ** 2), ground(), a.start)
    s.marker("a0", a.start)
    s.marker("a1", a.end)
    solve(s, steps=1)
    obs = s.observe()
    Fb, Fc = obs["on_b.Fn_z"], obs["on_c.Fn_z"]
    assert (Fb + Fc) / W == pytest.approx(1.0, abs=1e-9)
    x_cm = 0.5 * (obs["a0_x"] + obs["a1_x"])
    lever = W * (xc - x_cm) / (xc - xb)
    if xb == -xc:
        assert Fb / W == pytest.approx(0.5, abs=1e-7)   # (the spring along x at one end only)
    assert Fb == pytest.approx(lever, rel=5e-4)
    assert obs["on_b.penetration"] > 0 and obs["on_c.penetration"] > 0


# -- self-contact: a hairpin whose legs swing into each other ------------------------------------

def hairpin(E=1e6, V=0.5, contact=True, L=0.5, r=0.01, bend=0.03, n=12):
    """A rod bent into a U (legs along x at y = +-bend joined by a half circle of radius bend), its legs
    swinging towards each other (velocity V x / l across, the tips fastest)."""
    l = 0.5 * (L - np.pi * bend)

    def geometry(s):
        leg1, leg2 = s < l, s > L - l
        phi = (s - l) / bend
        x = np.where(leg1, l - s, np.where(leg2, s - (L - l), -bend * np.sin(phi)))
        y = np.where(leg1, bend, np.where(leg2, -bend, bend * np.cos(phi)))
        tx = np.where(leg1, -1.0, np.where(leg2, 1.0, -np.cos(phi)))
        ty = np.where(leg1 | leg2, 0.0, -np.sin(phi))
        return x, y, np.vstack([tx, ty, 0 * tx])

    def directors(i):
        def f(x):
            t = geometry(x[0])[2]
            e3 = np.vstack([0 * t[0], 0 * t[0], 1 + 0 * t[0]])
            return [t, np.cross(e3.T, t.T).T, e3][i]
        return f

    def velocity(x):
        X, Y, _ = geometry(x[0])
        leg = np.abs(Y) >= bend * (1 - 1e-12)
        return np.vstack([0 * X, np.where(leg, -np.sign(Y) * V * X / l, 0.0), 0 * X])
    initial = {"r": lambda x: np.vstack([*geometry(x[0])[:2], 0 * x[0]]), "v": velocity,
               **{f"d{i + 1}": directors(i) for i in range(3)},
               **{f"w{i}": lambda x: np.zeros((3, x.shape[1])) for i in (1, 2, 3)}}
    s = System(integrator="discrete-gradient", newton_options={"snes_atol": 1e-12, "snes_max_it": 40})
    model = solid_rod(E)
    rod = s.add("hairpin", model, L, n, initial=initial)
    KE = 0.5 * model.rhoA * 2 * V**2 * l / 3
    k = 1.5 * KE / 1e-3**3
    if contact:
        s.contact(RodContact(k, r), rod, name="self")
    s.marker("tip0", rod.start)
    s.marker("tip1", rod.end)
    return s, KE, k


def test_self_contact_stops_a_hairpin_from_passing_through_itself():
    """The legs' tips meet (self-contact of one rod; the bend itself, closer than pi r along the rod, is left
    out) and stay apart: the tips never cross y = 0, and the penetration stays below the energy's bound
    (3 H_0 / k)^(1/3) (k d^3 / 3 <= H_0); the momenta and the balance to round-off.  Without the contact the
    same legs pass through each other."""
    s, KE, k = hairpin()
    result = run(s, 4e-4, 0.08)
    pen = result.column("self.penetration")
    assert pen.max() > 1e-5
    assert pen.max() <= (3 * KE / k) ** (1 / 3)
    assert result.column("self.energy").max() <= KE * (1 + 1e-9)     # H_0 = KE: the U is stress-free
    assert result.column("tip0_y").min() > 0 and result.column("tip1_y").max() < 0
    assert result.max_balance_error <= 1e-12
    for key in ("p_x", "p_y", "p_z", "L_x", "L_y", "L_z"):
        assert np.abs(result.column(key) - result.rows[0][key]).max() <= 1e-14
    free, _, _ = hairpin(contact=False)
    assert run(free, 4e-4, 0.08).column("tip0_y").min() < 0


# -- a step that would carry the rods through each other -------------------------------------------

def test_a_step_that_would_pass_the_rods_through_each_other_is_split():
    """Stiff rods (E = 1e9) approaching at V = 10 m/s with steps of 6 ms: one step carries them 6 cm, from
    2.1 cm apart to the other side, with the contact at neither end, so its force is zero and without the
    guard (`System.guard_crossing`) the rods tunnel (their momenta unchanged, no contact ever).  With it
    the step is refused (its pairs' certified clearance (d_n + d_n+1 - s)/2 < R/2,
    rodfem/core/bodycontact.py) and split: the rods touch and bounce (the momentum of rod a reversed,
    its change within a quarter of the rigid-body impulse J = 2 m_eff V at these steps: measured 0.2),
    the balance to round-off of the contact forces.  With no split allowed the refused step ends the
    run, naming the pair."""
    over = {"V": 10.0, "dt": 0.006, "t_end": 0.03, "E": 1e9, "n_elements": 6}
    p = scene.values(over)
    answer, before = rigid(p), -0.5 * section(p)[0] * p["V"]
    free = scene.build(p, MPI.COMM_WORLD)
    free.guard_crossing = False
    tunnel = run(free, p["dt"], p["t_end"])
    assert tunnel.column("touch.N").max() == 0.0 and tunnel.stepping["rejected"] == 0
    assert tunnel.rows[-1]["pz_a"] == pytest.approx(before, rel=1e-12)
    guarded = run(scene.build(p, MPI.COMM_WORLD), p["dt"], p["t_end"])
    assert guarded.stepping["rejected"] > 0 and guarded.stepping["substeps"] > 5
    assert guarded.rows[-1]["pz_a"] > 0 and abs(guarded.rows[-1]["pz_a"] - answer["pz_a"]) <= 0.25 * answer["J"]
    assert guarded.max_balance_error <= 1e-11 * guarded.column("H").max()
    with pytest.raises(NewtonFailure, match="may pass through each other"):
        run(scene.build(p, MPI.COMM_WORLD), p["dt"], p["t_end"], control=StepControl(dt_min=p["dt"]))


# -- bad input -----------------------------------------------------------------------------------

def test_bad_input_is_refused_in_one_line():
    with pytest.raises(InputError, match="stiffness must be a positive number"):
        RodContact(-1.0, 0.01)
    with pytest.raises(InputError, match="radius must be a length >= 0"):
        RodContact(1.0, float("nan"))
    with pytest.raises(InputError, match="exclude must be an arc length"):
        RodContact(1.0, 0.01, exclude=-1.0)
    s = System()
    a = s.add("a", solid_rod(1e6), 0.5, 2)
    ball = s.add("ball", PointMass(1.0, 3), initial=PointMass.initial((0, 0, 1.0), (0, 0, 0)))
    with pytest.raises(ConstraintError, match="rigid"):   # (a sphere of radius > 0: tests/models/test_rigid_rod_contact.py)
        s.contact(RodContact(1.0, 0.01, radius_b=0.0), a, ball)
    with pytest.raises(ConstraintError, match="self-contact: give b = None"):
        s.contact(RodContact(1.0, 0.01), a, a)
    with pytest.raises(ConstraintError, match="not a rod contact law"):
        s.contact(object(), a)
    with pytest.raises(ParameterError, match="offset_a"):
        scene.build(scene.values({"offset_a": 0.3}), MPI.COMM_WORLD)


# -- serial = mpirun -n 2 ------------------------------------------------------------------------

SCRIPT = """
import json
from mpi4py import MPI
import rodfem
from rodfem.demos.rod_collision import scene
p = scene.values({"t_end": 0.03, "dt": 1e-3, "offset_a": 0.1, "offset_b": 0.05, "E": 1e8})
result = rodfem.run(scene.build(p, MPI.COMM_WORLD), p["dt"], p["t_end"])
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(result.rows[-1]))
"""


@pytest.mark.mpi
def test_rod_collision_in_parallel_equals_serial():
    """The collision (8 elements per rod over 2 ranks: the centrelines gathered on rank 0, the forces added to
    the owners' rows) under mpirun -n 2 writes the serial history; the contact is on at the end."""
    serial, parallel = script_on_ranks(SCRIPT, timeout=600)
    assert serial["touch.N"] > 0
    assert serial.keys() == parallel.keys()
    for key, value in serial.items():
        if key != "wall_time":
            assert parallel[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
