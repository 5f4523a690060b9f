"""Contact between a rigid body's sphere and a rod or string (forms/rod_contact.py with a segment of zero
length, rodfem/core/bodycontact.py) against independent answers: the point-to-segment distance against a
brute-force search; the step's force against its definition (work = the energy's change, no net force or
moment) with the sphere's centre as a doubled node; a heavy ball resting on a clamped-clamped beam and on a
taut string (statics: the contact force equals the weight, the deflection the analytic beam's and string's
under a point load); a ball hitting a free stiff rod at its centre and off it (momentum and the energy
balance to round-off, the rod's and the ball's momenta after the impact against the rigid-body impact law,
for equal and unequal masses; off-centre the rod spins and the total angular momentum stays); bad input;
mpirun -n 2 = serial."""

import os

import numpy as np
import pytest
from processes import script_on_ranks
from scipy.optimize import brentq

from rodfem import Load, Support, System, ground, run
from rodfem.analysis.statics import solve
from rodfem.core.bodycontact import Pairing
from rodfem.core.components import potential
from rodfem.demos.rod_collision import solid_rod
from rodfem.errors import ConstraintError, ParameterError
from rodfem.fem.jit import compile_forms
from rodfem.forms.contact import Coulomb, stiffness_for
from rodfem.forms.rigid_body import PlanarRigidBody, PointMass, RigidBody
from rodfem.forms.rod_contact import RodContact, closest_points
from rodfem.forms.string import String
from rodfem.forms.string_materials import biot


def straight(L, z=0.0, velocity=(0.0, 0.0, 0.0)):
    """A straight rod along x centred at (0, 0, z), translating."""
    initial = {"r": lambda x: np.vstack([x[0] - 0.5 * L, 0 * x[0], 0 * x[0] + z]),
               "v": lambda x: np.outer(velocity, np.ones(x.shape[1]))}
    for i, d in enumerate(np.eye(3)):
        initial[f"d{i + 1}"] = lambda x, d=d: np.outer(d, np.ones(x.shape[1]))
        initial[f"w{i + 1}"] = lambda x: np.zeros((3, x.shape[1]))
    return initial


# -- geometry and the step's force, without a mesh ---------------------------------------------------

def test_point_to_segment_distance_against_a_brute_force_search():
    """A segment of zero length (a point, either side) against segments: the distance equals the minimum
    over 100001 points of the segment to the grid's resolution and is never above it; a point against a
    point: their distance.  No NaN anywhere (the general formula divides by the length)."""
    rng = np.random.default_rng(5)
    p0, p1, c = (rng.normal(size=(30, 3)) for _ in range(3))
    t = np.linspace(0.0, 1.0, 100001)
    for d, a, b, n in (closest_points(p0, p1, c, c), closest_points(c, c, p0, p1)):
        assert np.all(np.isfinite(d)) and np.all(np.isfinite(n))
        for k in range(len(d)):
            brute = np.min(np.linalg.norm(p0[k] + t[:, None] * (p1[k] - p0[k]) - c[k], axis=1))
            assert d[k] <= brute + 1e-14 and brute - d[k] <= np.linalg.norm(p1[k] - p0[k]) ** 2 / 1e10 / d[k] + 1e-14
    d, a, b, n = closest_points(p0, p1, c, c)
    assert np.all(b == 0.0)
    assert np.allclose(np.linalg.norm(p0 + a[:, None] * (p1 - p0) - c, axis=1), d, rtol=1e-13)
    d, a, b, n = closest_points(c, c, p0, p0)
    assert np.allclose(d, np.linalg.norm(c - p0, axis=1), rtol=1e-14) and np.all(a == 0) and np.all(b == 0)


class _Line:
    """A stand-in centreline for a Pairing used without bodies."""
    s = q = v = None


