"""Materials of the 3D Cosserat rod (forms/rod_materials.py): complementary energies W*(N, M).

Per material: the discrete balance (exact with the discrete gradient, measurably not with the
midpoint rule for the non-quadratic laws), objectivity, a closed-form answer, and the linear law
bit for bit against the compliance form of before.  Small runs (4-16 elements): the machine is shared.
"""
import numpy as np
import pytest
import ufl
from mpi4py import MPI

from rodfem import Load, Problem, Support, run
from rodfem.demos import flying_spaghetti_3d, roll_up_3d, whirling_rod_3d
from rodfem.demos._rod3d import end_moment, straight
from rodfem.errors import ParameterError
from rodfem.fem.jit import compile_forms
from rodfem.forms import rod_materials
from rodfem.forms.cosserat_rod import RATES, CosseratRod

COMM = MPI.COMM_WORLD
NONQUADRATIC = ("stiffening", "asymmetric")
C = dict(C_N1=1e-3, C_N2=4e-3, C_N3=2e-3, C_M1=0.5, C_M2=1.0, C_M3=2.0)


def build(scene, **overrides):
    p = scene.values({k: str(v) for k, v in overrides.items()})
    return scene.build(p, COMM), p


def rel_balance(res):
    return res.max_balance_error / np.max(np.abs(res.column("H")))


# -- energy balance ---------------------------------------------------------------------------

# flying-spaghetti-3d (spatial variant: bending, torsion, stretch), 40 steps; kappa_lock = 0.5
# (the rod bends to |K| ~ 0.3: the stiffening law is well inside its nonlinear range), delta = 1 N
# (|N_1| ~ 10 N crosses the transition).  Measured with the discrete gradient: 3.0e-14 (linear),
# 6.1e-14 (stretch-twist), 3.0e-14 (stiffening), 3.9e-14 (asymmetric) of max|H|; with the
# midpoint rule: the same for the quadratic laws, 1.9e-5 (stiffening) and 2.5e-5 (asymmetric).
FS = dict(variant="spatial", n_elements=4, dt=0.1, t_end=4.0, kappa_lock=0.5, delta=1.0)


@pytest.mark.parametrize("material", list(rod_materials.MATERIALS))
def test_balance_is_exact_with_the_discrete_gradient(material):
    P, p = build(flying_spaghetti_3d.scene, material=material, integrator="discrete-gradient", **FS)
    res = run(P, p["dt"], p["t_end"])
    assert res.column("supplied")[-1] > 100.0
    assert rel_balance(res) <= 1e-12, rel_balance(res)


@pytest.mark.parametrize("material", NONQUADRATIC)
def test_midpoint_balance_is_not_exact_for_a_nonquadratic_law(material):
    """The midpoint rule's effort dW*(x_m) misses W*_{n+1} - W*_n by O(dN^3): a measurable balance
    error (while the quadratic laws keep round-off under both rules, first test)."""
    P, p = build(flying_spaghetti_3d.scene, material=material, integrator="midpoint", **FS)
    res = run(P, p["dt"], p["t_end"])
    assert rel_balance(res) >= 1e-7, rel_balance(res)


def test_zero_compliances_with_a_nonquadratic_law():
    """stiffening with C_N = 0 (inextensible, shear-rigid) in the whirling rod: the DG1 moments of
    Gamma stay zero (the weight-0 components of the discrete gradient keep gamma = 0: measured
    1e-17), the axial force is a real multiplier (int N_1^2 ds = 0.04), and the balance is exact (measured 5e-15)."""
    P, p = build(whirling_rod_3d.scene, material="stiffening", integrator="discrete-gradient", kappa_lock=1.0,
                 n_elements=4, t_end=0.5, C_N1=0.0, C_N2=0.0, C_N3=0.0)
    res = run(P, p["dt"], p["t_end"])
    assert rel_balance(res) <= 1e-12
    X = P.space.split(P.x0)
    s = ufl.SpatialCoordinate(P.mesh)[0]
    for i, d in enumerate(("d1", "d2", "d3")):
        G = ufl.inner(X[d], X["r"].dx(0)) - (1.0 if i == 0 else 0.0)
        for q in (1.0, s):
            assert abs(integral(P, G * q)) <= 1e-12
    assert integral(P, X["N"][0] ** 2) > 1e-3      # the axial force is a real multiplier (measured 0.04)


