"""Larger meshes (issue 11): the parallel solver, the fast Jacobian assembly, the serial LU.

- `mpirun -n 2` at 10^4 planar elements converges and gives the serial history (MUMPS, the
  old parallel default, stopped at step 1 with DIVERGED_LINEAR_SOLVE there);
- the interface Schur complement (rodfem/la/schur.py) solves as accurately as a direct
  LU, on 1, 2 and 3 ranks, with saddle points (the 3D rod's multipliers: AMD order inside);
- the partial LU (rodfem/la/partial_lu.py) leaves -A_GI A_II^{-1} A_IG in its corner and solves
  both sweeps exactly (against dense linear algebra), in RCM and AMD order;
- the serial LU chain: RCM (a net, which is no band: the partial LU first), and the partial LU
  (multipliers last) after the 3D rod's zero pivot,
  SuperLU when every order of the partial LU meets one;
"""

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc
from processes import assert_same_history, history, rodfem, serial_and_parallel, summary
from scenes import built

from rodfem import run
from rodfem.app.scene import load
from rodfem.la.lu_chain import backward_error
from rodfem.la.schur import InterfaceSchur, interface


def schur_pc(A):
    pc = PETSc.PC().create(A.getComm())
    pc.setType("python")
    pc.setPythonContext(InterfaceSchur())
    pc.setOperators(A)
    pc.setUp()
    return pc


def test_interface_is_a_vertex_cover_of_the_couplings():
    """G cuts every coupling between ranks, taking the smaller side of each pair of ranks."""
    # rank 0 rows 0..9, rank 1 rows 10..19: the shared node (dofs 8, 9) couples to 10, 11, 12
    pairs = [np.array([[8, 10, 1], [8, 11, 1], [9, 12, 1]]),
             np.array([[10, 8, 0], [11, 8, 0], [12, 9, 0], [12, 8, 0]])]
    G = interface(pairs)
    assert list(G) == [8, 9]
    for r, prs in enumerate(pairs):
        for i, j, _ in prs:
            assert i in G or j in G
    assert len(interface([np.zeros((0, 3), int), np.zeros((0, 3), int)])) == 0


@pytest.mark.parametrize("scene, n", [("flying-spaghetti-2d", 40), ("flying-spaghetti-3d", 8)])
def test_schur_pc_solves_like_lu_in_serial(scene, n):
    """On one rank the PC is the local LU (its first orders; the 3D rod's multipliers last)."""
    problem = built(scene, n)
    nw = problem.newton
    A = nw.A
    b = nw.b.copy()
    nw.assembler.residual(nw.xv, b)
    pc = schur_pc(A)
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setOperators(A)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("superlu")
    assert backward_error(A, pc.apply, b) <= 1e-13
    assert backward_error(A, ksp.solve, b) <= 1e-13
    assert pc.getPythonContext().describe() == "schur(rcm)"


