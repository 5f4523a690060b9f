"""Counting independent joint conditions (rodfem/la/rank.py) and reusing the joints' quadratic forms
(rodfem/core/joints.py, QuadraticForms): both were cubic or per-joint costs of building a many-body
system (a chain of 1000 links took 245 s to build), and both must give what the direct
computation gives."""
import numpy as np
import pytest
import scipy.sparse as sp
from mpi4py import MPI

from rodfem.core.joints import QuadraticForms, quadratic_form
from rodfem.errors import ConstraintError
from rodfem.la.rank import row_rank


def chain_constraints(n, rng):
    """G of a chain: condition rows of joint k touch the velocities of bodies k and k+1 (6 each)."""
    blocks = [sp.random(3, 12, density=0.8, random_state=rng) for _ in range(n)]
    G = sp.lil_matrix((3 * n, 6 * (n + 1)))
    for k, b in enumerate(blocks):
        G[3 * k:3 * k + 3, 6 * k:6 * k + 12] = b.toarray()
    return G.tocsr()


@pytest.mark.parametrize("n", [1, 7, 400])
def test_row_rank_against_the_singular_values(n):
    """Full row rank, then the rows made dependent in three ways (a repeated row, a combination of
    rows of two joints, a zero row): the count equals numpy's (matrix_rank, dense SVD)."""
    rng = np.random.default_rng(n)
    G = chain_constraints(n, rng)
    dense = G.toarray()
    assert row_rank(G) == np.linalg.matrix_rank(dense) == 3 * n
    repeated = sp.vstack([G, G[3 * (n // 2)]])
    combined = sp.vstack([G, 2.0 * G[0] - 0.5 * G[3 * n - 1]])
    zero = sp.vstack([G, sp.csr_matrix((1, G.shape[1]))])
    for H in (repeated, combined, zero):
        assert row_rank(H) == np.linalg.matrix_rank(H.toarray()) == 3 * n


def test_row_rank_sees_nearly_and_exactly_dependent_rows():
    """Rows at an angle of 1e-3 are independent; a row equal to another up to 1e-15 is not."""
    a = np.array([1.0, 0.0, 0.0])
    assert row_rank(np.array([a, [1.0, 1e-3, 0.0]])) == 2
    assert row_rank(np.array([a, [1.0, 1e-15, 0.0]])) == 1
    assert row_rank(np.zeros((0, 3))) == 0


def link_frame(q):
    from rodfem.core.joints import Frame
    return Frame(x=q[:3], d=[q[3:6], q[6:9], q[9:12]])


def hinge_between(qa0, qb0, constraint):
    na = len(qa0)
    a0, b0 = link_frame(qa0), link_frame(qb0)
    calls = [0]

    def g(q):
        calls[0] += 1
        return np.asarray(constraint(link_frame(q[:na]), link_frame(q[na:]), a0, b0), dtype=float).ravel()
    return g, calls


def test_moved_forms_equal_the_polarized_ones():
    """Links along a line, each 0.3 further on and turned 0.1 rad more about z than the last: the
    hinges about z (translation and rotation invariant: the known form moved by T = q0' - q0 is
    accepted only for the translated pairs), a tether of each point to where it started (moved, with
    Q T != 0: the linear term changes) and a constraint that depends on where a is
    (|x_a|^2 - |x_a(0)|^2: never moved).  Each found form equals the one polarized afresh to 1e-12,
    and the accepted moves cost 3 evaluations each (polarization: 325)."""
    from rodfem.forms import joints

    def turned(k, angle):
        c, s = np.cos(angle), np.sin(angle)
        return np.concatenate([[0.3 * k, 0.1 * k, 0.0], [c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])

    def distance_from_origin(a, b, a0, b0):
        return np.array([a.x @ a.x - a0.x @ a0.x])

    def tethered(a, b, a0, b0):   # (each point near where it started: moved by T, Q T != 0)
        return np.array([(a.x - a0.x) @ (a.x - a0.x) + (b.x - b0.x) @ (b.x - b0.x)])
    for constraint, angles, moved in ((joints.revolute(axis=2), lambda k: 0.0, True), (tethered, lambda k: 0.0, True),
                                      (joints.revolute(axis=2), lambda k: 0.1 * k, False),
                                      (distance_from_origin, lambda k: 0.0, False)):
        forms = QuadraticForms()
        for k in range(5):
            qa0, qb0 = turned(k, angles(k)), turned(k + 1, angles(k + 1))
            qa0[:3] += 0.15 * qa0[3:6]   # (the hinge at the shared end point)
            qb0[:3] -= 0.15 * qb0[3:6]
            g, calls = hinge_between(qa0, qb0, constraint)
            scale = max(1.0, np.max(np.abs(np.concatenate([qa0, qb0]))))
            Q, c, e = forms.find(g, np.concatenate([qa0, qb0]), scale, key="hinge")
            used = calls[0]
            Qr, cr, er = quadratic_form(g, 24, scale)
            for x, y in ((Q, Qr), (c, cr), (e, er)):
                assert np.max(np.abs(x - y), initial=0.0) <= 1e-12 * max(1.0, np.max(np.abs(y), initial=0.0))
            if k > 0:
                assert (used == 3) if moved else (used > 325), (constraint, k, used)   # moved, or polarized


def test_a_chain_of_200_links_builds_with_reused_forms_and_refuses_a_redundant_hinge():
    """The chain-1000 scene at 200 links binds its 200 hinges (199 by moving the first hinge's form)
    and passes the rank check; a second pivot at the ground end (5 conditions the first already
    imposes) is refused by the sparse check as before by the dense one."""
    from rodfem.core.joints import ground
    from rodfem.demos.chain_1000 import scene
    from rodfem.forms import joints
    p = scene.values({"n_links": 200})
    system = scene.build(p, MPI.COMM_SELF)
    system.build()
    hinges = system.joints
    first = hinges[1]
    assert len(hinges) == 200 and all(np.array_equal(j.Q, first.Q) for j in hinges[2:])
    again = scene.build(p, MPI.COMM_SELF)
    l = p["L"] / p["n_links"]
    again.join(joints.revolute(axis=1), ground((0.0, 0.0, 0.0)), again.bodies["link0"].point((-0.5 * l, 0.0, 0.0)),
               name="pivot again")
    with pytest.raises(ConstraintError, match="impose 1005 conditions of which only 1000 are independent"):
        again.build()
