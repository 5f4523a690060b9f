"""Bodies of one kind (rodfem/core/kinds.py): one mesh, one state space, one compiled set of forms.

The other bodies of a kind get the first body's compiled kernels on their own Functions and
Constants; the history must be that of every body building and compiling its own forms
(`System.share = False`), to the bit: a chain of equal links (one kind, one mesh), links of the
same length and different numbers of cells (one kind, several meshes), links of different lengths
(several kinds), loads whose values differ and change in time, and a scene of 3D rods with a rigid
body."""
import numpy as np
import pytest
from mpi4py import MPI
from test_batch import chain

from rodfem import Load, run
from rodfem.app.scene import load
from rodfem.core.system import System
from rodfem.forms import joints
from rodfem.forms.planar_beam import PlanarBeam, quadratic, straight


def shared_and_not(make, dt, steps):
    out = []
    for share in (True, False):
        System.share = share
        try:
            s = make()
            out.append((run(s, dt, steps * dt), s))
        finally:
            System.share = True
    return out


def assert_identical(a, b):
    (ra, sa), (rb, sb) = a, b
    assert list(ra.rows[0]) == list(rb.rows[0])
    for c in ra.rows[0]:
        if c != "wall_time":
            assert np.array_equal(np.asarray(ra.column(c), float), np.asarray(rb.column(c), float)), c
    assert np.array_equal(sa.state(), sb.state())


def same_length_chain(sizes):
    """Links of length 1/len(sizes) with `sizes` cells each, pinned end to end, their weights ramped."""
    s = System()
    w, rho, E = 0.01, 7800.0, 2e9
    A, I = w * w, w ** 4 / 12
    model = PlanarBeam(rho * A, rho * I, quadratic(EA=E * A, GA=E / 2.6 * A, EI=E * I))
    L, prev = 1.0 / len(sizes), None
    for k, n in enumerate(sizes):
        weight = np.array([0.0, -rho * A * 9.81 * (1 + 0.1 * k)])
        g = Load("v", lambda t, w=weight: w * (1 + 100 * t), "domain", f"gravity b{k}")
        b = s.add(f"b{k}", model, shape=straight((k * L, 0.0), ((k + 1) * L, 0.0)), n_elements=n, loads=[g])
        if prev is not None:
            s.join(joints.pin, prev.end, b.start)
        prev = b
    return s


def test_equal_links_share_one_mesh_and_kernels():
    """Eight equal links: one mesh, one state space, the same compiled kernels; the history (every
    column, the state) equal to the bit to that of eight bodies built one by one."""
    a, b = shared_and_not(lambda: chain(8, total=16), 1e-3, 3)
    s = a[1]
    bodies = [r.body for r in s.bodies.values()]
    assert len({id(bd.mesh) for bd in bodies}) == 1 and len({id(bd.space) for bd in bodies}) == 1
    assert s.kinds == {f"b{k}": "b1" for k in range(2, 8)}   # (b0, pinned, is a kind of its own)
    F = [s.compiled[(n, "F")] for n in s.bodies]
    assert len({f.ufcx_form for f in F}) == 1 and F[1].function_spaces[0] is not None
    assert len({id(bd.mesh) for bd in (r.body for r in b[1].bodies.values())}) == 8
    assert_identical(a, b)


def test_links_of_one_kind_on_different_meshes():
    """Links of the same length with 2, 3 and 5 cells (one kind, three meshes) under weights that
    differ and grow in time (free: momentum columns): the history as built one by one."""
    a, b = shared_and_not(lambda: same_length_chain([2, 3, 5, 3]), 1e-3, 3)
    assert len({id(r.body.mesh) for r in a[1].bodies.values()}) == 3
    assert a[1].kinds == {"b1": "b0", "b2": "b0", "b3": "b0"} and b[1].kinds == {}
    assert "p_x" in a[0].rows[0]
    assert_identical(a, b)


def test_links_of_different_lengths():
    """Links of different lengths (their columns' forms differ: a kind each) as built one by one."""
    assert_identical(*shared_and_not(lambda: chain(4, sizes=[2, 3, 5, 6], ramp=True), 1e-3, 3))


@pytest.mark.parametrize("scene, overrides, steps", [
    ("free-flying-3d", {"n_elements": 4}, 3),            # two 3D rods and a rigid ball
    ("spring-damper-chain", {"n_bodies": 3}, 3),         # rigid boxes, springs and dashpots
])
def test_scenes_shared_equal_built_one_by_one(scene, overrides, steps):
    sc = load(scene)
    p = sc.values(overrides)
    assert_identical(*shared_and_not(lambda: sc.build(p, MPI.COMM_WORLD), p["dt"], steps))


def test_redundant_joint_in_a_long_chain_is_refused():
    """The joints' rank check, block by block over the joints that share velocities: a second pin
    between the same two links (of a 40-link chain) is redundant and refused."""
    from rodfem.errors import ConstraintError
    s = chain(40, total=40)
    refs = list(s.bodies.values())
    s.join(joints.pin, refs[20].end, refs[21].start)
    with pytest.raises(ConstraintError, match="independent"):
        s.build()