@pytest.mark.parametrize("method", ["rcm", "nd", "amd"])
def test_partial_lu_leaves_the_schur_complement(method):
    """A chain-like interior (scrambled numbering) with an interface coupled to its last dofs:
    the corner is -A_GI A_II^{-1} A_IG, the forward sweep gives -A_GI A_II^{-1} b_I and the
    backward sweep A_II^{-1} (b_I - A_IG x_G), each to round-off."""
    import scipy.sparse as sp

    from rodfem.la.partial_lu import PartialLU
    rng = np.random.default_rng(1)
    nI, nG = 300, 6
    chain = sp.diags([rng.normal(size=nI - abs(k)) for k in range(-4, 5)], range(-4, 5)) + 10 * sp.eye(nI)
    p = rng.permutation(nI)
    K = sp.lil_matrix((nI + nG, nI + nG))
    K[:nI, :nI] = sp.csr_matrix(chain)[p][:, p]
    near = np.argsort(p)[nI - 5:]
    for g in range(nG):
        for c in near[:3 + g % 3]:
            K[c, nI + g], K[nI + g, c] = rng.normal(size=2)
    K = sp.csr_matrix(K)
    K.sort_indices()
    lu = PartialLU(K.indptr, K.indices, nI, nG, np.arange(K.nnz), K.nnz, 0, method)
    T = lu.factor(K.data.copy(), None, None)
    Kd = K.toarray()
    AII, AIG, AGI = Kd[:nI, :nI], Kd[:nI, nI:], Kd[nI:, :nI]
    want = -AGI @ np.linalg.solve(AII, AIG)
    assert np.max(np.abs(T - want)) <= 1e-13 * np.max(np.abs(want))
    b, xG = rng.normal(size=nI), rng.normal(size=nG)
    assert np.max(np.abs(lu.forward(b) + AGI @ np.linalg.solve(AII, b))) <= 1e-13
    out = np.zeros(nI)
    lu.backward(xG, out)
    assert np.max(np.abs(out - np.linalg.solve(AII, b - AIG @ xG))) <= 1e-13
    assert lu.fill < 2.5   # RCM turned so that the interface side comes last: no fill outside the band


def _chain_with_interface(half_band, nI=300, nG=6, seed=1):
    """K (CSR): a band of half-width `half_band` in scrambled numbering, its last dofs coupled to nG interface dofs."""
    import scipy.sparse as sp
    rng = np.random.default_rng(seed)
    band = range(-half_band, half_band + 1)
    chain = sp.diags([rng.normal(size=nI - abs(k)) for k in band], band) + 10 * sp.eye(nI)
    p = rng.permutation(nI)
    K = sp.lil_matrix((nI + nG, nI + nG))
    K[:nI, :nI] = sp.csr_matrix(chain)[p][:, p]
    for g in range(nG):
        for c in np.argsort(p)[nI - 5:][:3 + g % 3]:
            K[c, nI + g], K[nI + g, c] = rng.normal(size=2)
    K = sp.csr_matrix(K)
    K.sort_indices()
    return K, nI, nG


def test_the_interior_graph_is_the_pattern_of_k_plus_its_transpose():
    """interior_graph (C) against scipy's K + K^T on the interior rows and columns: the same pattern, rows
    sorted, for unsymmetric patterns whose rows are not sorted, with an interface block left out."""
    import scipy.sparse as sp

    from rodfem.la.partial_lu import interior_graph
    rng = np.random.default_rng(3)
    for seed in range(10):
        n, nI = 120, 110 - seed
        K = sp.csr_matrix(sp.random(n, n, density=0.04, random_state=seed) + sp.eye(n))
        kj = K.indices.copy()
        for r in range(n):   # (each row's columns in a random order)
            kj[K.indptr[r]:K.indptr[r + 1]] = rng.permutation(kj[K.indptr[r]:K.indptr[r + 1]])
        want = (K + K.T).tocsr()[:nI, :nI]
        want.sort_indices()
        got = interior_graph(K.indptr, kj, nI)
        assert np.array_equal(got.indptr, want.indptr) and np.array_equal(got.indices, want.indices)


def test_a_subgraph_is_scipys_rows_and_columns_of_the_graph():
    """subgraph (C) against scipy's graph[keep][:, keep]: the same pattern, rows sorted, renumbered, for
    kept sets that leave out rows at the ends, in the middle, none and all but one."""
    import scipy.sparse as sp

    from rodfem.la.partial_lu import interior_graph, subgraph
    rng = np.random.default_rng(5)
    for seed in range(6):
        n = 90
        K = sp.csr_matrix(sp.random(n, n, density=0.05, random_state=seed) + sp.eye(n))
        graph = interior_graph(K.indptr, K.indices, n)
        for keep in (np.flatnonzero(rng.random(n) < 0.8), np.arange(n), np.arange(5, n - 3), np.array([7])):
            want = graph[keep][:, keep].tocsr()
            want.sort_indices()
            got = subgraph(graph, keep)
            assert got.shape == want.shape
            assert np.array_equal(got.indptr, want.indptr) and np.array_equal(got.indices, want.indices)


