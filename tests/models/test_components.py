"""Springs and dampers (forms/components.py) against independent answers: the linear oscillator's
exact discrete solution (the midpoint map is a Cayley transform), a 3D torsional pendulum's
elliptic-integral period, a hanging spring's static stretch mg/k; and the structure: the
discrete-gradient balance to round-off for non-quadratic energies, h d_n >= 0 per step, the
midpoint rule's nonzero balance error, conserved momenta of a free spinning pair."""
import math

import numpy as np
import pytest
from mpi4py import MPI
from scipy.special import ellipk

from rodfem import Load, System, run
from rodfem.analysis import statics
from rodfem.app.scene import load
from rodfem.core.joints import ground
from rodfem.errors import ConstraintError
from rodfem.forms import joints
from rodfem.forms.components import (
    damper,
    dashpot,
    hookean,
    quartic,
    rotational_damper,
    rotational_spring,
    spring,
    tension_only,
    torsional_spring,
)
from rodfem.forms.rigid_body import PlanarRigidBody, PointMass, RigidBody

RULES = ("midpoint", "discrete-gradient")
TIGHT = {"snes_atol": 1e-12, "snes_rtol": 1e-14}   # Newton to round-off (the default atol is 1e-10)


def state(system, name, field, which="x0"):
    body = system.body(name)
    return body.space.nodal(getattr(body, which), field)[1].reshape(-1)


def column(result, name):
    return np.array([row[name] for row in result.rows])


def cayley(m, c, k, h, x0, v0, n):
    """The midpoint rule for m x'' + c x' + k x = 0: [x, v]_{j+1} = (I - h/2 A)^-1 (I + h/2 A) [x, v]_j,
    and its dissipated work sum_j h c v_{j+1/2}^2 (an independent small implementation)."""
    A = np.array([[0.0, 1.0], [-k / m, -c / m]])
    step = np.linalg.solve(np.eye(2) - 0.5 * h * A, np.eye(2) + 0.5 * h * A)
    z, out, lost = np.array([x0, v0]), [np.array([x0, v0])], 0.0
    for _ in range(n):
        z1 = step @ z
        lost += h * c * (0.5 * (z[1] + z1[1])) ** 2
        z = z1
        out.append(z)
    return np.array(out), lost


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("eta, kind", [(0.0, None), (0.8, damper), (0.8, dashpot)],
                         ids=["undamped", "damper", "dashpot"])
def test_mass_on_a_spring_follows_the_midpoint_recurrence(rule, eta, kind):
    """A mass m on a Hookean spring (rest length l0, psi = k/2 (sqrt(c) - l0)^2 of the squared
    length c) to the ground, with a damper, moving along the spring's axis: m x'' + eta x' + k (x - l0)
    = 0.  Along a line the discrete gradient in c is the difference quotient of V(x) = k/2 (x - l0)^2,
    i.e. the midpoint gradient: both rules reproduce the Cayley recurrence to round-off, and the
    dissipated work is its sum h eta v_{n+1/2}^2 (a damper on the relative velocity or a dashpot
    along the line: the same force along the axis)."""
    m, k, l0, h, n = 2.0, 50.0, 1.0, 0.05, 60
    s = System(integrator=rule, newton_options=TIGHT)
    body = s.add("mass", PointMass(m, dim=3), initial=PointMass.initial((1.3, 0.0, 0.0), (0.4, 0.0, 0.0)))
    s.connect(spring(hookean(k, l0)), ground((0.0, 0.0, 0.0)), body.point())
    if eta:    # along the axis the dashpot's force c (e . v) e is the damper's c v
        s.connect(kind(eta), ground((0.0, 0.0, 0.0)), body.point())
    result = run(s, h, n * h)
    exact, lost = cayley(m, eta, k, h, 0.3, 0.4, n)
    assert state(s, "mass", "x")[0] - l0 == pytest.approx(exact[-1, 0], abs=1e-12)
    assert state(s, "mass", "v")[0] == pytest.approx(exact[-1, 1], abs=1e-12)
    assert np.max(np.abs(state(s, "mass", "x")[1:])) <= 1e-14          # stays on the axis
    if eta:
        assert column(result, "dissipated")[-1] == pytest.approx(lost, rel=1e-11)
    else:
        assert "dissipated" not in result.rows[0]
    assert np.max(np.abs(column(result, "balance_error"))) <= 1e-12


