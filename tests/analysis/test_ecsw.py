"""ECSW hyper-reduction of the nonlinear reduced model (rodfem/analysis/ecsw.py, rodfem/fem/sampled.py).

Oracles: with every cell and unit weights the sampled assembly IS the Galerkin projection of DOLFINx's full
assembly (residual, Jacobian, H, work, outputs to round-off; per-cell energies summing to DOLFINx's H), and the
hyper-reduced run is galerkin.ReducedSystem's (to Newton's tolerance), for two integrators and energies; the
tip load is not weighted (V^T B u exactly, whatever the sample); the weights are > 0, few, and fit the training
contributions within the tolerance (recomputed from the training matrix); the weighted energy balance
H_w(n+1) - H_w(n) = h y.u holds to round-off and H_w is conserved without input; the error against the full
model stays close to that without hyper-reduction on the training input and on another one."""
import numpy as np
import pytest
import scipy.sparse as sp
from mpi4py import MPI
from processes import rodfem_lines

from rodfem.analysis.ecsw import HyperReducedSystem, Sample, nnls, train, training_matrix
from rodfem.analysis.galerkin import layout, pod_basis
from rodfem.analysis.timeloop import run
from rodfem.app.analyses import resolve
from rodfem.app.driver import build
from rodfem.app.nonlinear_reduction import energy_error, errors, full_run, reduced_run
from rodfem.errors import ParameterError

# the steel strip of cantilever-2d, 1 m, 32 elements, its tip load ramped over 0.1 s to a deflection of 20 % of L
BASE = {"degree": 2, "n_elements": 32, "fy": -80.0, "t_ramp": 0.1, "t_load": 1.0, "t_end": 0.1, "dt": 2e-3}
TEST = {"fy": -50.0, "fx": 10.0}


def trained(overrides=None, test=None):
    scene, p = resolve("cantilever-2d", {**BASE, **(overrides or {})})
    problem = build(scene, p, MPI.COMM_WORLD)
    res, X = full_run(problem, p["dt"], p["t_end"])
    out = {"train": (problem, res, X, p)}
    if test:
        _, q = resolve("cantilever-2d", {**BASE, **(overrides or {}), **test})
        other = build(scene, q, MPI.COMM_WORLD)
        out["test"] = (other, *full_run(other, q["dt"], q["t_end"]), q)
    return out, layout(problem)


@pytest.fixture(scope="module")
def hooke():
    return trained(test=TEST)


def every_cell(n):
    return Sample(np.arange(n), np.ones(n), 0.0, 0.0, n, 0)


def full_projection(problem, basis, xi1, xi0):
    """V^T F, V^T J V, H, work, tip_y by DOLFINx's full assembly at x_{n+1} = x_ref + V xi1, x_n = x_ref + V xi0."""
    problem.restore((basis.full(xi0), []))
    a = problem.assembler
    X = a.vector
    X.getArray()[:] = basis.full(xi1)
    a.update(X)
    b = a.create_vector()
    a.residual(X, b)
    a.jacobian(X, a.A)
    indptr, cols, vals = a.A.getValuesCSR()
    J = sp.csr_matrix((vals, cols, indptr), shape=a.A.getSize())
    V = basis.V
    return (V.T @ b.getArray(readonly=True), V.T @ (J @ V), problem.hamiltonian(), problem.supplied_work(),
            problem.observe()["tip_y"])