def test_the_dofs_next_to_the_interface_are_ordered_last():
    """interior_orders puts the interior dofs that couple to the interface G after the others, just before G:
    a chain of 10 interior dofs whose last couples to G's first by its own row, and whose first only through
    an interface row's entry (K_G0, not K_0G)."""
    import scipy.sparse as sp

    from rodfem.la.partial_lu import interior_orders
    n, nI = 12, 10
    K = sp.diags([np.ones(n - 1), np.ones(n), np.ones(n - 1)], [-1, 0, 1], format="lil")
    K[10, 9] = 0.0   # (G's rows couple to dof 9 only through dof 9's row...)
    K[11, 0] = 1.0   # (...and to dof 0 through an interface row's entry)
    K = sp.csr_matrix(K)
    K.eliminate_zeros()
    for tries in ((("rcm", False),), (("amd", False),), (("rcm", True),)):
        (order,) = interior_orders(K.indptr, K.indices, nI, n - nI, tries)
        assert sorted(order[nI - 2:nI]) == [0, 9] and list(order[nI:]) == [10, 11], (tries, order)


def test_partial_lu_tries_end_at_the_pattern_of_the_matrix(monkeypatch):
    """"rcm" tries RCM, AMD and RCM turned round and keeps the least fill; since no order's factor has fewer
    entries than K and its diagonal, an order within NO_BETTER of that ends the tries.  A tridiagonal
    chain: RCM's factor is K's pattern and a few entries, one symbolic count.  A band of half-width 4 (its
    interface side first in RCM's order: 1.9 times K's entries): all three counted, the one kept the least
    of the three counted independently (RCM turned round, K's pattern and 2 %)."""
    from rodfem.la import partial_lu
    from rodfem.la.partial_lu import NO_BETTER, PartialLU, interior_orders
    counts = []
    count = PartialLU._symbolic_count
    monkeypatch.setattr(PartialLU, "_symbolic_count", lambda self, limit=None: counts.append(limit) or count(self, limit))
    monkeypatch.setattr(partial_lu, "_SYMBOLIC", {})
    K, nI, nG = _chain_with_interface(1, nI=3000)
    lu = PartialLU(K.indptr, K.indices, nI, nG, None, K.nnz, 0, "rcm")
    assert counts == [None] and K.nnz < lu.nnz <= NO_BETTER * K.nnz   # (the interface side: a few entries more)
    T = lu.factor(K.data.copy(), None, None)
    Kd = K.toarray()
    assert np.allclose(T, -Kd[nI:, :nI] @ np.linalg.solve(Kd[:nI, :nI], Kd[:nI, nI:]), rtol=1e-12, atol=1e-12)
    counts.clear()
    K, nI, nG = _chain_with_interface(4)
    lu = PartialLU(K.indptr, K.indices, nI, nG, None, K.nnz, 0, "rcm")
    assert len(counts) == 3   # (RCM's factor 1.9 times K's: AMD and RCM turned round tried)
    each = []
    for perm in interior_orders(K.indptr.astype(np.int32), K.indices.astype(np.int32), nI, nG,
                                (("rcm", False), ("amd", False), ("rcm", True))):
        one = PartialLU.__new__(PartialLU)
        one.mod, one.n, one.nI, one.ki, one.kj = lu.mod, nI + nG, nI, lu.ki, lu.kj
        one.perm, one.iperm = perm, np.argsort(perm).astype(np.int32)
        each.append(count(one))
    assert lu.nnz == min(each) and len(set(each)) > 1


