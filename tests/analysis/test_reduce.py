"""Structure-preserving reduction of the linear PH model (rodfem/analysis/reduce.py, `rodfem reduce`):
port-Hamiltonian and passive by construction, interpolation at the points, error falling with the order,
the reduced frequencies against the full model's modes, a dissipating model, the files, bad input."""
import json

import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp
from processes import rodfem_lines

from rodfem.analysis.linearize import natural_modes
from rodfem.analysis.reduce import FullModel, frequency_error, interpolation_points, reduce, response
from rodfem.app.analyses import prepare
from rodfem.app.reduction import run_reduce
from rodfem.errors import ParameterError

CASES = {"cantilever-2d": {"fy": 0.0, "n_elements": 6}, "hanging-cable": {"n_elements": 6},
         "viscoelastic-cantilever-2d": {"fy": 0.0, "n_elements": 4}}


@pytest.fixture(scope="module", params=list(CASES))
def model(request):
    _, _, lin = prepare(request.param, CASES[request.param])
    omega, _, _ = natural_modes(lin, 8)
    return request.param, FullModel(lin.E, lin.J, lin.R, lin.Q, lin.B, lin.C), omega


def test_reduced_model_is_port_hamiltonian_and_passive(model):
    """J_r = -J_r^T exactly, R_r = R_r^T >= 0, Q_r = I, E_r^T Q_r = E_r symmetric positive definite (= I: the
    basis is orthonormal in the energy product), C_r = B_r^T; the eigenvalues of the reduced model lie in the
    closed left half plane (on the axis without dissipation)."""
    name, full, omega = model
    for r in (4, 8):
        red = reduce(full, r, interpolation_points(omega, r // 2))
        assert np.array_equal(red.J, -red.J.T) and np.array_equal(red.R, red.R.T)
        assert np.array_equal(red.Q, np.eye(r)) and np.array_equal(red.C, red.B.T)
        lowest = np.linalg.eigvalsh(red.R).min()
        assert lowest >= -1e-12 * max(np.abs(red.R).max(), 1.0)
        assert np.max(np.abs(red.E - np.eye(r))) <= 1e-10
        assert red.checks["passive"] and red.checks["J_dropped_symmetric_part"] <= 1e-12
        s = la.eigvals(red.A, red.E)
        assert np.max(s.real) <= 1e-9 * np.max(np.abs(s)), name
        if name.startswith("viscoelastic"):     # the dashpots: R_r > 0 somewhere, eigenvalues strictly damped
            assert np.abs(red.R).max() > 0 and np.max(s.real) < 0
        else:
            assert np.abs(red.R).max() <= 1e-12 * np.abs(red.J).max()


def test_transfer_functions_agree_at_the_interpolation_points(model):
    """G_r(s_j) b_j = G(s_j) b_j at every point and its conjugate, to 1e-8 (measured: 1e-12)."""
    _, full, omega = model
    for r in (4, 8):
        red = reduce(full, r, interpolation_points(omega, r // 2))
        for s, b in zip(red.points, red.directions):
            for z, d in ((s, b), (np.conj(s), np.conj(b))):
                g = full.transfer(z) @ d
                assert np.linalg.norm(red.transfer(z) @ d - g) <= 1e-8 * np.linalg.norm(g)
        s = red.points[0] + 0.37 * omega[0]      # not a point: no agreement there to that accuracy
        assert np.linalg.norm(red.transfer(s) - full.transfer(s)) > 1e-8 * np.linalg.norm(full.transfer(s))


def test_error_falls_with_the_order_and_frequencies_converge(model):
    """On a fixed grid (s = alpha + i omega, omega in [omega_1/10, omega_8]) the median pointwise error falls
    with r = 4, 8, 16 and the max error of r = 16 is below that of r = 4; the reduced model's first frequency
    matches the full model's first mode to 1e-3 (undamped: ever closer); r = 16 has the first 4 to 1e-3."""
    name, full, omega = model
    alpha = 0.05 * omega[0]
    grid = alpha + 1j * np.geomspace(omega[0] / 10, omega[7], 120)
    G = response(full, grid)
    medians, maxima, first = [], [], []
    for r in (4, 8, 16):
        red = reduce(full, r, interpolation_points(omega, r // 2))
        err, _, _ = frequency_error(G, response(red, grid))
        medians.append(err["median_pointwise"])
        maxima.append(err["max_relative"])
        f = red.frequencies()
        first.append(abs(f[0] / omega[0] - 1))
    assert medians[0] > medians[1] > medians[2], (name, medians)
    assert maxima[2] < maxima[0], (name, maxima)
    assert max(first) <= 1e-3, (name, first)
    if not name.startswith("viscoelastic"):    # (damped: 1.5e-5 at r = 4, 3.1e-5 at 8 and 16)
        assert first[2] <= first[0], (name, first)
    assert np.all(np.abs(f[:4] / omega[:4] - 1) <= 1e-3), (name, f[:4], omega[:4])


def test_cli_writes_the_reduced_models(tmp_path, rodfem):
    """`rodfem reduce` writes per order the matrices (the PH form again), V, reduced.mat, reduce.json and
    bode.png; the files hold what the Python API returns."""
    out = tmp_path / "red"
    p = rodfem("reduce", "cantilever-2d", "--set", "fy=0", "--set", "n_elements=6", "--order", "4", "8",
               "--out", out)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "passive" in p.stdout
    info = json.loads((out / "reduce.json").read_text())
    assert set(info["orders"]) == {"4", "8"} and (out / "bode.png").stat().st_size > 10000
    api = run_reduce("cantilever-2d", {"fy": 0.0, "n_elements": 6}, orders=(4, 8))
    for r in (4, 8):
        for k in "EJRQBC":
            M = sp.load_npz(out / f"r{r}" / f"{k}.npz").toarray()
            assert np.allclose(M, getattr(api["models"][r], k), rtol=1e-12, atol=1e-14 * np.abs(M).max()), (r, k)
        assert info["orders"][str(r)]["checks"]["passive"]
        assert info["orders"][str(r)]["interpolation_error"] <= 1e-8
    assert (out / "r8" / "V.npy").exists() and (out / "r8" / "reduced.mat").exists()


@pytest.mark.parametrize("args, message", [
    (["--order", "5"], "--order must be even"),
    (["--order", "0"], "--order must be even"),
    (["--order", "200"], "at most the full model's"),
    (["--alpha", "-1"], "--alpha must be a number > 0"),
])
def test_bad_input_is_one_line(tmp_path, rodfem, args, message):
    p = rodfem("reduce", "cantilever-2d", "--set", "n_elements=4", *args, "--out", tmp_path / "x")
    assert p.returncode == 2 and message in p.stderr and len(rodfem_lines(p.stderr)) == 1, p.stderr


def test_a_scene_without_inputs_is_refused():
    with pytest.raises(ParameterError, match="no input ports"):
        FullModel(sp.identity(2), sp.csr_matrix((2, 2)), sp.csr_matrix((2, 2)), sp.identity(2),
                  sp.csr_matrix((2, 0)), sp.csr_matrix((0, 2)))
