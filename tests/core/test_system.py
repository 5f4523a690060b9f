"""Multibody systems: bodies joined by joints (rodfem/core/system.py, forms/joints.py, forms/rigid_body.py).

What can fail here: the four-bar against the authors' own reference value, the
exact energy balance of the whole system, position constraints at round-off
(index 2 with quadratic constraints), conservation of momentum maps of a free
system, observed orders, serial = 2 ranks, and the one-line errors for bad
mechanisms.
"""
import numpy as np
import pytest
from mpi4py import MPI
from processes import assert_same_history, rodfem_lines, serial_and_parallel

from rodfem import Load, Support, run
from rodfem.app.scene import load
from rodfem.core.joints import ground
from rodfem.core.system import System
from rodfem.errors import ConstraintError
from rodfem.forms import joints
from rodfem.forms.cosserat_rod import CosseratRod
from rodfem.forms.planar_beam import PlanarBeam, quadratic, straight
from rodfem.forms.rigid_body import PlanarRigidBody, PointMass, RigidBody


def four_bar(**overrides):
    scene = load("four-bar-2d")
    p = scene.values(overrides)
    return scene.build(p, MPI.COMM_WORLD), p


def marker_at_end(**overrides):
    system, p = four_bar(**overrides)
    res = run(system, p["dt"], p["t_end"])
    return np.array([res.rows[-1]["marker_x"], res.rows[-1]["marker_y"]]), res


def test_four_bar_reproduces_the_authors_reference_point():
    """The coupler's mid-node at t = 1 with h = 0.005 and 10/6/6 elements, 2 Gauss points: the
    authors' code (fourbar_convergence.m, moofeKIT) gives (1.396144818042612, -0.763824524916379)
    with a Newton tolerance of 1e-5.  We measured a difference of 3e-12: the same discrete model."""
    x, res = marker_at_end(t_end=1.0, dt=0.005)
    assert np.max(np.abs(x - [1.396144818042612, -0.763824524916379])) < 1e-10
    # 3 Gauss points give another (equally valid) discretisation: it must differ, or the
    # quadrature parameter did nothing
    x3, _ = marker_at_end(t_end=1.0, dt=0.005, gauss_points=3)
    assert 0 < np.max(np.abs(x3 - x))


def test_four_bar_balance_and_pins_at_round_off():
    """H_{n+1} - H_n = h y.u (gravity is the input) to 1.5e-14 max|H| measured (bound 1e-12), and the
    pins' gap |x_a - x_b| <= 3e-15 measured (bound 1e-13 m on bars of 1.5-2.2 m)."""
    _, res = marker_at_end(t_end=1.0)
    H = res.column("H")
    assert res.max_balance_error <= 1e-12 * np.max(np.abs(H))
    assert np.max(res.column("constraint_residual")) <= 1e-13
    assert np.all(res.column("newton_its")[1:] <= 4)


def test_four_bar_time_order_two():
    """Self-convergence of the mid-node at t = 0.4: errors against h/8 fall with order 2."""
    xs = {h: marker_at_end(t_end=0.4, dt=h)[0] for h in (0.04, 0.02, 0.01, 0.0025)}
    e = [np.linalg.norm(xs[h] - xs[0.0025]) for h in (0.04, 0.02, 0.01)]
    orders = np.log2(np.array(e[:-1]) / np.array(e[1:]))
    assert np.all(orders > 1.8), orders


def test_four_bar_space_convergence():
    """Mid-node at t = 0.2, h = 0.02, coupler/rocker elements n = 4, 8, 16 against n = 32: the error falls
    at least with order 1.8 (P1/DG0; measured: see the assertion message)."""
    xs = {n: marker_at_end(t_end=0.2, n_elements=n)[0] for n in (4, 8, 16, 32)}
    e = [np.linalg.norm(xs[n] - xs[32]) for n in (4, 8, 16)]
    orders = np.log2(np.array(e[:-1]) / np.array(e[1:]))
    assert np.all(orders > 1.8), (e, orders)