def integral(problem, expr):
    from dolfinx import fem
    return problem.comm.allreduce(fem.assemble_scalar(compile_forms({"f": expr * problem.dx})["f"]), op=MPI.SUM)


# -- the linear law is the compliance form of before ------------------------------------------

def test_linear_material_is_the_compliance_form_bit_for_bit():
    """CosseratRod(material=linear(...)) and CosseratRod(C_N, C_M): the same UFL residual and
    Hamiltonian (form signatures) and the same history to the last bit."""
    initial = straight((0, 0, 0), np.eye(3), omega=(1.0, 0.5, 2.0), velocity=(0.0, 0.3, 0.0))
    runs = []
    for rod in (CosseratRod(1.0, (0.02, 0.01, 0.01), (C["C_N1"], C["C_N2"], C["C_N3"]), (C["C_M1"], C["C_M2"], C["C_M3"])),
                CosseratRod(1.0, (0.02, 0.01, 0.01), material=rod_materials.linear(**C))):
        P = Problem(rod, 1.0, 4, initial=initial, comm=COMM)
        forms = P.forms()
        runs.append((forms["F"].signature(), forms["H"].signature(), run(P, 0.01, 0.2).rows))
    assert runs[0][0] == runs[1][0] and runs[0][1] == runs[1][1]
    assert runs[0][2] == runs[1][2]


# -- objectivity ------------------------------------------------------------------------------

def rotation(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


MATERIAL_OF = {"stretch-twist": lambda: rod_materials.stretch_twist(**C, C_NM=0.6 * np.sqrt(C["C_N1"] * C["C_M1"])),
               "stiffening": lambda: rod_materials.stiffening(**C, kappa_lock=1.0),
               "asymmetric": lambda: rod_materials.asymmetric(**C, C_N1c=4 * C["C_N1"], delta=0.5)}


@pytest.mark.parametrize("material", list(MATERIAL_OF))
def test_objectivity_under_a_superposed_rotation(material):
    """As tests/models/test_cosserat_rod.py: a deformed, moving free rod (10 steps from a non-rigid
    velocity) and the same state rotated by Q run 20 more steps; H, N, M (and gamma, kappa) agree,
    every vector of B is Q times A's.  Discrete gradient.  Measured <= 1e-14 of the scales."""
    vectors = ("r", "d1", "d2", "d3", "v", *RATES)
    E = np.eye(3)

    def director_rate(i):
        return lambda x: np.cross(np.vstack([3 * x[0], 1 + 0 * x[0], -2 * np.cos(np.pi * x[0])]).T, E[i]).T
    initial = {"r": lambda x: np.vstack([x[0] - 0.5, 0 * x[0], 0 * x[0]]),
               "v": lambda x: np.vstack([0.3 * np.cos(np.pi * x[0]), 2 * np.sin(np.pi * x[0]),
                                         -1.5 * (x[0] - 0.5) ** 2]),
               **{f"d{i + 1}": (lambda i: lambda x: np.outer(E[i], np.ones(x.shape[1])))(i) for i in range(3)},
               **{w: director_rate(i) for i, w in enumerate(RATES)}}

    def rod_problem():
        rod = CosseratRod(1.0, (0.03, 0.02, 0.01), material=MATERIAL_OF[material]())
        return Problem(rod, 1.0, 4, initial=initial, comm=MPI.COMM_SELF, integrator="discrete-gradient")

    A, B = rod_problem(), rod_problem()
    scalars = ("N", "M") + (("gamma", "kappa") if A.model.general else ())

    class History:
        def __init__(self):
            self.H, self.fields = [], []

        def record(self, row, problem):
            self.H.append(row["H"])
            self.fields.append({n: problem.space.nodal(problem.x0, n)[1].copy() for n in (*vectors, *scalars)})

    run(A, 0.01, 0.1)
    Q = rotation((1.0, 2.0, 3.0), 0.9)
    B.x0.x.array[:] = A.x0.x.array
    for n in vectors:
        _, dofs = B.space.collapse(n)
        B.x0.x.array[dofs] = (B.x0.x.array[dofs].reshape(-1, 3) @ Q.T).ravel()
    B.x1.x.array[:] = B.x0.x.array
    B.t = A.t
    hA, hB = History(), History()
    run(A, 0.01, 0.3, writer=hA)
    run(B, 0.01, 0.3, writer=hB)
    H_A, H_B = np.array(hA.H), np.array(hB.H)
    assert np.max(np.abs(H_A - H_B)) <= 1e-12 * np.max(H_A)
    for n in scalars:
        a, b = (np.array([f[n] for f in h.fields]) for h in (hA, hB))
        assert np.max(np.ptp(a, axis=0)) > 0.1 * np.max(np.abs(a))
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a)), n
    for n in vectors:
        a, b = (np.array([f[n] for f in h.fields]) for h in (hA, hB))
        assert np.max(np.abs(a @ Q.T - b)) <= 1e-12 * np.max(np.abs(a)), n


