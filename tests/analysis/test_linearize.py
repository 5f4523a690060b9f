"""The linearized PH model (rodfem/analysis/linearize.py): structure, frequencies against the analytic ones,
the response to a small input against the nonlinear model, the exported files, bad input."""
import csv
import json

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp
from mpi4py import MPI
from processes import rodfem_lines

from rodfem import run
from rodfem.analysis.linearize import Linearization, natural_modes
from rodfem.app.analyses import prepare
from rodfem.app.scene import load

J0_ZEROS = np.array([2.404825557695773, 5.520078110286311, 8.653727912911013])   # zeros of the Bessel J0
BETA_L = np.array([1.8751040687119611, 4.6940911329741745, 7.8547574382376126])  # cantilever cos(bL)cosh(bL) = -1

# A slender steel strip whose Timoshenko frequencies equal the Euler-Bernoulli ones to < 1e-6
# (rotary inertia 1e-9 of rhoA L^2, shear stiffness 6e6 EI / L^2): the error left is the mesh's.
SLENDER = {"fy": 0.0, "rhoI": 1e-9, "GA": 1e9}


def cantilever_frequencies(n, solver="auto", **extra):
    _, p, lin = prepare("cantilever-2d", {"n_elements": n, **SLENDER, **extra})
    omega, _, used = natural_modes(lin, 3, solver)
    exact = BETA_L**2 * np.sqrt(p["EI"] / (p["rhoA"] * p["L"] ** 4))
    return omega, exact, used


def test_cantilever_frequencies_converge_to_euler_bernoulli():
    """Relative errors of the first three bending frequencies: O(h^2) (ratio 4 from 16 to 32
    elements: 1.2e-4, 2.4e-3, 6.9e-3 at 32), and the Richardson extrapolation (4 w_32 - w_16)/3
    meets the analytic values to 1e-7, 2e-5, 1.3e-4 (its O(h^4) remainder)."""
    w16, exact, _ = cantilever_frequencies(16)
    w32, _, _ = cantilever_frequencies(32)
    e16, e32 = np.abs(w16 / exact - 1), np.abs(w32 / exact - 1)
    assert np.all(e32 <= [2e-4, 3e-3, 8e-3]), e32
    assert np.all(e16 / e32 >= 3.8) and np.all(e16 / e32 <= 4.2), (e16, e32)
    extrapolated = np.abs((4 * w32 - w16) / 3 / exact - 1)
    assert np.all(extrapolated <= [1e-6, 3e-5, 3e-4]), extrapolated


def test_slepc_and_dense_agree():
    pytest.importorskip("slepc4py")
    w_dense, _, used_d = cantilever_frequencies(12, "dense")
    w_slepc, _, used_s = cantilever_frequencies(12, "slepc")
    assert (used_d, used_s) == ("dense", "slepc")
    assert np.max(np.abs(w_slepc / w_dense - 1)) <= 1e-9


def hanging_chain(n):
    """The hanging cable (nearly inextensible, EA = 1e6) about its static equilibrium under gravity."""
    _, p, lin = prepare("hanging-cable", {"n_elements": n, "angle": 0.0, "EA": 1e6, "material": "kirchhoff"})
    omega, _, _ = natural_modes(lin, 6)
    exact = J0_ZEROS / 2 * np.sqrt(p["g"] / p["L"])
    return omega, exact, lin


def test_hanging_chain_bessel_frequencies():
    """omega_k = j_0,k / 2 sqrt(g / L) (each twice: swinging in x and in y); O(h^2), 1e-3 at 40."""
    w20, exact, _ = hanging_chain(20)
    w40, _, lin = hanging_chain(40)
    assert np.allclose(w40[0::2], w40[1::2], rtol=1e-9)          # the pairs
    e20, e40 = np.abs(w20[0::2] / exact - 1), np.abs(w40[0::2] / exact - 1)
    assert np.all(e40 <= [1e-4, 1e-3, 4e-3]), e40
    assert np.all(e20 / e40 >= 3.0), (e20, e40)
    # pre-stressed: the geometric stiffness (the tension) is in Q and E^T Q stays symmetric
    assert lin.checks["ph_residual"] <= 1e-12 and lin.checks["EtQ_asymmetry"] <= 1e-10