def pendulum(mass_a=1.0, mass_b=2.0, g=9.81):
    """A double pendulum of two point masses on massless links (the `distance` joint) hung at the origin."""
    s = System()
    a = s.add("a", PointMass(mass_a, dim=2), initial=PointMass.initial([1.0, 0.0]))
    b = s.add("b", PointMass(mass_b, dim=2), initial=PointMass.initial([1.0, -1.0], [0.5, 0.0]),
              loads=[Load("v", [0.0, -mass_b * g], "domain", "gravity b")])
    s.join(joints.distance, ground((0.0, 0.0)), a.point(), name="link_a")
    s.join(joints.distance, a.point(), b.point(), name="link_b")
    s.marker("b", b.point())
    return s


def test_double_pendulum_keeps_link_lengths_to_round_off():
    """|x_b - x_a|^2 = 1 is quadratic: the midpoint index-2 scheme keeps it to 1.5e-13 over 200 steps
    (bound 1e-12); H - supplied (the total energy with gravity) is constant to the balance error."""
    res = run(pendulum(), 0.01, 2.0)
    assert np.max(res.column("constraint_residual")) <= 1e-12
    total = res.column("H") - res.column("supplied")
    assert np.max(np.abs(total - total[0])) <= 1e-11 * np.max(res.column("H"))
    assert np.ptp(res.column("b_x")) > 0.5      # it really swings


def test_free_pinned_beams_conserve_momentum():
    """Two flexible beams pinned together, thrown spinning with no load: p_x, p_y and L_z of the
    whole system are conserved (the joint's reactions cancel pairwise) to 1e-12 relative."""
    s = System()
    beam = PlanarBeam(1.0, 0.1, quadratic(EA=1e3, GA=1e3, EI=10.0))
    La, ia = straight((0.0, 0.0), (1.0, 0.0))
    Lb, ib = straight((1.0, 0.0), (1.0, 1.0))
    ia["v"] = lambda x: np.vstack([0 * x[0], 0.5 * x[0] + 0.3])        # a shear-spin velocity field
    a = s.add("a", beam, La, 4, initial=ia)
    b = s.add("b", beam, Lb, 4, initial={**ib, "omega": lambda x: np.full(x.shape[1], 1.0)})
    s.join(joints.pin, a.end, b.start)
    res = run(s, 0.01, 1.0)
    for col in ("p_x", "p_y", "L_z"):
        c = res.column(col)
        assert np.ptp(c) <= 1e-12 * max(np.max(np.abs(c)), 1.0), col
    assert abs(res.column("L_z")[0]) > 0.1
    assert res.max_balance_error <= 1e-12 * np.max(res.column("H"))


def test_rigid_body_spins_with_orthonormal_directors():
    """A free director rigid body (J = 1, 2, 3) spun about an axis near the middle one (unstable):
    H, p and all of L conserved; d_i.d_j = delta_ij to round-off."""
    s = System()
    R = np.eye(3)
    body = s.add("body", RigidBody(2.0, (1.0, 2.0, 3.0)), initial=RigidBody.initial([0, 0, 0], R, omega=[0.01, 3.0, 0.02]))
    res = run(s, 0.01, 3.0)
    for col in ("H", "L_x", "L_y", "L_z", "p_x"):
        c = res.column(col)
        assert np.ptp(c) <= 1e-12 * max(np.max(np.abs(c)), 1.0), col
    b = body.body
    D = np.stack([b.x0.x.array[b.space.collapse(n)[1]] for n in ("d1", "d2", "d3")], axis=1) if b.x0.x.array.size else np.eye(3)
    assert np.max(np.abs(D.T @ D - np.eye(3))) <= 1e-13