# -- closed-form answers ---------------------------------------------------------------------

def test_stiffening_roll_up_closes_the_circle():
    """roll-up-3d with material=stiffening (kappa_lock = 0.8/m, 2 pi/L = 0.63/m): the scene's moment is
    the closed form EI kappa / sqrt(1 - kappa^2/kappa_lock^2) = 1.62 x the linear one (to 1e-12),
    and the rod closes the circle: tip error falls with order ~4 from 8 to 16 elements (measured
    2.28e-2, 1.44e-3: order 3.98; balance 1.1e-14 of max|H|)."""
    errors = []
    for n in (8, 16):
        P, p = build(roll_up_3d.scene, material="stiffening", integrator="discrete-gradient", n_elements=n)
        res = run(P, p["dt"], p["t_end"])
        tip = res.rows[-1]
        errors.append(np.linalg.norm([tip[f"tip_{c}"] for c in "xyz"]))
        assert rel_balance(res) <= 1e-12
    EI, kappa = 1.0 / p["C_M3"], 2 * np.pi / p["L"]
    closed = EI * kappa / np.sqrt(1 - (kappa / p["kappa_lock"]) ** 2)
    assert abs(roll_up_3d.closing_moment(p) - closed) <= 1e-12 * closed
    order = np.log2(errors[0] / errors[1])
    assert errors[1] <= 2e-3 and 3.7 <= order <= 4.3, (errors, order)


def tip_state(P):
    """Tip position and tip directors of x_n (serial: the last node)."""
    s, r = P.space.nodal(P.x0, "r")
    k = int(np.argmax(s))
    return r[k], [P.space.nodal(P.x0, d)[1][k] for d in ("d1", "d2", "d3")]


def straight_rod_static(material, force, torque, n=4):
    """A straight unit rod along x, clamped at 0, under an end force (x) and a body torque about d1:
    the static equilibrium of the discrete model (rodfem/analysis/statics.py: no load-step error);
    tip stretch, tip twist angle, tip position and directors."""
    from rodfem.analysis.statics import Statics
    rod = CosseratRod(0.0, (0.0, 0.0, 0.0), material=material)
    loads = [Load("v", [force, 0.0, 0.0], "right", "tip force"), end_moment([torque, 0.0, 0.0], "body")]
    P = Problem(rod, 1.0, n, loads=loads, supports=[Support("left", "clamped")],
                initial=straight((0, 0, 0), np.eye(3)), comm=MPI.COMM_SELF)
    Statics(P).solve(t=0.0, steps=4)
    r, d = tip_state(P)
    return r[0] - 1.0, np.arctan2(d[1][2], d[1][1]), r, d


def test_stretch_twist_against_its_two_by_two_solve():
    """Coupled law, end force F = 2 and end torque T = -0.3 on a straight unit rod (static
    equilibrium): the strains are the 2 x 2 solve [gamma_1, kappa_1] = [[C_N1, C_NM], [C_NM, C_M1]]
    [F, T], uniform, so the tip moves by gamma_1 along the axis and turns by kappa_1 about it.  A
    uniform twist is no polynomial in the directors, so both carry the P2 error: measured 1.1e-8
    (stretch) and 1.0e-8 (angle) relative at 4 elements, 6.9e-10 and 6.6e-10 at 8 (order 4).
    The coupling is real: without it the stretch would have the other sign (+0.002 vs -0.0034)."""
    C_NM = 0.8 * np.sqrt(C["C_N1"] * C["C_M1"])
    F, T = 2.0, -0.3
    gamma, kappa = np.array([[C["C_N1"], C_NM], [C_NM, C["C_M1"]]]) @ [F, T]
    errors = []
    for n in (4, 8):
        stretch, angle, r, d = straight_rod_static(rod_materials.stretch_twist(**C, C_NM=C_NM), F, T, n=n)
        errors.append((abs(stretch - gamma) / abs(gamma), abs(angle - kappa) / abs(kappa)))
        assert np.max(np.abs(r[1:])) <= 1e-12 and abs(d[0][0] - 1.0) <= 1e-12   # the axis stays e1
    assert max(errors[0]) <= 3e-8 and max(errors[1]) <= 3e-9, errors
    assert all(np.log2(a / b) >= 3.5 for a, b in zip(*errors)), errors
    assert gamma * C["C_N1"] * F < 0