@pytest.mark.parametrize("case", ["midpoint", "discrete-gradient"])
def test_every_cell_with_unit_weights_is_the_galerkin_model(case, hooke):
    """With every cell and w = 1: the sampled residual, Jacobian, H, work and tip equal the projections of DOLFINx's
    full assembly to round-off at states off the training run, the per-cell energies sum to DOLFINx's H, and the run
    is galerkin.ReducedSystem's to Newton's tolerance (Hooke's law with the midpoint rule; the log-axial law with the
    discrete gradient)."""
    cases, lay = hooke if case == "midpoint" else trained({"material": "log-axial", "integrator": "discrete-gradient"})
    problem, res, X, p = cases["train"]
    basis = pod_basis(X, 3, lay, problem)
    rom = HyperReducedSystem(problem, basis, every_cell(p["n_elements"]), start=X[:, 0])
    rom.reuse_jacobian = False
    problem.set_step(p["dt"])
    problem.set_time(0.05)
    rng = np.random.default_rng(1)
    for k in (10, 40):
        xi0 = basis.coordinates(X[:, k]) + 1e-3 * rng.standard_normal(basis.order)
        xi1 = basis.coordinates(X[:, k + 1]) + 1e-3 * rng.standard_normal(basis.order)
        r, J, H, W, tip = full_projection(problem, basis, xi1, xi0)
        rom.rstate.set(xi1, xi0)
        assert np.linalg.norm(rom.F.evaluate() - r) <= 1e-12 * np.linalg.norm(r)
        assert np.linalg.norm(rom.J.evaluate() - J) <= 1e-12 * np.linalg.norm(J)
        assert rom.H.evaluate() == pytest.approx(H, rel=1e-13)
        assert rom.W.evaluate() == pytest.approx(W, rel=1e-13) and abs(W) > 0
        assert rom.outputs["tip_y"].evaluate() == pytest.approx(tip, rel=1e-13)
        per_cell, facets = rom.H.evaluate(separate=True)
        assert per_cell.shape == (p["n_elements"],) and per_cell.sum() + facets == pytest.approx(H, rel=1e-13)
    red, S, rom = reduced_run(problem, basis, p["dt"], p["t_end"], X[:, 0], every_cell(p["n_elements"]))
    ref, S_ref, _ = reduced_run(problem, basis, p["dt"], p["t_end"], X[:, 0])
    assert np.abs(S - S_ref).max() <= 1e-7 * np.abs(S_ref).max()
    assert np.abs(red.column("H") - ref.column("H")).max() <= 1e-9 * ref.column("H").max()


def test_sampled_jacobian_is_the_derivative_of_the_sampled_residual(hooke):
    """With a trained sample (weights not 1), the reduced Jacobian is the derivative of the weighted reduced residual
    (central differences in every reduced coordinate, to 1e-6)."""
    cases, lay = hooke
    problem, res, X, p = cases["train"]
    basis = pod_basis(X, 3, lay, problem)
    s = train(problem, basis, X, 3e-2)
    assert np.ptp(s.weights) > 0.1
    rom = HyperReducedSystem(problem, basis, s, start=X[:, 0])
    problem.set_step(p["dt"])
    problem.set_time(0.05)
    xi0, xi1 = basis.coordinates(X[:, 30]), basis.coordinates(X[:, 31])
    rom.rstate.set(xi1, xi0)
    J = rom.J.evaluate()
    fd = np.zeros_like(J)
    for j in range(basis.order):
        eps = 1e-6 * max(1.0, abs(xi1[j]))
        for sign in (1, -1):
            rom.rstate.set(xi1 + sign * eps * np.eye(basis.order)[j])
            fd[:, j] += sign * rom.F.evaluate() / (2 * eps)
    assert np.linalg.norm(J - fd) <= 1e-6 * np.linalg.norm(J)


def test_point_load_is_not_weighted(hooke):
    """The tip load is a facet term, not a cell integral: whatever the sample (here one cell at the clamp, weight 2,
    the tip's cell left out), the load's part of the reduced residual is V^T B u of the full assembly, exactly."""
    cases, lay = hooke
    problem, res, X, p = cases["train"]
    basis = pod_basis(X, 3, lay, problem)
    rom = HyperReducedSystem(problem, basis, Sample(np.array([0]), np.array([2.0]), 0.0, 0.0, p["n_elements"], 0),
                             start=X[:, 0])
    problem.set_step(p["dt"])
    xi0, xi1 = basis.coordinates(X[:, 20]), basis.coordinates(X[:, 21])
    parts = []
    for t in (0.05, 2.0):     # the load on (fy = -40 N), then off (t > t_load)
        problem.set_time(t)
        rom.rstate.set(xi1, xi0)
        parts.append((rom.F.evaluate(), full_projection(problem, basis, xi1, xi0)[0]))
    load, full_load = parts[0][0] - parts[1][0], parts[0][1] - parts[1][1]
    assert np.linalg.norm(full_load) > 1.0
    assert np.linalg.norm(load - full_load) <= 1e-12 * np.linalg.norm(full_load)