@pytest.mark.parametrize("rule", ["discrete-gradient", "midpoint"])
def test_the_step_force_on_a_sphere_does_the_energy_change_with_no_net_force_or_moment(rule):
    """A sphere's centre c (both nodes of body b at c: a segment of zero length) against a rod's segment, for
    random steps that start, end or keep a contact: the work of the forces (those on the two copies of c
    added: the rows they share) equals V(X1) - V(X0) to round-off with the discrete gradient, not with the
    midpoint rule; the forces sum to zero and have no moment about the origin at the midpoint positions."""
    rng = np.random.default_rng(4)
    law = RodContact(1e6, 0.1, radius_b=0.25)
    pair = Pairing(law, _Line(), _Line(), "test")
    n = 400
    seg0 = rng.normal(size=(n, 2, 3)) * 0.5
    c0 = rng.normal(size=(n, 1, 3)) * 0.3
    dseg = rng.normal(size=(n, 2, 3)) * 0.2 * rng.uniform(0, 1, size=(n, 1, 1)) ** 3
    dc = rng.normal(size=(n, 1, 3)) * 0.2 * rng.uniform(0, 1, size=(n, 1, 1)) ** 3
    X0 = np.concatenate([seg0, c0, c0], axis=1)
    X1 = np.concatenate([seg0 + dseg, c0 + dc, c0 + dc], axis=1)
    F = pair.force(X0, X1, rule)
    d0, d1 = pair.distance(X0), pair.distance(X1)
    assert np.sum(d0 < pair.R) > 50 and np.sum((d0 < pair.R) != (d1 < pair.R)) > 5
    work = np.einsum("nij,nij->n", F[:, :2], dseg) + np.einsum("nj,nj->n", F[:, 2] + F[:, 3], dc[:, 0])
    change = law.energy(d1, pair.R) - law.energy(d0, pair.R)
    scale = np.maximum(law.energy(d0, pair.R) + law.energy(d1, pair.R), 1e-30)
    error = np.abs(work - change) / scale
    if rule == "discrete-gradient":
        assert error.max() <= 1e-11
    else:
        assert error.max() >= 1e-4
    Xm = 0.5 * (X0 + X1)
    size = np.abs(F).max(axis=(1, 2))[:, None]
    assert np.abs(F.sum(axis=1)).max() <= 1e-12 * size.max()
    assert np.all(np.abs(np.cross(Xm, F).sum(axis=1)) <= 1e-11 * size * (1 + np.abs(Xm).max()))


def test_a_sphere_counts_as_one_point_in_the_contact_zone_weights():
    """With a contact zone (segments shorter than it share it), a sphere's centre (a segment of zero length)
    weighs 1, the rod's segments min(1, l / zone), either order of the bodies."""
    law = RodContact(1.0, 0.01, radius_b=0.05, zone=0.1)
    rod, ball = _Line(), _Line()
    rod.s, ball.s, ball.point = np.array([0.0, 0.05, 0.3]), np.zeros(2), True
    pairs = np.array([[0, 0], [1, 0]])
    assert np.allclose(Pairing(law, rod, ball, "w").weights(pairs), [0.5, 1.0])
    assert np.allclose(Pairing(law, ball, rod, "w").weights(pairs[:, ::-1]), [0.5, 1.0])


# -- a heavy ball at rest on a clamped-clamped beam and on a taut string (statics) ----------------------

def hold_sideways(s, ball, at, ks=1e2):
    """Soft springs to the ground along x and y at the ball (a ball on a cylinder's top rolls off sideways);
    no force along z, none at the symmetric rest state."""
    def separation(p, q, p0, q0):
        return q.x - p.x
    s.connect(potential(separation, lambda xi: 0.5 * ks * (xi[0] ** 2 + xi[1] ** 2)), ground(at), ball.point())