@pytest.mark.parametrize("scene, extra", [
    ("cantilever-2d", {"n_elements": 4, "fy": 0.0}),
    ("hanging-cable", {"n_elements": 4, "angle": 0.0}),
    ("roll-up-3d", {"n_elements": 2, "rhoA": 1.0, "rhoJ1": 0.02, "rhoJ2": 0.01, "rhoJ3": 0.01}),
])
def test_port_hamiltonian_structure(scene, extra):
    """J = -J^T, R = 0 (no dissipation), E^T Q = Q^T E >= 0, A = (J - R) Q, C = B^T Q; the
    3D rod's constraints make E singular (a DAE).  (E^T Q >= 0 holds about unstressed states and
    states in tension; a bending or compressive pre-stress makes the geometric-stiffness block
    indefinite.)"""
    _, _, lin = prepare(scene, extra)
    J, Q, E = lin.J, lin.Q, lin.E
    scale = abs(lin.A).max()
    assert abs(J + J.T).max() <= 1e-14 * scale
    assert lin.checks["R_norm"] <= 1e-12
    assert lin.checks["ph_residual"] <= 1e-12
    assert lin.checks["output_map_residual"] <= 1e-12
    EQ = (E.T @ Q).toarray()
    assert np.max(np.abs(EQ - EQ.T)) <= 1e-10 * np.max(np.abs(EQ))
    assert np.min(np.linalg.eigvalsh(0.5 * (EQ + EQ.T))) >= -1e-9 * np.max(np.abs(EQ))
    if scene == "roll-up-3d":
        assert np.linalg.matrix_rank(E.toarray()) < E.shape[0]      # multipliers: singular E


def test_linear_response_matches_the_nonlinear_one_to_second_order():
    """A sudden small tip force eps on the cantilever: the midpoint steps of the linear model
    E dx' = A dx + B du and the nonlinear run differ by O(eps^2) (ratio 4 when eps doubles)."""
    scene = load("cantilever-2d")
    base = {"n_elements": 4, "fy": 0.0, "dt": 1e-3, "t_end": 0.02, "t_load": 1.0}
    _, _, lin = prepare(scene, base, about="initial")
    x_star = lin.X.x.array[lin.free].copy()
    col = lin.inputs.index("tip force[1]")
    h = base["dt"]
    Ed, Ad = lin.E.toarray(), lin.A.toarray()
    lhs, rhs = Ed / h - 0.5 * Ad, Ed / h + 0.5 * Ad
    diffs = []
    for eps in (1e-2, 2e-2):
        problem = scene.build(scene.values({**base, "fy": eps}), MPI.COMM_WORLD)
        run(problem, base["dt"], base["t_end"])
        nonlinear = problem.x0.x.array[lin.free] - x_star
        x = np.zeros(len(x_star))
        for _ in range(20):
            x = np.linalg.solve(lhs, rhs @ x + lin.B.toarray()[:, col] * eps)
        diffs.append(np.max(np.abs(nonlinear - x)) / np.max(np.abs(x)))
    assert diffs[0] <= 1e-3, diffs
    assert 1.7 <= diffs[1] / diffs[0] <= 2.3, diffs     # relative error O(eps): absolute O(eps^2)