@pytest.mark.parametrize("force", [3.0, -3.0], ids=["tension", "compression"])
def test_asymmetric_axial_law_in_tension_and_compression(force):
    """Asymmetric law (C_N1 in tension, 4 C_N1 in compression, delta = 0.5): a straight rod under an
    end force +-3 stretches by the closed form gamma_1 = C_N1c N + (C_N1 - C_N1c) rho(N) (uniform
    strain: exact in P2, measured 1e-16 relative); compression shortens it 3.3 x more than tension."""
    m = rod_materials.asymmetric(**C, C_N1c=4 * C["C_N1"], delta=0.5)
    stretch, _, _, _ = straight_rod_static(m, force, 0.0)
    rho = (force + np.sqrt(force ** 2 + 0.25) - 0.5) / 2
    exact = 4 * C["C_N1"] * force + (C["C_N1"] - 4 * C["C_N1"]) * rho
    assert abs(stretch - exact) <= 1e-10 * abs(exact), (stretch, exact)
    assert abs(m.strains([force, 0, 0, 0, 0, 0])[0] - exact) <= 1e-14
    tension, compression = (abs(m.strains([f, 0, 0, 0, 0, 0])[0]) for f in (3.0, -3.0))
    assert compression > 3 * tension


# -- parameters ---------------------------------------------------------------------------------

def test_bad_material_parameters_one_line_errors():
    with pytest.raises(ParameterError, match="C_NM") as e:
        build(whirling_rod_3d.scene, material="stretch-twist", coupling=1.0)
    assert "\n" not in str(e.value)
    with pytest.raises(ParameterError, match="kappa_lock") as e:
        build(roll_up_3d.scene, material="stiffening", kappa_lock=0.5)
    assert "\n" not in str(e.value)
    with pytest.raises(ParameterError, match="C_M3") as e:
        build(whirling_rod_3d.scene, material="stiffening", C_M3=0.0)
    assert "\n" not in str(e.value)
    with pytest.raises(ValueError, match="delta must be a positive number"):
        rod_materials.asymmetric(**C, C_N1c=1.0, delta=0.0)
    with pytest.raises(ValueError, match="either"):
        CosseratRod(1.0, (0.02, 0.01, 0.01), (1, 1, 1), (1, 1, 1), material=rod_materials.linear(**C))


def test_small_strain_compliances_and_numerical_legendre():
    """Each law's Hessian at 0 is the documented small-strain compliance; `stresses` inverts `strains`."""
    m = MATERIAL_OF
    st, sf, asy = m["stretch-twist"](), m["stiffening"](), m["asymmetric"]()
    C0 = np.diag([C[k] for k in rod_materials.COMPLIANCES])
    assert np.allclose(sf.compliance(), C0, rtol=1e-14, atol=0)
    coupled = C0.copy()
    coupled[0, 3] = coupled[3, 0] = 0.6 * np.sqrt(C["C_N1"] * C["C_M1"])
    assert np.allclose(st.compliance(), coupled, rtol=1e-14, atol=0)
    assert np.isclose(asy.compliance()[0, 0], 2.5 * C["C_N1"], rtol=1e-14)
    X = np.array([0.5, -0.2, 0.1, 0.3, -0.4, 0.25])
    for mat in (st, sf, asy):
        assert np.allclose(mat.stresses(mat.strains(X)), X, rtol=0, atol=1e-12)


# -- serial vs 2 ranks ------------------------------------------------------------------------------

# serial vs 2 ranks with a non-quadratic law: tests/models/test_cosserat_rod.py::test_serial_and_two_ranks_agree