def ball_on_beam(x_ball, n, M=0.02, L=1.0, r=0.01, E=1e9, R_s=0.03, g=9.81):
    """A ball (a point mass of weight P = M g with a sphere of radius R_s) at rest on a clamped-clamped beam
    along x at x_ball from its centre: (contact force on the ball / P - 1, the beam's deflection under the ball
    / the analytic one - 1).  The deflection: the ball's height less r + R_s, plus the penetration; the
    analytic one of the linear Timoshenko beam, P a^3 b^3 / (3 E I L^3) + P a b / (L G A) (a, b the load's
    distances to the ends; the rod's shear compliance 1/(G A) has no correction factor; the shear part is
    0.4 % of the total and its split between the ends is that of a simply supported beam, 1e-4 off)."""
    P = M * g
    k = stiffness_for(P, 1e-4)
    z = r + R_s - 1e-5
    s = System(integrator="discrete-gradient")
    beam = s.add("beam", solid_rod(E, r), L, n, initial=straight(L), supports=[Support("left"), Support("right")])
    ball = s.add("ball", PointMass(M), initial=PointMass.initial((x_ball, 0.0, z)),
                 loads=[Load("v", [0.0, 0.0, -P], "domain", "weight")])
    s.contact(RodContact(k, r, radius_b=R_s), beam, ball, name="rest")
    hold_sideways(s, ball, (x_ball, 0.0, z))
    s.marker("ball", ball.point())
    solve(s, steps=2)
    obs = s.observe()
    A, Isec = np.pi * r**2, np.pi * r**4 / 4
    a, b = 0.5 * L + obs["ball_x"], 0.5 * L - obs["ball_x"]
    exact = P * a**3 * b**3 / (3 * E * Isec * L**3) + P * a * b / (L * (E / 3) * A)
    sag = (r + R_s) - obs["rest.penetration"] - obs["ball_z"]
    assert obs["rest.active"] == (2 if x_ball == 0 else 1)   # at a node: the two segments' pairs
    return -obs["rest.Fn_z"] / P - 1, sag / exact - 1


def test_ball_resting_on_a_clamped_beam_at_a_node_deflects_it_as_a_point_load():
    """A ball of weight P = 0.2 N on the centre of a clamped-clamped beam (E = 1e9, r = 0.01, L = 1, 16
    elements; no beam weight): at rest the contact force on the ball equals P to 1e-10 and the beam's centre
    deflects by P L^3 / (192 E I) + P L / (4 G A) within 2e-4 (measured 4e-5: the load on a node, the
    rest is the clamped beam's stretching, 1e-4 of the deflection squared over r^2: 5e-7 at P/10)."""
    force, deflection = ball_on_beam(0.0, 16)
    assert abs(force) <= 1e-10
    assert abs(deflection) <= 2e-4


def test_ball_resting_inside_a_segment_deflects_the_beam_converging_with_the_mesh():
    """The same ball 0.02 off the centre, inside a segment (its force shared by the segment's two nodes
    linearly): the contact force equals P to 1e-10, and the deflection under the ball approaches the
    analytic P a^3 b^3 / (3 E I L^3) + shear as the mesh is refined: within 1e-2 at 16 elements (measured
    5.4e-3), 3e-3 at 32 (1.3e-3), the error shrinking at least 3 times."""
    errors = []
    for n in (16, 32):
        force, deflection = ball_on_beam(0.02, n)
        assert abs(force) <= 1e-10
        errors.append(abs(deflection))
    assert errors[0] <= 1e-2 and errors[1] <= 3e-3 and errors[1] <= errors[0] / 3