@pytest.mark.parametrize("rule", RULES)
def test_planar_rotational_spring_and_damper_follow_the_recurrence(rule):
    """A planar body pinned at its centre, with a rotational damper and a rotational spring preloaded
    to the rest angle 0 from the initial angle 0.2, psi = k/2 (theta + 0.2)^2 of the relative angle
    theta = phi - 0.2: J phi'' + c phi' + k phi = 0, the Cayley recurrence to round-off."""
    J, c, k, h, n = 0.5, 0.3, 8.0, 0.02, 100
    s = System(integrator=rule, newton_options=TIGHT)
    body = s.add("wheel", PlanarRigidBody(1.0, J), initial=PlanarRigidBody.initial((0.0, 0.0), phi=0.2, omega=-1.0))
    s.join(joints.pin, ground((0.0, 0.0)), body.point())
    s.connect(rotational_spring(lambda theta: 0.5 * k * (theta + 0.2) ** 2), ground((0.0, 0.0)), body.point())
    s.connect(rotational_damper(c), ground((0.0, 0.0)), body.point())
    result = run(s, h, n * h)
    exact, lost = cayley(J, c, k, h, 0.2, -1.0, n)
    assert state(s, "wheel", "phi")[0] == pytest.approx(exact[-1, 0], abs=1e-12)
    assert state(s, "wheel", "omega")[0] == pytest.approx(exact[-1, 1], abs=1e-12)
    assert column(result, "dissipated")[-1] == pytest.approx(lost, rel=1e-11)


@pytest.mark.parametrize("amplitude", [0.5, 2.0], ids=["small", "large"])
def test_torsional_spring_swings_with_the_pendulum_period(amplitude):
    """A 3D body held at its centre (spherical joint), at rest against a torsional spring
    V = k (1 - cos theta) and spun about its axis d3 with omega0: J3 theta'' = -k sin theta, a pendulum
    of amplitude theta_max (k (1 - cos theta_max) = J3 omega0^2 / 2) and period
    4 K(sin(theta_max / 2)) / sqrt(k / J3).  Measured from the zero crossings of theta (midpoint rule,
    200 steps a small-angle period: O(h^2) ~ 1e-4); the largest angle is theta_max."""
    Jc, k = (0.3, 0.4, 0.5), 2.0
    omega = np.sqrt(k / Jc[2])
    omega0 = np.sqrt(2 * k * (1 - np.cos(amplitude)) / Jc[2])
    T = 4 * ellipk(np.sin(amplitude / 2) ** 2) / omega
    s = System()
    body = s.add("rotor", RigidBody(1.0, Jc), initial=RigidBody.initial((0.0, 0.0, 0.0), omega=(0.0, 0.0, omega0)))
    s.join(joints.spherical, ground((0.0, 0.0, 0.0)), body.point())
    s.connect(torsional_spring(k), ground((0.0, 0.0, 0.0)), body.point())
    h = 2 * np.pi / omega / 200
    crossings, previous, largest = [], 0.0, 0.0
    for j in range(1, int(2.2 * T / h)):
        run(s, h, j * h)
        d1 = state(s, "rotor", "d1")
        theta = np.arctan2(d1[1], d1[0])
        largest = max(largest, abs(theta))
        if previous * theta < 0:
            crossings.append((j - 1) * h + h * previous / (previous - theta))
        previous = theta
    periods = 2 * np.diff(crossings)
    assert len(periods) >= 2
    assert np.max(np.abs(periods / T - 1)) <= 3e-4, (periods, T)
    assert largest == pytest.approx(amplitude, abs=2e-3)


def spinning_pair(rule, energy):
    """Two free masses on a spring and a dashpot, spinning and stretching: no external force or moment."""
    s = System(integrator=rule, momentum=True, newton_options=TIGHT)
    a = s.add("a", PointMass(1.0, dim=3), initial=PointMass.initial((0.0, 0.0, 0.0), (0.0, -1.0, 0.3)))
    b = s.add("b", PointMass(2.0, dim=3), initial=PointMass.initial((1.2, 0.0, 0.0), (0.5, 0.5, 0.0)))
    s.connect(spring(energy), a.point(), b.point())
    s.connect(dashpot(0.8), a.point(), b.point())
    return s