def test_weights_are_positive_few_and_fit_within_the_tolerance(hooke):
    """The trained weights are > 0, on fewer cells than the mesh has, and fit the training matrix within the
    tolerance: |G w - G 1| <= tol |G 1|, recomputed here from G; a smaller tolerance samples more cells, and even
    at 1e-3 at most 40 % of them (9 of 32)."""
    cases, lay = hooke
    problem, res, X, p = cases["train"]
    basis = pod_basis(X, 3, lay, problem)
    G, cells = training_matrix(problem, basis, X)
    counts = []
    for tol in (3e-2, 1e-3):
        s = train(problem, basis, X, tol)
        assert np.all(s.weights > 0) and len(s.cells) == len(s.weights) and len(np.unique(s.cells)) == len(s.cells)
        w = np.zeros(len(cells))
        w[np.searchsorted(cells, s.cells)] = s.weights
        ones = G @ np.ones(len(cells))
        fit = np.linalg.norm(G @ w - ones) / np.linalg.norm(ones)
        assert fit <= tol and fit == pytest.approx(s.fit_residual, rel=1e-6, abs=1e-12)
        counts.append(len(s.cells))
    assert counts[0] < counts[1] <= 0.4 * p["n_elements"]


def test_nnls_meets_the_tolerance_with_few_non_negative_weights():
    """On a random G (200 x 60), the greedy NNLS stops at the tolerance with w >= 0, its reported residual the true
    one; at a tolerance it cannot meet with fewer cells it uses more."""
    rng = np.random.default_rng(0)
    G = rng.random((200, 60)) + 0.1 * rng.standard_normal((200, 60))
    b = G @ np.ones(60)
    sizes = []
    for tol in (1e-1, 1e-2, 1e-4):
        w, fit = nnls(G, tol)
        assert np.all(w >= 0) and fit <= tol
        assert fit == pytest.approx(np.linalg.norm(G @ w - b) / np.linalg.norm(b), rel=1e-6)
        sizes.append(int(np.count_nonzero(w)))
    assert sizes[0] < sizes[1] <= sizes[2] and sizes[0] < 20


def test_nnls_reaches_the_constrained_optimum_of_scipy():
    """For targets outside the cone of G's columns (b = G x, x of both signs), run to its end (a tolerance below the
    optimum), the greedy NNLS stops at the optimum of scipy.optimize.nnls (Lawson-Hanson run to convergence): the
    same residual with weights >= 0, on a Gaussian G (60 x 30) and on 200 small G of positive, strongly correlated
    columns (12 x 8), where the active set's unconstrained fit often has negative weights."""
    from scipy.optimize import nnls as scipy_nnls
    rng = np.random.default_rng(5)
    problems = [rng.standard_normal((60, 30))] + [rng.random((12, 8)) for _ in range(200)]
    for G in problems:
        b = G @ rng.standard_normal(G.shape[1])
        w, fit = nnls(G, 1e-14, target=b)
        x, rnorm = scipy_nnls(G, b)
        assert np.all(w >= 0) and fit == pytest.approx(rnorm / np.linalg.norm(b), rel=1e-8, abs=1e-12)
    assert nnls(problems[0], 1e-14, target=problems[0] @ rng.standard_normal(30))[1] > 0.05   # the constraint binds