@pytest.mark.parametrize("R_s", [0.03, 0.003], ids=["big-ball", "small-ball"])
def test_ball_resting_on_a_taut_string_sags_it_as_the_exact_string(R_s):
    """A ball (P = 0.4 N, sphere radius R_s) at rest on the centre of a massless string (EA = 1000, biot:
    N = EA (lambda - 1), reference length 1, pinned 1.01 apart: T_0 = 10 N; 8 elements) held sideways by soft
    springs.  The contact force equals P to 1e-10, and the sag under the ball approaches the exact one of
    two straight halves: 2 T sin(theta) = P with T = EA (lambda - 1), lambda = cos(theta)^-1 (the pinned
    halves' stretch; theta by root finding), sag = 0.505 tan(theta) (the linear P L / (4 T_0) is 1.9 % off:
    the tension's rise).  What remains is the groove: the ball touches each half R sin(theta) from the kink
    (R = r + R_s), on a segment whose far node takes that share of the load, which lifts the kink by
    2 R sin(theta) / span of the sag on a string (a mesh much finer than R theta would wrap the ball):
    the error is below that and shrinks with R (measured 1.18e-3 and 1.8e-4 of the sag)."""
    L0, stretch, EA, r, M, g = 1.0, 1.01, 1000.0, 0.002, 0.4 / 9.81, 9.81
    P = M * g
    s = System(integrator="discrete-gradient")
    string = s.add("string", String(biot(EA=EA), 0.01), L0, 8,
                   initial={"r": lambda x: np.vstack([stretch * x[0] - 0.5 * stretch * L0, 0 * x[0], 0 * x[0]]),
                            "v": lambda x: np.zeros((3, x.shape[1]))},
                   supports=[Support("left", "pinned"), Support("right", "pinned")])
    z = r + R_s - 1e-5
    ball = s.add("ball", PointMass(M), initial=PointMass.initial((0.0, 0.0, z)),
                 loads=[Load("v", [0.0, 0.0, -P], "domain", "weight")])
    s.contact(RodContact(stiffness_for(P, 1e-4), r, radius_b=R_s), string, ball, name="rest")
    hold_sideways(s, ball, (0.0, 0.0, z))
    s.marker("ball", ball.point())
    solve(s, steps=4)
    obs = s.observe()
    assert -obs["rest.Fn_z"] / P == pytest.approx(1.0, abs=1e-10)
    half = 0.5 * stretch * L0
    theta = brentq(lambda t: 2 * EA * (half / np.cos(t) / (0.5 * L0) - 1) * np.sin(t) - P, 0.0, 0.5, xtol=1e-15)
    sag = (r + R_s - obs["rest.penetration"]) / np.cos(theta) - obs["ball_z"]
    exact = half * np.tan(theta)
    groove = 2 * (r + R_s) * np.sin(theta) / (stretch * L0)
    assert obs["rest.active"] == 2
    assert -groove <= sag / exact - 1 < 0


# -- a ball hitting a free rod (dynamics) ----------------------------------------------------------

def impact(mass_ratio, offset, E, n=6, V=0.1, dt=1e-3, t_end=0.05, rule="discrete-gradient", spin=None):
    """A ball (mass mass_ratio m, sphere radius 0.02; a PointMass, or with `spin` a RigidBody turning at the
    angular velocity `spin`) falls at V onto a free rod (L = 0.5, r = 0.01, rho = 1750, E; at rest along x),
    hitting it at `offset` from its centre.  The penalty stiffness: a rigid impact penetrates 1e-3.
    Returns (result, answer): the history (columns pz_rod, Ly_rod, pz_ball, the ball's spin about its centre
    sx, sy, sz) and the rigid-body impact law: frictionless and elastic, the impulse J = 2 m_eff V,
    1/m_eff = 1/M + 1/m + offset^2 / I (I = m L^2/12 + the sections' rotary inertia), after which
    pz_ball = -M V + J, pz_rod = -J, Ly_rod = offset J (about the origin: the rod's centre moves along z)."""
    L, r, rho, R_s, gap, pen = 0.5, 0.01, 1750.0, 0.02, 1e-3, 1e-3
    model = solid_rod(E, r, rho)
    m = rho * np.pi * r**2 * L
    inertia = m * L**2 / 12 + rho * np.pi * r**4 / 4 * L
    M = mass_ratio * m
    m_eff = 1.0 / (1.0 / M + 1.0 / m + offset**2 / inertia)
    J = 2 * m_eff * V
    s = System(integrator=rule, newton_options={"snes_atol": 1e-12, "snes_max_it": 40})
    rod = s.add("rod", model, L, n, initial=straight(L))
    centre, velocity = (offset, 0.0, r + R_s + gap), (0.0, 0.0, -V)
    if spin is None:
        ball = s.add("ball", PointMass(M), initial=PointMass.initial(centre, velocity))
    else:
        Jb = 0.4 * M * R_s**2
        ball = s.add("ball", RigidBody(M, (Jb, Jb, Jb)), initial=RigidBody.initial(centre, v=velocity, omega=spin))
    s.contact(RodContact(1.5 * m_eff * V**2 / pen**3, r, radius_b=R_s), rod, ball, name="hit")
    s.marker("ball", ball.point())
    compiled = {}

    def momenta(system):
        if not compiled:
            forms = {}
            for name in ("rod", "ball"):
                body = system.body(name)
                forms.update({f"{k}_{name}": f for k, f in body.momentum_forms(body.space.split(body.x1)).items()})
            compiled.update(compile_forms(forms))
        value = {k: system.assemble(f) for k, f in compiled.items()}
        out = {"pz_rod": value["p_z_rod"], "Ly_rod": value["L_y_rod"], "pz_ball": value["p_z_ball"]}
        out.update({f"L{c}_ball": value[f"L_{c}_ball"] for c in "xyz"})
        out.update({f"p{c}_ball": value[f"p_{c}_ball"] for c in "xyz"})
        return out
    s.record(momenta)
    result = run(s, dt, t_end)
    answer = {"pz_ball": -M * V + J, "pz_rod": -J, "Ly_rod": offset * J, "J": J, "scale": M * V * L}
    return result, answer