def test_field_values_are_every_bodys_nodal_values():
    """System.field_values reads a field of all of the rank's bodies in one indexing: the same rows as
    each body's own nodal values (a rigid body: one row; a 3D rod: its nodes), x_n and x_{n+1} apart
    after a step; a body without the field (a point mass has no directors) adds no row."""
    s = System()
    a = s.add("a", RigidBody(2.0, (1.0, 2.0, 3.0)), initial=RigidBody.initial([0, 0, 0], np.eye(3), omega=[0.1, 3.0, 0.2]))
    rod = s.add("rod", CosseratRod(1.0, (1.0, 0.5, 0.5), (0.1, 0.1, 0.1), (0.1, 0.1, 0.1)), length=1.0, n_elements=3,
                loads=[Load("v", [0.0, 0.0, -1.0], "domain", "weight")])
    m = s.add("m", PointMass(1.0, 3), initial=PointMass.initial([2.0, 0.0, 0.0], [0.0, 1.0, 0.0]))
    run(s, 0.01, 0.01)
    rod.body.x1.x.array[:] += np.linspace(0.1, 0.2, rod.body.x1.x.array.size)   # x_{n+1} apart from x_n
    for state in ("x0", "x1"):
        for name, bodies in (("d2", (a, rod)), ("x", (a, m)), ("r", (rod,))):
            expected = np.concatenate([b.body.space.nodal(getattr(b.body, state), name)[1] for b in bodies])
            got = s.field_values(name, state)
            assert got.shape == expected.shape
            assert np.array_equal(np.sort(got, axis=0), np.sort(expected, axis=0)), (state, name)
    assert not np.array_equal(s.field_values("d2", "x0"), s.field_values("d2", "x1"))
    assert s.field_values("d2").shape == (1 + 7, 3)   # the rigid body's row, the rod's P2 nodes


@pytest.mark.parametrize("kind", ["beam", "rod", "string", "rigid"])
def test_a_body_placed_without_initial_values_is_straight_at_rest(kind):
    """No `initial`: the model's default, straight along x from the origin at rest (it was the zero state:
    a rod of zero length, whose Jacobian is singular).  The body starts at r(s) = s e1 with H = 0 and
    falls under its weight f per length: p(t) = f L t exactly (the midpoint rule integrates a constant
    force exactly), unstretched (rigid translation: H = |p|^2 / 2m)."""
    from rodfem.forms import string_materials
    from rodfem.forms.string import String
    dim = 2 if kind == "beam" else 3
    g = [0.0, -1.0] if dim == 2 else [0.0, 0.0, -1.0]
    model = {"beam": lambda: PlanarBeam(1.0, 0.1, quadratic(10.0, 10.0, 1.0)),
             "rod": lambda: CosseratRod(1.0, (0.2, 0.1, 0.1), (0.1, 0.1, 0.1), (0.1, 0.1, 0.1)),
             "string": lambda: String(string_materials.kirchhoff(EA=10.0), 1.0),
             "rigid": lambda: RigidBody(1.0, (0.2, 0.1, 0.15))}[kind]()
    s = System()
    body = s.add("b", model, length=1.0, n_elements=4, loads=[Load("v", g, "domain", "weight")]).body
    position = "x" if kind == "rigid" else "r"
    if kind != "rigid":
        sn, r = body.space.nodal(body.x0, position)
        assert np.allclose(r[:, 0], sn) and np.allclose(r[:, 1:], 0.0)
    res = run(s, 0.01, 0.1)
    assert res.column("H")[0] == 0.0
    p = res.column("p_y" if dim == 2 else "p_z")
    assert np.max(np.abs(p - (-res.column("t")))) <= 1e-10
    assert np.max(np.abs(res.column("H") - 0.5 * res.column("t") ** 2)) <= 1e-9


def test_nothing_unused_is_assembled():
    """Each joint adds exactly its conditions to the unknowns; without joints there is no multiplier block."""
    full, _ = four_bar(t_end=0.02)
    full.build()
    bodies = sum(r.body.dofs for r in full.bodies.values())
    assert full.dofs == bodies + 4                      # two pins, 2 conditions each
    s = System()
    L, init = straight((0, 0), (1, 0))
    s.add("a", PlanarBeam(1.0, 1.0, quadratic(EA=10, GA=10, EI=1)), L, 4, initial=init)
    s.build()
    assert s.layout.n_multipliers == 0 and s.dofs == s.bodies["a"].body.dofs


