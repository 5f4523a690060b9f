"""Contact between a rigid body's sphere and a rod or string (forms/rod_contact.py with a segment of zero
length, rodfem/core/bodycontact.py) against independent answers: the point-to-segment distance against a
brute-force search; the step's force against its definition (work = the energy's change, no net force or
moment) with the sphere's centre as a doubled node; a heavy ball resting on a clamped-clamped beam and on a
taut string (statics: the contact force equals the weight, the deflection the analytic beam's and string's
under a point load); a ball hitting a free stiff rod at its centre and off it (momentum and the energy
balance to round-off, the rod's and the ball's momenta after the impact against the rigid-body impact law,
for equal and unequal masses; off-centre the rod spins and the total angular momentum stays); bad input;
mpirun -n 2 = serial."""

import numpy as np
import pytest
from mpi4py import MPI
from processes import script_on_ranks

from rodfem import Load, Support, System, ground, run
from rodfem.analysis.statics import solve
from rodfem.core.bodycontact import Pairing
from rodfem.core.components import potential
from rodfem.errors import ConstraintError
from rodfem.fem.jit import compile_forms
from rodfem.forms import cosserat_rod
from rodfem.forms.contact import stiffness_for
from rodfem.forms.rigid_body import PlanarRigidBody, PointMass, RigidBody
from rodfem.forms.rod_contact import RodContact, closest_points
from rodfem.forms.string import String
from rodfem.forms.string_materials import logarithmic


def column(result, name):
    return np.array([row[name] for row in result.rows])


def rod_model(E, r=0.01, rho=1750.0):
    A, Isec = np.pi * r**2, np.pi * r**4 / 4
    G = E / 3
    return cosserat_rod.CosseratRod(rho * A, (rho * 2 * Isec, rho * Isec, rho * Isec),
                                    [1 / (E * A), 1 / (G * A), 1 / (G * A)], [1 / (G * 2 * Isec), 1 / (E * Isec), 1 / (E * Isec)])


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
    beam = s.add("beam", rod_model(E, r), L, n, initial=straight(L), supports=[Support("left"), Support("right")])
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