def spin_of(row):
    """The ball's angular momentum about its centre: L - x x p."""
    x = np.array([row[f"ball_{c}"] for c in "xyz"])
    p = np.array([row[f"p{c}_ball"] for c in "xyz"])
    return np.array([row[f"L{c}_ball"] for c in "xyz"]) - np.cross(x, p)


@pytest.mark.parametrize("mass_ratio", [1.0, 0.5], ids=["equal", "light-ball"])
def test_ball_hitting_a_stiff_rod_at_its_centre(mass_ratio):
    """Head-on at the rod's centre: the total momentum stays to round-off, H (with the contact energy) is
    constant to round-off, and the momenta after the impact follow the rigid-body law (equal masses: the
    velocities are exchanged; a ball of half the rod's mass: it bounces back at V/3, the rod leaves at 2V/3)
    within 1e-4 of J for a stiff rod (E = 1e10; measured 2.1e-5 and 1.4e-5: the rod's vibration)."""
    result, answer = impact(mass_ratio, 0.0, 1e10)
    last = result.rows[-1]
    assert result.column("hit.N").max() > 0 and last["hit.N"] == 0.0
    for k in ("p_x", "p_y", "p_z", "L_x", "L_y", "L_z"):
        assert np.abs(result.column(k) - result.rows[0][k]).max() <= 1e-14 * answer["scale"], k
    assert result.max_balance_error <= 1e-12 * result.column("H").max()
    error = max(abs(last[k] - answer[k]) / answer["J"] for k in ("pz_ball", "pz_rod"))
    assert error <= 1e-4


def test_ball_hitting_a_rod_off_centre_spins_it():
    """0.1 off the rod's centre, a spinning ball (a RigidBody, angular velocity (3, -2, 5) rad/s): the rod
    spins up; the total linear and angular momentum about the origin stay to round-off, the balance holds
    to round-off, the ball's own spin (L - x x p) is untouched (the sphere's force acts through its centre:
    no couple, to round-off), and the rod's p_z and L_y and the ball's p_z after the impact approach the
    rigid-body law as the rod stiffens: within 1e-2 of J at E = 1e9, within 3e-4 at E = 1e10 (measured
    3.0e-3 and 8.5e-5), the error at least 10 times smaller."""
    errors = []
    for E in (1e9, 1e10):
        result, answer = impact(0.7, 0.1, E, spin=(3.0, -2.0, 5.0))
        first, last = result.rows[0], result.rows[-1]
        assert result.column("hit.N").max() > 0 and last["hit.N"] == 0.0
        for k in ("p_x", "p_y", "p_z", "L_x", "L_y", "L_z"):
            assert np.abs(result.column(k) - first[k]).max() <= 1e-14 * answer["scale"], k
        assert result.max_balance_error <= 1e-12 * result.column("H").max()
        assert np.abs(spin_of(last) - spin_of(first)).max() <= 1e-14 * answer["scale"]
        assert abs(last["Ly_rod"]) > 0.05 * answer["J"]
        errors.append(max(abs(last[k] - answer[k]) / answer["J"] for k in ("pz_ball", "pz_rod", "Ly_rod")))
    assert errors[0] <= 1e-2 and errors[1] <= 3e-4 and errors[1] <= errors[0] / 10