@pytest.mark.parametrize("energy", [quartic(40.0, 1.0), hookean(60.0, 1.0), tension_only(60.0, 1.0)],
                         ids=["quartic", "hookean", "tension-only"])
def test_discrete_gradient_balance_to_round_off_and_momenta_conserved(energy):
    """Non-quadratic spring energies: under the discrete gradient H_{n+1} - H_n + h d_n = 0 to round-off
    at a large step (h = 0.1, a tenth of the period), h d_n >= 0 every step, and p and L (the spring's
    force is along the line between the masses) conserved; the midpoint rule breaks the balance."""
    result = run(spinning_pair("discrete-gradient", energy), 0.1, 5.0)
    H = column(result, "H")
    assert np.max(np.abs(column(result, "balance_error"))) <= 1e-13 * H[0]
    lost = np.diff(column(result, "dissipated"))
    assert np.all(lost >= 0) and lost.sum() > 0.05 * H[0]
    for c in ("p_x", "p_y", "p_z", "L_x", "L_y", "L_z"):
        values = column(result, c)
        assert np.max(np.abs(values - values[0])) <= 1e-12 * max(1.0, abs(values[0])), c
    midpoint = run(spinning_pair("midpoint", energy), 0.1, 5.0)
    assert np.max(np.abs(column(midpoint, "balance_error"))) >= 1e-4 * H[0]


def test_four_particle_decays_monotonically_under_the_discrete_gradient():
    """Kinon, Morandin & Schulze's four-particle DAE at h = 0.25: the discrete gradient decays
    monotonically with the balance at Newton's tolerance; the midpoint rule gains energy in some
    steps (the damper only dissipates); without the damper the DG run keeps H."""
    scene = load("four-particle")
    runs = {}
    for rule, eta0 in (("discrete-gradient", 1.0), ("midpoint", 1.0), ("discrete-gradient", 0.0)):
        p = scene.values({"dt": 0.25, "t_end": 10.0, "integrator": rule, "eta0": eta0})
        runs[rule, eta0] = run(scene.build(p, MPI.COMM_WORLD), 0.25, 10.0)
    dg, mp, cons = runs["discrete-gradient", 1.0], runs["midpoint", 1.0], runs["discrete-gradient", 0.0]
    H = column(dg, "H")
    assert np.all(np.diff(H) < 0) and np.max(np.abs(column(dg, "balance_error"))) <= 1e-11
    assert np.max(np.diff(column(mp, "H"))) > 0.1 and np.max(np.abs(column(mp, "balance_error"))) > 0.1
    assert np.max(np.abs(column(cons, "H") - H[0])) <= 1e-11
    assert np.max(np.abs(column(dg, "constraint_residual"))) <= 1e-12


@pytest.mark.parametrize("energy, stretch", [(hookean(40.0, 0.5), lambda mg: mg / 40.0),
                                             (quartic(40.0, 0.5), None)], ids=["hookean", "quartic"])
def test_static_hanging_spring_stretches_by_its_law(energy, stretch):
    """A mass m hanging on a spring from the ground under gravity: statics gives |x| = l with
    psi'(l^2) 2 l = m g (Hookean: l = l0 + m g / k; quartic: 2 k (l^2 - l0^2) l = m g)."""
    m, g = 1.5, 9.81
    s = System()
    body = s.add("mass", PointMass(m, dim=2), initial=PointMass.initial((0.0, -0.5)),
                 loads=[Load("v", [0.0, -m * g], "domain", "gravity")])
    s.connect(spring(energy), ground((0.0, 0.0)), body.point())
    s.join(joints.slider((0.0, 1.0)), ground((0.0, 0.0)), body.point())   # no lateral stiffness at rest
    statics.solve(s, 0.0)
    y = state(s, "mass", "x")[1]
    if stretch is not None:
        assert -y == pytest.approx(0.5 + stretch(m * g), rel=1e-12)
    else:
        assert 2 * 40.0 * (y**2 - 0.25) * (-y) == pytest.approx(m * g, rel=1e-12)