@pytest.mark.parametrize("scene, n, lu", [("flying-spaghetti-2d", 200, "petsc"), ("flying-spaghetti-3d", 12, "schur(rcm)")])
def test_serial_lu_chain(scene, n, lu):
    """The serial LU: PETSc's in RCM order for the beam; for the 3D rod, whose multipliers are zero
    pivots in RCM order, the partial LU that orders them last (not SuperLU: 4x faster); accurate solves."""
    problem = built(scene, n)
    nw = problem.newton
    assert nw.linear_solver == lu
    b = nw.b.copy()
    nw.assembler.residual(nw.xv, b)
    assert backward_error(nw.A, problem.newton.snes.getKSP().solve, b) <= 1e-11


@pytest.mark.parametrize("scene, values, lu", [
    ("whirling-rod-3d", {"n_elements": 8}, "schur(rcm)"),
    ("helix-3d", {"n_elements": 8, "constraint": "kirchhoff"}, "superlu")])
def test_serial_lu_chain_on_harder_saddle_points(scene, values, lu):
    """A thin section (massless axis director: w1 has a zero diagonal too, and lambda_11 couples
    only to it) is ordered by the partial LU in rounds (w1 after the stresses, lambda_11 after w1);
    a massless Kirchhoff rod (statics: every velocity a multiplier) has a zero pivot in every
    order, and the partial LU hands over to SuperLU, which pivots.  Accurate solves."""
    s = load(scene)
    p = s.values(values)
    problem = s.build(p, MPI.COMM_WORLD)
    run(problem, p["dt"], 2 * p["dt"])
    nw = problem.newton
    assert nw.linear_solver == lu
    b = nw.b.copy()
    nw.assembler.residual(nw.xv, b)
    assert backward_error(nw.A, nw.snes.getKSP().solve, b) <= 1e-11


@pytest.mark.mpi
def test_mpi_two_ranks_at_ten_thousand_elements(tmp_path):
    """10^4 planar elements, 3 steps: mpirun -n 2 converges and equals serial to 1e-8 (it failed
    at step 1 with MUMPS); the summary names the parallel solver."""
    args = ["run", "flying-spaghetti-2d", "--set", "n_elements=10000", "--set", "t_end=0.3",
            "--set", "frames=2", "--quiet"]
    a, b, par = serial_and_parallel(tmp_path, args, timeout=240)
    assert_same_history(a, b, 1e-8)
    assert par["linear_solver"] == "schur(rcm)"
    assert len(b["t"]) == 4
    assert np.array_equal(a["newton_its"], b["newton_its"])
    assert np.max(np.abs(b["balance_error"])) <= 1e-12 * np.max(np.abs(b["H"]))


@pytest.mark.mpi
def test_mpi_three_ranks_3d_rod_matches_serial(tmp_path):
    """Three ranks (two interfaces; the multipliers ordered last inside the ranks, those of an
    interface node on the interface) give the serial history of the 3D rod."""
    args = ["run", "flying-spaghetti-3d", "--set", "n_elements=12", "--set", "t_end=0.5",
            "--set", "frames=2", "--quiet"]
    a, b, par = serial_and_parallel(tmp_path, args, np=3, timeout=240)
    assert_same_history(a, b, 1e-8)
    assert par["linear_solver"] == "schur(rcm)"


@pytest.mark.mpi
def test_mpi_step_retried_after_a_failed_chord_newton(tmp_path):
    """2000 planar elements (18,006 unknowns: the chord Newton of large systems) at dt = 1: steps
    that the chord Newton fails are repeated with full Newton, then from x_n (Newton's settings
    applied again made a new parallel solver context that PETSc did not set up: it crashed at step
    3 under mpirun).  Serial and two ranks take the same steps and both stop at the same step with
    one line and exit code 3, the history so far kept and equal."""
    args = ["run", "flying-spaghetti-2d", "--set", "n_elements=2000", "--set", "dt=1.0", "--set", "t_end=12",
            "--set", "dt_min=1.0", "--quiet"]   # no sub-steps: the failure path (split steps: test_stepping.py)
    s = rodfem(*args, "--out", str(tmp_path / "np1"))
    p = rodfem(*args, "--out", str(tmp_path / "np2"), np=2, timeout=240)
    assert s.returncode == 3 and p.returncode == 3, p.stderr[-2000:]
    for out in (s, p):
        assert "Newton failed at step 8 (t = 8)" in out.stderr
    a, b = history(tmp_path / "np1"), history(tmp_path / "np2")
    assert len(a["t"]) == 8   # t = 0 .. 7
    # the states to 1e-8; Newton's iteration counts may differ near the failure (round-off decides
    # whether the chord Newton's step 4 is retried with full Newton: 15 serial, 6 on two ranks)
    assert_same_history(a, b, 1e-8, skip=("newton_its",))
    assert summary(tmp_path / "np2")["status"] == "newton-failure"