def test_ball_hitting_a_free_string_keeps_momentum_and_energy():
    """A ball (M = 0.05, R_s = 0.02) hits a free string (no supports; EA = 50, rhoA = 0.3, r = 0.005, 10 P1
    elements) 0.13 off its centre and between two nodes, obliquely: they touch and part with the total linear
    and angular momentum constant to 1e-14 of M V L and H (with the contact energy) constant to 1e-12."""
    rhoA, V, r, R_s, M, L = 0.3, 0.5, 0.005, 0.02, 0.05, 0.5
    s = System(integrator="discrete-gradient", newton_options={"snes_atol": 1e-12, "snes_max_it": 40})
    string = s.add("string", String(biot(EA=50.0), rhoA), L, 10,
                   initial={"r": lambda x: np.vstack([x[0] - 0.5 * L, 0 * x[0], 0 * x[0]]),
                            "v": lambda x: np.zeros((3, x.shape[1]))})
    ball = s.add("ball", PointMass(M), initial=PointMass.initial((0.13, 0.004, r + R_s + 2e-3), (0.1, 0.05, -V)))
    m_eff = 1 / (1 / M + 1 / (rhoA * 0.05))
    s.contact(RodContact(1.5 * m_eff * V**2 / 1e-3**3, r, radius_b=R_s), ball, string, name="hit")
    result = run(s, 2e-4, 0.03)
    assert result.column("hit.N").max() > 0 and result.rows[-1]["hit.N"] == 0.0
    assert result.max_balance_error <= 1e-12 * result.column("H").max()
    for key in ("p_x", "p_y", "p_z", "L_x", "L_y", "L_z"):
        assert np.abs(result.column(key) - result.rows[0][key]).max() <= 1e-14 * M * V * L, key


def test_a_spinning_ball_rubbing_a_rod_keeps_p_and_the_balance_and_L_changes_by_the_ball_arm():
    """With friction (Coulomb(0.3)) a RigidBody ball (it has directors, but the sphere is a side without a
    section: the friction acts at its centre) hits a free rod while sliding along it: the linear momentum stays
    to round-off, the friction's work is never positive, the balance (with `dissipated`) is exact, the total
    angular momentum changes by exactly h rub.Mf per step (the ball's arm R_s d / R of the couple, not applied
    to its rotation)."""
    M, V, R_s, L, r = 0.02, 0.5, 0.02, 0.5, 0.01
    s = System(integrator="discrete-gradient", newton_options={"snes_atol": 1e-12, "snes_max_it": 40})
    rod = s.add("rod", solid_rod(1e7), L, 6, initial=straight(L))
    Jb = 0.4 * M * R_s**2
    ball = s.add("ball", RigidBody(M, (Jb, Jb, Jb)),
                 initial=RigidBody.initial((0.07, 0.0, r + R_s + 1e-3), v=(0.2, 0.0, -V), omega=(1.0, 2.0, 0.5)))
    m_eff = 1 / (1 / M + 1 / (1750 * np.pi * r**2 * L))
    s.contact(RodContact(1.5 * m_eff * V**2 / 1e-3**3, r, radius_b=R_s, friction=Coulomb(0.3)), rod, ball, name="rub")
    s.marker("ball", ball.point())
    h = 2e-4
    result = run(s, h, 0.01)
    assert result.column("rub.N").max() > 0
    scale = M * V
    for key in ("p_x", "p_y", "p_z"):
        assert np.abs(result.column(key) - result.rows[0][key]).max() <= 1e-14 * scale, key
    Mf = np.column_stack([result.column(f"rub.Mf_{c}") for c in "xyz"])
    Lt = np.column_stack([result.column(f"L_{c}") for c in "xyz"])
    assert np.abs(Mf).max() > 1e-3 * R_s * 0.3 * result.column("rub.N").max()
    assert np.abs(np.diff(Lt, axis=0) - h * Mf[1:]).max() <= 1e-13 * scale * L
    lost = np.diff(result.column("dissipated"))
    assert lost.min() >= 0 and lost.max() > 0
    assert result.max_balance_error <= 1e-12 * result.column("H").max()


# -- bad input -----------------------------------------------------------------------------------