def test_bad_components_are_one_line_errors():
    s = System()
    body = s.add("mass", PointMass(1.0, dim=3), initial=PointMass.initial((1.0, 0.0, 0.0)))
    with pytest.raises(ConstraintError, match="a function is not a spring, damper or control law"):
        s.connect(lambda a, b: 0.0, ground(), body.point())
    s.connect(damper(-1.0), ground((0.0, 0.0, 0.0)), body.point(), name="bad_damper")
    with pytest.raises(ConstraintError, match=r"bad_damper .*coefficient must be one number >= 0"):
        s.build()
    s = System()
    body = s.add("mass", PointMass(1.0, dim=3), initial=PointMass.initial((1.0, 0.0, 0.0)))
    s.connect(spring(lambda c: 0.5 * math.sqrt(c)), ground((0.0, 0.0, 0.0)), body.point(), name="mathy")
    with pytest.raises(ConstraintError, match="mathy .*accept complex numbers"):
        run(s, 0.1, 0.1)


def test_four_particle_converges_with_the_authors_orders():
    """Kinon, Morandin & Schulze's convergence study, shortened: against a discrete-gradient run with
    h = 2e-4, particle 4's position and velocity at t = 0.1 converge with order 2, the link's
    multiplier (lambda at t_{n+1}) with order 1 (measured 1.95, 2.05, 1.05 between h = 0.01 and 0.005;
    benchmarks/bench_four_particle.py has the whole table)."""
    scene = load("four-particle")

    def at_01(h):
        p = scene.values({"dt": h, "t_end": 0.1})
        system = scene.build(p, MPI.COMM_WORLD)
        result = run(system, h, 0.1)
        body = system.body("p4")
        return (body.space.nodal(body.x0, "x")[1].reshape(-1), body.space.nodal(body.x0, "v")[1].reshape(-1),
                result.rows[-1]["link_12.lambda1"])
    ref = at_01(2e-4)
    errors = [[np.linalg.norm(np.atleast_1d(a - b)) / np.linalg.norm(np.atleast_1d(b)) for a, b in zip(at_01(h), ref)]
              for h in (0.01, 0.005)]
    orders = np.log2(np.array(errors[0]) / np.array(errors[1]))
    assert 1.8 <= orders[0] <= 2.2 and 1.8 <= orders[1] <= 2.3 and 0.9 <= orders[2] <= 1.2, orders


@pytest.mark.parametrize("law", ["hookean", "quartic"])
def test_spring_damper_chain_statics_against_the_column_equations(law):
    """spring-damper-chain at rest: the boxes only move down, and each gap's four springs carry the
    weight below them less the floor's pull: T_i - T_{i+1} = m g with the springs' tension
    T(l) = 4 psi'(l^2) 2 l (hookean 4 k (l - l0), quartic 8 k l (l^2 - l0^2)) of the gap lengths
    l_i, whose sum is fixed by ceiling and floor; solved here as a small nonlinear system."""
    from scipy.optimize import fsolve

    from rodfem.demos.spring_damper_chain import layout
    scene = load("spring-damper-chain")
    p = scene.values({"n_bodies": 3, "law": law, "push": 0.0, "spin": 0.0})
    system = scene.build(p, MPI.COMM_WORLD)
    statics.solve(system, 0.0, steps=2)
    m, g, k, l0, b, n = p["mass"], p["g"], p["k"], p["rest_length"], p["b"], p["n_bodies"]
    centres, floor = layout(p)

    def tension(length):
        return 4 * k * (length - l0) if law == "hookean" else 8 * k * length * (length**2 - l0**2)

    def equations(z):      # z: the centres
        tops = np.concatenate([[0.0], z - b / 2])            # ceiling, then the boxes' bottoms
        bottoms = np.concatenate([z + b / 2, [floor]])       # the boxes' tops, then the floor
        T = tension(tops - bottoms)
        return T[:-1] - T[1:] - m * g
    z = fsolve(equations, np.array(centres), xtol=1e-12)
    assert np.max(np.abs(equations(z))) <= 1e-9
    for i in range(n):
        x = state(system, f"box{i + 1}", "x")
        assert x[2] == pytest.approx(z[i], abs=1e-10)
        assert np.max(np.abs(x[:2])) <= 1e-12
    assert abs(z[0] - centres[0]) > 0.01          # gravity moved them