def test_bad_mechanisms_give_one_line_errors():
    beam = PlanarBeam(1.0, 1.0, quadratic(EA=10, GA=10, EI=1))
    rod = CosseratRod(1.0, (1.0, 0.5, 0.5), (0.1, 0.1, 0.1), (0.1, 0.1, 0.1))
    L, init = straight((0, 0), (1, 0))

    def system():
        s = System()
        return s, s.add("beam", beam, L, 2, initial=init, supports=[Support("left", "pinned")])
    # a point of a body that is not in the system
    s, a = system()
    other, b = system()
    with pytest.raises(ConstraintError, match="not in this system"):
        s.join(joints.pin, a.end, b.start)
    # a planar joint on a 3D rod end (no angle), and a 2D point joined to a 3D one
    s, a = system()
    r = s.add("rod", rod, 1.0, 2, initial={"r": lambda x: np.vstack([1 + x[0], 0 * x[0], 0 * x[0]]),
                                            "d1": _const([1, 0, 0]), "d2": _const([0, 1, 0]), "d3": _const([0, 0, 1])})
    s.join(joints.pin, a.end, r.start)
    with pytest.raises(ConstraintError, match="2D point to a 3D point"):
        s.build()
    # a joint that does not hold at t = 0
    s, a = system()
    s.join(joints.pin, ground((0.5, 0.0)), a.end)
    with pytest.raises(ConstraintError, match="does not hold in the initial configuration"):
        s.build()
    # redundant: a pin to the ground at an end that is already pinned
    s, a = system()
    s.join(joints.pin, ground((0.0, 0.0)), a.start)
    with pytest.raises(ConstraintError, match="independent"):
        s.build()
    # not quadratic: a planar rigid body joined at an offset (x + A(phi) X is trigonometric)
    s, a = system()
    body = s.add("body", PlanarRigidBody(1.0, 1.0), initial=PlanarRigidBody.initial([1.5, 0.0]))
    s.join(joints.pin, a.end, body.point((-0.5, 0.0)))
    with pytest.raises(ConstraintError, match="not quadratic"):
        s.build()


def test_bad_mechanism_from_the_cli_is_one_line(rodfem, tmp_path):
    p = rodfem("run", "four-bar-2d", "--set", "n_elements=5", "--out", str(tmp_path / "o"), "--quiet")
    assert p.returncode == 2 and len(rodfem_lines(p.stderr)) == 1 and "n_elements" in p.stderr


@pytest.mark.mpi
def test_four_bar_two_ranks_equal_serial(tmp_path):
    """`mpirun -n 2` gives the serial history (measured: 1e-14 relative), every column."""
    a, b, _ = serial_and_parallel(tmp_path, ["run", "four-bar-2d", "--set", "t_end=0.5", "--quiet"])
    assert_same_history(a, b, 1e-8)


def _const(v):
    v = np.asarray(v, dtype=float)
    return lambda x: np.outer(v, np.ones(x.shape[1]))


def test_driven_joint_is_an_input_port():
    """A prescribed hub rotation theta(t) (Simo & Vu-Quoc's spin-up law) drives a pinned beam through
    a driven `angle` joint: the hub angle follows theta(t) to round-off, and the work of the driven joint,
    -lambda . (theta(t_{n+1}) - theta(t_n)), is the energy input: H_{n+1} - H_n = h y.u per step
    (measured 2e-15 of max H; bound 1e-12) and H = supplied throughout (the beam starts at rest)."""
    T, w_s = 1.0, 2.0

    def theta(t):
        t = min(t, T)
        return [w_s / T * (t ** 2 / 2 + (T / (2 * np.pi)) ** 2 * (np.cos(2 * np.pi * t / T) - 1))]
    s = System()
    beam = PlanarBeam(1.0, 0.01, quadratic(EA=1e3, GA=1e3, EI=10.0))
    arm = s.add("arm", beam, shape=straight((0.0, 0.0), (1.0, 0.0)), n_elements=4, supports=[Support("left", "pinned")])
    hub = s.join(joints.angle, ground((0.0, 0.0)), arm.start, name="hub", drive=theta)
    res = run(s, 0.01, 1.5)
    H, W = res.column("H"), res.column("supplied")
    assert W[-1] > 0.5          # the drive did work (about 1/2 J w_s^2 = 0.69 for the rigid arm)
    assert res.max_balance_error <= 1e-12 * np.max(np.abs(H))
    assert np.max(np.abs(H - W)) <= 1e-12 * np.max(np.abs(H))
    assert np.max(res.column("constraint_residual")) <= 1e-13  # the hub angle is theta(t) exactly
    assert np.any(np.abs(res.column("hub.lambda1")) > 0.1)    # the drive torque (the port's output)
    assert hub.size == 1