@pytest.mark.parametrize("case", ["midpoint", "discrete-gradient"])
def test_weighted_energy_balance_is_exact(case, hooke):
    """H_w(xi_{n+1}) - H_w(xi_n) = h y.u per step to 1e-12 of max H_w with a sample of few cells (Hooke's law with
    the midpoint rule; the log-axial law with the discrete gradient); the port did work, and H_w is not H."""
    cases, lay = hooke if case == "midpoint" else trained({"material": "log-axial", "integrator": "discrete-gradient"})
    problem, res, X, p = cases["train"]
    basis = pod_basis(X, 3, lay, problem)
    s = train(problem, basis, X, 3e-2)
    assert len(s.cells) <= 0.6 * p["n_elements"]
    red, S, rom = reduced_run(problem, basis, p["dt"], p["t_end"], X[:, 0], s)
    e = errors(res, X, red, S, lay)
    assert e["balance_relative"] <= 1e-12
    assert abs(red.rows[-1]["supplied"]) > 0.1 * e["H_max"]
    assert rom.jacobians < rom.iterations      # the kept Jacobian


def test_no_energy_created_without_input(hooke):
    """From the deflected end of the training run with the load off (u = 0), H_w stays constant to 1e-12 while the
    beam swings: the hyper-reduced model creates no energy."""
    cases, lay = hooke
    _, _, X, p = cases["train"]
    problem = cases["train"][0]
    basis = pod_basis(X, 4, lay, problem)
    s = train(problem, basis, X, 3e-2)
    scene, q = resolve("cantilever-2d", {**BASE, "t_load": 0.0})
    free = build(scene, q, MPI.COMM_WORLD)
    res = run(HyperReducedSystem(free, basis, s, start=X[:, -1]), p["dt"], 0.05)
    H = res.column("H")
    assert H[0] > 1.0 and np.max(np.abs(H - H[0])) <= 1e-12 * H[0]
    assert np.max(np.abs(res.column("supplied"))) == 0.0
    assert np.ptp(res.column("tip_y")) > 1e-3


def test_error_stays_close_to_the_galerkin_model(hooke):
    """On the training input and on another one (another amplitude and a horizontal load the training never had),
    at r = 4 and the default tolerance: the hyper-reduced model's configuration error against the full model is at
    most 1.5 times that of the model without hyper-reduction plus 2e-3, and below 2e-2, with fewer cells than the
    mesh has; H_w stays within 1e-3 of max H of the full model's H at the same states."""
    cases, lay = hooke
    X = cases["train"][2]
    basis = pod_basis(X, 4, lay, cases["train"][0])
    s = train(cases["train"][0], basis, X)
    assert len(s.cells) < BASE["n_elements"]
    for name, (problem, res, Xc, p) in cases.items():
        red, S, _ = reduced_run(problem, basis, p["dt"], p["t_end"], Xc[:, 0], s)
        hyper = errors(res, Xc, red, S, lay)
        plain = errors(res, Xc, *reduced_run(problem, basis, p["dt"], p["t_end"], Xc[:, 0])[:2], lay)
        assert hyper["configuration"] <= 1.5 * plain["configuration"] + 2e-3, (name, hyper, plain)
        assert hyper["configuration"] < 2e-2 and hyper["balance_relative"] <= 1e-12
        assert energy_error(problem, red, S) < 1e-3     # H_w is close to H at the same states


def test_bad_input(hooke):
    """A tolerance outside (0, 1), a snapshot count < 1, a weight <= 0 are refused with one line naming them."""
    cases, lay = hooke
    problem, res, X, p = cases["train"]
    basis = pod_basis(X, 2, lay, problem)
    for tol in (-1e-3, 0.0, 1.0, float("nan")):
        with pytest.raises(ParameterError, match=r"--ecsw-tol must be a number in \(0, 1\)"):
            train(problem, basis, X, tol)
    with pytest.raises(ParameterError, match="snapshots must be an integer >= 1"):
        train(problem, basis, X, 1e-2, count=0)
    with pytest.raises(ParameterError, match="weights must be > 0"):
        HyperReducedSystem(problem, basis, Sample(np.array([0, 1]), np.array([1.0, -0.5]), 0, 0, 32, 0))