def test_bad_input_is_refused_in_one_line():
    """A sphere's radius <= 0, a rigid body without a 3D position, two rigid bodies, a rigid body with itself,
    a planar rigid body: one line each (ConstraintError, exit code 2)."""
    s = System()
    rod = s.add("rod", solid_rod(1e6), 0.5, 2)
    ball = s.add("ball", PointMass(1.0, 3), initial=PointMass.initial((0, 0, 1.0), (0, 0, 0)))
    other = s.add("other", PointMass(1.0, 3), initial=PointMass.initial((0, 0, 2.0), (0, 0, 0)))
    flat = s.add("flat", PlanarRigidBody(1.0, 1.0), initial=PlanarRigidBody.initial((0.0, 0.0)))
    dot = s.add("dot", PointMass(1.0, 2), initial=PointMass.initial((0.0, 0.0)))
    with pytest.raises(ConstraintError, match="radius_b, the radius of rigid body ball's sphere, must be > 0"):
        s.contact(RodContact(1.0, 0.01, radius_b=0.0), rod, ball)     # (< 0: refused by RodContact)
    with pytest.raises(ConstraintError, match="radius, the radius of rigid body ball's sphere, must be > 0"):
        s.contact(RodContact(1.0, 0.0, radius_b=0.01), ball, rod)
    for body in (flat, dot):
        with pytest.raises(ConstraintError, match="needs a position field of 3 coordinates"):
            s.contact(RodContact(1.0, 0.01, radius_b=0.1), rod, body)

    class Anonymous(PointMass):   # a rigid model without a position field
        position = None
    ghost = s.add("ghost", Anonymous(1.0, 3), initial=PointMass.initial((0, 0, 3.0)))
    with pytest.raises(ConstraintError, match="rigid body ghost: its model needs a position field"):
        s.contact(RodContact(1.0, 0.01, radius_b=0.1), rod, ghost)
    with pytest.raises(ConstraintError, match="one rigid body per contact"):
        s.contact(RodContact(1.0, 0.1), ball, other)
    with pytest.raises(ConstraintError, match="one rigid body per contact, no self-contact"):
        s.contact(RodContact(1.0, 0.1), ball)
    assert not s.contacts


# -- serial = mpirun -n 2 ------------------------------------------------------------------------

SCRIPT = """
import json
import sys
import numpy as np
from mpi4py import MPI
sys.path[:0] = [{here!r}, {tests!r}]
from test_rigid_rod_contact import impact
result, answer = impact(0.7, 0.1, 1e8, n=6, t_end=0.03)
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(result.rows[-1]))
"""


@pytest.mark.mpi
def test_ball_on_rod_in_parallel_equals_serial():
    """The off-centre impact (6 elements over 2 ranks, the ball's cell on one of them: its position gathered
    on rank 0 with the rod's nodes) under mpirun -n 2 writes the serial history; the contact is on at the
    end."""
    here = os.path.dirname(os.path.abspath(__file__))
    serial, parallel = script_on_ranks(SCRIPT.format(here=here, tests=os.path.dirname(here)), timeout=600)
    assert serial["hit.N"] > 0
    assert serial.keys() == parallel.keys()
    for key, value in serial.items():
        if key != "wall_time":
            assert parallel[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key


# -- the scene -------------------------------------------------------------------------------------

def test_ball_dropped_on_a_string_keeps_the_balance():
    """The ball-on-string scene (8 elements, to t = 0.12: the ball lands and is caught): the balance
    H_{n+1} - H_n = supplied (gravity's work) to round-off through the landing, the contact force on the
    string only along -z at the symmetric landing, and the ball held above the string's centre line by less
    than the rest state's sag plus its landing overshoot (not through the string)."""
    from mpi4py import MPI

    from rodfem.app.scene import load, scenes
    from rodfem.demos.ball_on_string import rest
    assert "ball-on-string" in scenes()
    scene = load("ball-on-string")
    with pytest.raises(ParameterError, match="stretch"):
        scene.values({"stretch": 0.99})
    p = scene.values({"t_end": 0.12, "n_elements": 8})
    result = run(scene.build(p, MPI.COMM_WORLD), p["dt"], p["t_end"])
    N = result.column("hit.N")
    assert N.max() > p["M"] * p["g"]
    assert result.max_balance_error <= 1e-12 * np.abs(result.column("H")).max()
    assert np.abs(result.column("hit.Fn_x")).max() <= 1e-12 * N.max()
    theta, sag, z_rest = rest(p)
    assert result.rows[-1]["z_rest"] == z_rest and 0 < z_rest < p["R_s"] + p["r"]
    assert result.column("ball_z").min() > -3 * sag