@pytest.mark.mpi
def test_two_point_masses_under_a_domain_load_follow_the_closed_form():
    """Two free 2D point masses (m = 1 and 2, constant initial values) under the domain force
    (0, -9.81) each: the midpoint rule is exact for a constant force, so x, p and L_z = sum m x ^ v
    equal the parabolas' to round-off (L_z(1) = -4.905 - 7.81).  Run in child processes too, serial
    and on two ranks: under mpirun it ended with a PETSc SEGV at exit (rc 59) after its results."""
    from rodfem.forms.rigid_body import PointMass
    s = System()
    g = [0.0, -9.81]
    s.add("a", PointMass(1.0, dim=2), initial={"x": (0.0, 0.0), "v": (1.0, 0.0)}, loads=[Load("v", g, "domain")])
    s.add("b", PointMass(2.0, dim=2), initial={"x": (1.0, 0.0), "v": (0.0, 1.0)}, loads=[Load("v", g, "domain")])
    res = run(s, 0.1, 1.0)
    t = res.column("t")
    p_y = 2.0 - 2 * 9.81 * t
    L_z = -4.905 * t**2 + 2 * (1.0 - 4.905 * t)   # a: x ^ v = -g t^2 / 2; b: 2 (1 - g t / 2)
    assert np.max(np.abs(res.column("p_x") - 1.0)) <= 1e-12
    assert np.max(np.abs(res.column("p_y") - p_y)) <= 1e-12
    assert np.max(np.abs(res.column("L_z") - L_z)) <= 1e-12
    code = ("from rodfem import Load, System, run\nfrom rodfem.forms.rigid_body import PointMass\ns = System()\n"
            "for n, m, x, v in (('a', 1.0, (0, 0), (1, 0)), ('b', 2.0, (1, 0), (0, 1))):\n"
            "    s.add(n, PointMass(m, dim=2), initial={'x': x, 'v': v}, loads=[Load('v', [0, -9.81], 'domain')])\n"
            "run(s, 0.1, 1.0)\n")
    import shutil
    import subprocess
    import sys

    from processes import environment
    mpirun = ["timeout", "300", shutil.which("mpirun"), "--allow-run-as-root", "--oversubscribe", "-n", "2"]
    for launcher in ([], mpirun):   # two ranks: the parallel solver's SNES was left to PETSc's finalization
        p = subprocess.run([*launcher, sys.executable, "-c", code], capture_output=True, text=True,
                           env=environment(), timeout=330)
        assert p.returncode == 0, p.stderr[-2000:]


@pytest.mark.mpi
def test_field_values_of_a_rod_split_over_ranks_count_each_node_once():
    """A 3D rod of 8 elements (17 P2 nodes) on one and on two ranks: the ranks' rows of
    System.field_values together are the 17 nodes, each once (owned entries only), equal to serial's."""
    from processes import script_on_ranks
    script = """
import json
import numpy as np
from mpi4py import MPI
from rodfem.core.system import System
from rodfem.forms.cosserat_rod import CosseratRod
s = System()
s.add("rod", CosseratRod(1.0, (0.2, 0.1, 0.1), (0.1, 0.1, 0.1), (0.1, 0.1, 0.1)), length=2.0, n_elements=8)
rows = np.concatenate(MPI.COMM_WORLD.allgather(s.field_values("r")))
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps({"r": sorted(rows[:, 0].tolist()), "others": float(np.abs(rows[:, 1:]).max())}))
"""
    serial, parallel = script_on_ranks(script, timeout=300)
    assert np.allclose(serial["r"], np.linspace(0.0, 2.0, 17), atol=1e-14)
    assert parallel == serial