def test_cli_hyper_reduces_and_writes_the_sample(tmp_path, rodfem):
    """`rodfem reduce --nonlinear` (ECSW by default) writes per order the sample's cells and weights and the runs'
    errors, balance and timings; --hyper none gives the model without hyper-reduction."""
    import json
    sets = [a for k, v in BASE.items() for a in ("--set", f"{k}={v}")]
    p = rodfem("reduce", "cantilever-2d", "--nonlinear", "--order", "3", *sets, "--test", "fy=-50", "--ecsw-tol", "0.03",
               "--out", tmp_path / "e")
    assert p.returncode == 0, p.stderr[-2000:]
    info = json.loads((tmp_path / "e" / "nonlinear_reduce.json").read_text())
    o = info["orders"]["3"]
    assert info["hyper"] == "ecsw" and o["ecsw"]["tol"] == 0.03 and o["ecsw"]["fit_residual"] <= 0.03
    assert len(o["ecsw"]["cells"]) == len(o["ecsw"]["weights"]) == o["ecsw"]["sampled"] < 32
    assert min(o["ecsw"]["weights"]) > 0 and "/32" in p.stdout
    for name in ("train", "test"):
        assert o[name]["errors"]["balance_relative"] <= 1e-12 and o[name]["speed_up"] > 0
    p = rodfem("reduce", "cantilever-2d", "--nonlinear", "--order", "3", *sets, "--hyper", "none", "--out", tmp_path / "n")
    assert p.returncode == 0, p.stderr[-2000:]
    info = json.loads((tmp_path / "n" / "nonlinear_reduce.json").read_text())
    assert info["hyper"] == "none" and "ecsw" not in info["orders"]["3"]


@pytest.mark.parametrize("args, message", [
    (["--nonlinear", "--ecsw-tol", "-0.001"], "--ecsw-tol must be a number in (0, 1)"),
    (["--nonlinear", "--ecsw-tol", "1.5"], "--ecsw-tol must be a number in (0, 1)"),
    (["--hyper", "ecsw"], "--hyper and --ecsw-tol go with --nonlinear"),
])
def test_cli_bad_input_is_one_line(tmp_path, rodfem, args, message):
    p = rodfem("reduce", "cantilever-2d", "--set", "n_elements=4", "--set", "t_end=0.01", "--set", "degree=2", *args,
               "--out", tmp_path / "x")
    assert p.returncode == 2 and message in p.stderr and len(rodfem_lines(p.stderr)) == 1, p.stderr


def test_damped_scene_keeps_its_balance_with_dissipation():
    """Kelvin-Voigt (tau_kv = 2 ms) and Rayleigh (alpha = 5/s) damping: with the energy basis split by strain component
    the reduced model without and with ECSW keeps H_r(n+1) - H_r(n) + h d_n = h y.u to 1e-12 of max H, dissipates
    within 2 % of the full model's dissipated energy (9 % of the final H), and its error at r = 4 is below 1e-2.  The component
    positions of the layout are DOLFINx's sub-space dofs of each strain component."""
    cases, lay = trained({"tau_kv": 2e-3, "rayleigh_alpha": 5.0})
    problem, res, X, p = cases["train"]
    body = problem.body_items()[0][1]
    k = 0
    for name, _ in lay.field_slices["e"]:
        size = body.space.field(name).size
        for c in range(size):
            sub = body.space.sub(name).sub(c) if size > 1 else body.space.sub(name)
            dofs = np.sort(np.asarray(sub.collapse()[1], dtype=np.int64))
            assert np.array_equal(np.sort(lay.e[lay.components["e"][k]]), dofs), (name, c)
            k += 1
    assert k == len(lay.components["e"]) == 3      # Gamma_1, Gamma_2, kappa
    basis = pod_basis(X, 4, lay, problem)
    full_lost = res.column("dissipated")[-1]
    assert full_lost > 0.05 * res.column("H")[-1]
    s = train(problem, basis, X)
    for sample in (None, s):
        red, S, _ = reduced_run(problem, basis, p["dt"], p["t_end"], X[:, 0], sample)
        e = errors(res, X, red, S, lay)
        assert e["balance_relative"] <= 1e-12 and e["configuration"] < 1e-2
        assert red.column("dissipated")[-1] == pytest.approx(full_lost, rel=2e-2)