def test_cli_linearize_and_modes_write_files(tmp_path, rodfem):
    out = tmp_path / "lin"
    p = rodfem("linearize", "cantilever-2d", "--set", "n_elements=4", "--out", str(out))
    assert p.returncode == 0, p.stderr
    info = json.loads((out / "linear.json").read_text())
    n = info["n_states"]
    assert n == 4 * 9   # 4 free nodes x (r, phi, v, omega) + 4 cells x (Gamma, kappa)
    for name in ("E", "J", "R", "Q", "A", "Hess"):
        assert sp.load_npz(out / f"{name}.npz").shape == (n, n)
    assert sp.load_npz(out / "B.npz").shape == (n, 2) and sp.load_npz(out / "C.npz").shape == (2, n)
    mat = scipy.io.loadmat(out / "linear.mat")
    assert mat["E"].shape == (n, n) and mat["B"].shape == (n, 2) and mat["state_s"].size == n
    with open(out / "states.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == n and {r["field"] for r in rows} == {"r", "phi", "v", "omega", "Gamma", "kappa"}
    m = tmp_path / "modes"
    p = rodfem("modes", "cantilever-2d", "--set", "n_elements=8", "--count", "3", "--out", str(m))
    assert p.returncode == 0, p.stderr
    assert len((m / "modes.csv").read_text().splitlines()) == 4 and (m / "modes.png").stat().st_size > 1000


@pytest.mark.parametrize("args, np_, words", [
    (["modes", "cantilever-2d", "--count", "0"], None, ["--count"]),
    pytest.param(["modes", "cantilever-2d"], 2, ["one process"], marks=pytest.mark.mpi),
])
def test_bad_input_one_line(rodfem, args, np_, words):
    p = rodfem(*args, np=np_)
    assert p.returncode == 2, p.stderr
    lines = rodfem_lines(p.stderr)
    assert len(lines) == 1 and all(w in lines[0] for w in words), p.stderr


def test_system_of_two_welded_beams_has_the_modes_of_one_beam():
    """A cantilever of two beams (4 + 4 elements) welded by a planar rigid joint: the joint's three
    multipliers are states (E = 0 rows), the frequencies equal those of one beam of 8 elements."""
    from rodfem import Support, System
    from rodfem.forms import joints
    from rodfem.forms.planar_beam import PlanarBeam, quadratic, straight
    beam = PlanarBeam(0.785, 1e-9, quadratic(EA=2.1e7, GA=1e9, EI=175.0))
    system = System()
    a = system.add("a", beam, n_elements=4, supports=[Support("left", "clamped")], shape=straight((0, 0), (0.5, 0)))
    b = system.add("b", beam, n_elements=4, shape=straight((0.5, 0), (1.0, 0)))
    system.join(joints.planar_rigid, a.end, b.start, name="weld")
    lin = Linearization(system)
    w_sys, _, _ = natural_modes(lin, 3, "dense")
    assert sum(1 for st in lin.states if st[0] == "joints.lambda") == 3
    assert lin.checks["ph_residual"] <= 1e-12 and lin.checks["R_norm"] <= 1e-12
    assert abs(lin.J + lin.J.T).max() <= 1e-14 * abs(lin.A).max()
    _, _, one = prepare("cantilever-2d", {"n_elements": 8, **SLENDER})
    w_one, _, _ = natural_modes(one, 3, "dense")
    assert np.max(np.abs(w_sys / w_one - 1)) <= 1e-9, (w_sys, w_one)


def test_viscoelastic_modes_follow_the_standard_linear_solid():
    """A Maxwell branch with 0.1 of every stiffness: the stiffness becomes K (1 + 0.1 s tau/(1 + s tau)),
    so each eigenvalue solves tau s^3 + s^2 + 1.1 tau w0^2 s + w0^2 = 0 with w0 the elastic frequency
    of the same mesh; R (the dashpots) is symmetric, >= 0 and nonzero."""
    base = {"n_elements": 6, "fy": 0.0}
    _, p, lin = prepare("viscoelastic-cantilever-2d", base)
    w, _, _ = natural_modes(lin, 3)
    s = -lin.damping * w / np.sqrt(1 - lin.damping**2) + 1j * w
    _, _, elastic = prepare("viscoelastic-cantilever-2d", {**base, "EA1": 0.0, "GA1": 0.0, "EI1": 0.0})
    w0, _, _ = natural_modes(elastic, 3)
    tau = p["tau1"]
    for sk, w0k in zip(s, w0):
        roots = np.roots([tau, 1.0, 1.1 * tau * w0k**2, w0k**2])
        exact = roots[np.argmax(roots.imag)]
        assert abs(sk - exact) <= 1e-8 * abs(exact), (sk, exact)
    assert np.all(lin.damping > 1e-4)
    R = lin.R.toarray()
    assert np.max(np.abs(R - R.T)) <= 1e-14 * np.max(np.abs(R)) and np.max(np.abs(R)) > 0
    assert np.min(np.linalg.eigvalsh(R)) >= -1e-12 * np.max(np.abs(R))
    assert lin.checks["ph_residual"] <= 1e-12


# -- SLEPc on constrained and dissipating pencils (rodfem/la/pencil.py) -------------------------

def both_solvers(lin, k=6):
    """(s_dense, s_slepc, solver SLEPc's call reports) of the same Linearization: s = -zeta|s| + i omega."""
    out, used = [], None
    for solver in ("dense", "slepc"):
        omega, _, used = natural_modes(lin, k, solver)
        out.append(-lin.damping * omega / np.sqrt(1 - lin.damping**2) + 1j * omega)
    return out[0], out[1], used


@pytest.mark.parametrize("scene, about, extra", [
    ("four-bar-2d", "initial", {"n_elements": 6}),                     # 4 joint multipliers, a double zero
    ("viscoelastic-cantilever-2d", "static", {"n_elements": 10}),     # 30-fold relaxation -45.5 below omega_1 = 54
    ("viscoelastic-cantilever-2d", "static", {"n_elements": 64}),     # 192-fold
    ("viscoelastic-cantilever-3d", "static", {"n_elements": 4}),      # orthonormality multipliers, double modes
])
def test_slepc_equals_dense_on_constrained_and_dissipating_models(scene, about, extra):
    """Before: SLEPc found 4 of 6 wrong, undamped-made-damped modes of the four-bar, 0 of the 2D
    and 2 of the 3D viscoelastic cantilever; now its verified modes are the dense solver's to
    1e-8 of |s| (frequencies relative, damping ratios absolute), with no fallback."""
    pytest.importorskip("slepc4py")
    _, _, lin = prepare(scene, extra, about=about)
    dense, slepc, used = both_solvers(lin)
    assert used == "slepc" and len(dense) == len(slepc) == 6, (dense, slepc)
    assert np.max(np.abs(slepc - dense) / np.abs(dense)) <= 1e-8, (dense, slepc)
    assert lin.modes_info["fallback"] is None and max(lin.modes_info["residuals"]) <= 1e-10


def test_viscoelastic_3d_first_mode_is_the_cantilevers():
    """The dense filter Im s > 1e-9 max|Im s| dropped every mode below 65 rad/s (max |Im s| ~ 6.5e10:
    the infinite eigenvalues' roundoff) and gave 116 rad/s, the second bending frequency, as the
    first.  Euler-Bernoulli: 1.875^2 sqrt(EI / (rhoA L^4)) = 17.7 rad/s, twice (two bending planes),
    stiffened by the Maxwell branch."""
    _, p, lin = prepare("viscoelastic-cantilever-3d", {"n_elements": 8})
    omega, _, _ = natural_modes(lin, 4, "dense")
    r = p["radius"]
    exact = BETA_L[0] ** 2 * np.sqrt(p["E"] * np.pi * r**4 / 4 / (p["rho"] * np.pi * r**2 * p["L"] ** 4))
    assert np.allclose(omega[0], omega[1], rtol=1e-9) and 1.0 < omega[0] / exact < 1.05, (omega, exact)
    assert 6.0 < omega[2] / omega[0] < 6.6                      # the second bending mode, 6.27 x


def test_slider_crank_has_no_mode_and_slepc_says_so():
    """The rigid slider crank about its initial state: a double zero and 105 infinite eigenvalues, no
    oscillation.  SLEPc's pairs are roundoff images of the infinite ones (|s| ~ 1e5-1e7): the
    row-wise residual rejects them all, the dense fallback finds no mode."""
    pytest.importorskip("slepc4py")
    from rodfem.la.pencil import NotVerified, Pencil, slepc_modes
    _, _, lin = prepare("slider-crank-3d", {}, about="initial")
    with pytest.raises(NotVerified, match="fail the residual check"):
        slepc_modes(Pencil(lin.Am, lin.Em), 6)
    omega, _, used = natural_modes(lin, 6, "slepc")
    assert len(omega) == 0 and used == "dense" and lin.modes_info["fallback"]
    assert lin.modes_info["finite_eigenvalues"] == 2 == lin.modes_info["real_eigenvalues"]


def test_unverified_slepc_result_above_the_fallback_size_is_refused(monkeypatch):
    pytest.importorskip("slepc4py")
    import rodfem.analysis.linearize as linearize
    from rodfem.errors import ParameterError
    _, _, lin = prepare("slider-crank-3d", {}, about="initial")
    monkeypatch.setattr(linearize, "DENSE_FALLBACK_MAX", 100)
    with pytest.raises(ParameterError, match="not verified .* 107 states are more than the dense fallback takes"):
        natural_modes(lin, 6, "slepc")


def one_error_line(p):
    lines = rodfem_lines(p.stderr)
    assert p.returncode == 2 and len(lines) == 1 and lines[0].startswith("rodfem: error: "), p.stderr
    return lines[0]


@pytest.mark.parametrize("solver", ["auto", "slepc"])
def test_cli_refuses_a_model_without_modes(tmp_path, rodfem, solver):
    """Before: exit 0, '0 modes', and 'results in ...: modes.csv, modes.json, modes.png,
    mode_shapes.npz' of which the last two did not exist (and with --solver slepc a petsc4py
    traceback: zero pivot)."""
    out = tmp_path / "sc"
    line = one_error_line(rodfem("modes", "slider-crank-3d", "--about", "initial", "--solver", solver, "--out", out))
    assert "no oscillating mode" in line and "2 finite eigenvalues: 2 real" in line
    assert not list(out.glob("mode*"))                      # no modes written; the record says why
    assert json.loads((out / "summary.json").read_text())["status"] == "error"


def test_cli_slepc_modes_of_the_relaxation_cluster(tmp_path, rodfem):
    """viscoelastic-cantilever-2d at 64 elements: SLEPc reported 0 modes with exit 0 (a 192-fold
    eigenvalue -45.5 nearer to 0 than omega_1 = 53.9); now the dense solver's modes, every file
    it names written."""
    from processes import ok
    out = tmp_path / "m"
    p = ok(rodfem("modes", "viscoelastic-cantilever-2d", "--set", "n_elements=64", "--solver", "slepc", "--out", out))
    info = json.loads((out / "modes.json").read_text())
    assert info["solver"] == "slepc" and len(info["omega_rad_s"]) == 6 and info["fallback"] is None
    _, _, lin = prepare("viscoelastic-cantilever-2d", {"n_elements": 64})
    omega, _, _ = natural_modes(lin, 6, "dense")
    assert np.allclose(info["omega_rad_s"], omega, rtol=1e-8, atol=0)
    assert np.allclose(info["damping_ratio"], lin.damping, rtol=0, atol=1e-8)
    named = rodfem_lines(p.stdout)[-1].split(": ", 1)[1].split(", ")
    assert named == ["modes.csv", "modes.json", "modes.png", "mode_shapes.npz", "summary.json"]
    assert info["files"] == named[:4]        # (modes.json is written before the summary)
    assert all((out / f).stat().st_size > 0 for f in named)


@pytest.mark.parametrize("command, time", [
    ("linearize", "nan"), ("modes", "nan"), ("modes", "inf"), ("static", "nan"), ("static", "-inf")])
def test_cli_refuses_a_time_that_is_not_finite(tmp_path, rodfem, command, time):
    """Before: linearize --time nan exited 0 and wrote "t": NaN (not JSON), static exited 0
    (cantilever) or 3 (roll-up: Newton on a NaN load)."""
    scene = "roll-up-2d" if command == "static" else "cantilever-2d"
    out = tmp_path / "out"
    line = one_error_line(rodfem(command, scene, "--set", "n_elements=2", f"--time={time}", "--out", out))
    assert line == f"rodfem: error: --time must be a finite number (got {time})"
    assert not out.exists()