@pytest.mark.mpi
@pytest.mark.parametrize("stage", ["amd", "superlu", "mumps"])
def test_mpi_every_interior_solver_gives_the_serial_history(tmp_path, stage):
    """The parallel solver with each of its interior stages (-rodfem_schur_local_solver: the partial LU
    in AMD order, SuperLU, MUMPS; RCM is the default, tested above) on the 3D rod (multipliers: saddle
    points) gives the serial history to 1e-8 of each column's scale, and says which stage ran.  Only the
    default stage was run under mpirun before: a wrong sign in the MUMPS stage went unnoticed."""
    args = ["run", "flying-spaghetti-3d", "--set", "n_elements=8", "--set", "t_end=0.3", "--set", "frames=2",
            "--quiet"]
    serial = tmp_path / "np1"
    assert rodfem(*args, "--out", serial, timeout=240).returncode == 0
    par = tmp_path / "np2"
    p = rodfem(*args, "--out", par, np=2, timeout=240, env={"PETSC_OPTIONS": f"-rodfem_schur_local_solver {stage}"})
    assert p.returncode == 0, p.stderr[-2000:]
    assert_same_history(history(serial), history(par), 1e-8)
    assert summary(par)["linear_solver"] == f"schur({stage})"


def test_a_net_starts_with_the_partial_lu_and_keeps_the_history():
    """A net of strings joined at its crossings (10 x 10, 5,300 unknowns) is no band: RCM's envelope holds
    3.4 entries per entry of the Jacobian (a chain of beams 0.47), and the serial solver starts with the
    partial LU (its AMD order with each multiplier after the dofs it constrains).  The history equals that
    of PETSc's LU in RCM order (kept when the user's option names it) to 1e-10, and the partial LU's
    factor has less than half as many entries (measured: 2.1 against 5.2 per entry of the Jacobian)."""
    from rodfem.la.lu_chain import rcm_envelope
    s = load("cable-net")
    p = s.values({"n": 10})
    runs = []
    for forced in (False, True):
        opts = PETSc.Options()
        if forced:   # (the user's option: Newton keeps the LU it names)
            opts["rodfem_pc_factor_mat_ordering_type"] = "rcm"
        try:
            problem = s.build(p, MPI.COMM_WORLD)
            runs.append((run(problem, p["dt"], 5 * p["dt"]), problem))
        finally:
            opts.delValue("rodfem_pc_factor_mat_ordering_type")
    (net, partial), (_, rcm) = runs
    assert partial.newton.linear_solver == "schur(rcm)" and rcm.newton.linear_solver == "petsc"
    assert rcm_envelope(partial.newton.A) > 3.0
    columns = [c for c in net.rows[0] if c != "wall_time"]
    assert_same_history(*({c: np.asarray(r.column(c), float) for c in columns} for r in (net, runs[1][0])), 1e-10)
    fill = partial.newton.snes.getKSP().getPC().getPythonContext().plu.fill
    rcm_fill = rcm.newton.snes.getKSP().getPC().getFactorMatrix().getInfo()["nz_used"] / rcm.newton.A.getInfo()["nz_used"]
    assert fill < 0.5 * rcm_fill
