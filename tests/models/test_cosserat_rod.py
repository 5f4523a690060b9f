"""3D port-Hamiltonian Cosserat rod (forms/cosserat_rod.py): structure preservation, constraints, exact solutions.

Every run is small (4-16 elements): the machine is shared.
"""

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI
from processes import serial_and_parallel

from rodfem import run
from rodfem.demos import flying_spaghetti_3d, helix_3d, roll_up_3d, whirling_rod_3d
from rodfem.demos._rod3d import orthonormality_error
from rodfem.errors import ParameterError
from rodfem.fem.jit import compile_forms
from rodfem.forms.cosserat_rod import director_masses

COMM = MPI.COMM_WORLD


def build(scene, **overrides):
    p = scene.values(overrides)
    return scene.build(p, COMM), p


class Recorder:
    """Per-step checks (the time loop calls record(row, problem) after every step)."""

    def __init__(self):
        self.orth = []

    def record(self, row, problem):
        self.orth.append(orthonormality_error(problem))


def integral(problem, expr):
    return problem.comm.allreduce(fem.assemble_scalar(compile_forms({"f": expr * problem.dx})["f"]), op=MPI.SUM)


def tip_error(row, ref):
    return np.linalg.norm([row[f"tip_{c}"] - ref[f"tip_{c}"] for c in "xyz"])


def strain_moments(problem):
    """The DG1 moments int Gamma_i q ds (q = 1, s) of the strains Gamma_i = d_i . r' - delta_i1 of x_n."""
    X = problem.space.split(problem.x0)
    s = ufl.SpatialCoordinate(problem.mesh)[0]
    Gamma = [ufl.inner(X[d], X["r"].dx(0)) - (1.0 if i == 0 else 0.0) for i, d in enumerate(("d1", "d2", "d3"))]
    return np.array([[integral(problem, G * q) for q in (1.0, s)] for G in Gamma])


# -- free rod: energy, momenta, orthonormality ---------------------------------------

def test_free_rod_conserves_energy_momenta_and_orthonormality():
    """Whirling rod about a non-principal axis, 500 steps with no load: H and L stay constant, p = 0, and
    d_i.d_j = delta_ij holds at the nodes.  Measured drifts: H 6.8e-15 H_0, L 2.0e-15 |L|, p 8e-16;
    the bounds (1e-11) leave room for round-off on other machines, far below any scheme error."""
    P, p = build(whirling_rod_3d.scene, n_elements=4, dt=0.01, t_end=5.0)
    rec = Recorder()
    res = run(P, p["dt"], p["t_end"], writer=rec)
    assert res.steps == 500
    H = res.column("H")
    assert np.max(np.abs(H - H[0])) <= 1e-11 * H[0]
    L = np.column_stack([res.column(f"L_{c}") for c in "xyz"])
    assert np.linalg.norm(L[0]) > 0.1 and abs(L[0, 0]) > 0 and abs(L[0, 2]) > 0   # tilted spin: two components
    assert np.max(np.abs(L - L[0])) <= 1e-11 * np.linalg.norm(L[0])
    pm = np.column_stack([res.column(f"p_{c}") for c in "xyz"])
    assert np.max(np.abs(pm)) <= 1e-12
    assert max(rec.orth) <= 1e-10
    # not a trivial rigid motion: the rod deforms (stress resultants build up, the tip leaves the x-axis plane)
    N = P.space.split(P.x0)["N"]
    assert integral(P, ufl.inner(N, N)) > 1e-4
    assert np.ptp(res.column("tip_y")) > 0.1


def test_spin_about_the_axis_is_strain_free():
    """A straight rod spinning about its own axis is an exact rigid motion: N = M = 0 for all time.

    (A weak check of objectivity only: every strain rate vanishes here in ANY formulation, since
    v = 0 and the directors are uniform; test_objectivity_under_a_superposed_rotation is the real one.)

    Full Newton here (the scenes' chord Newton converges linearly at 1 rad per step and stops
    at ~1e-11), so that the balance is checked at the level of quadratic convergence.
    """
    from petsc4py import PETSc
    PETSc.Options()["rodfem_snes_lag_jacobian"] = 1
    try:
        P, p = build(whirling_rod_3d.scene, n_elements=4, dt=0.05, t_end=5.0, tilt=0.0, Omega0=20.0)
    finally:
        PETSc.Options().delValue("rodfem_snes_lag_jacobian")
    res = run(P, p["dt"], p["t_end"])
    X = P.space.split(P.x0)
    assert integral(P, ufl.inner(X["N"], X["N"]) + ufl.inner(X["M"], X["M"])) < 1e-18
    # the directors did turn: d2 left its initial direction e2
    d2 = P.space.nodal(P.x0, "d2")[1]
    assert np.max(np.abs(d2[:, 1] - 1.0)) > 0.5
    assert res.max_balance_error <= 1e-12


def test_energy_balance_with_inputs():
    """Flying spaghetti (torsional variant): H_{n+1} - H_n = h y.u per step; H, L conserved after the load.

    Measured: balance 2.9e-14 max|H|, ptp of H after the load 3.8e-14 max|H|, of L_i 2.6e-14 |L|.
    Bounds 1e-11 (round-off); the port output y taken at x_{n+1} instead of x_{n+1/2} gives 2.2e-2."""
    P, p = build(flying_spaghetti_3d.scene, n_elements=4, dt=0.1, t_end=4.0, variant="spatial", Fz=2.0)
    rec = Recorder()
    res = run(P, p["dt"], p["t_end"], writer=rec)
    H = res.column("H")
    assert res.column("supplied")[-1] > 100.0          # the ports did work
    assert res.max_balance_error <= 1e-11 * np.max(np.abs(H))
    assert max(rec.orth) <= 1e-10
    after = res.column("t") > p["t_load"] + p["dt"]
    assert np.ptp(H[after]) <= 1e-11 * np.max(H)
    L = np.column_stack([res.column(f"L_{c}")[after] for c in "xyz"])
    assert np.linalg.norm(L[-1]) > 10.0
    assert np.max(np.ptp(L, axis=0)) <= 1e-11 * np.linalg.norm(L[-1])
    assert np.ptp(res.column("tip_z")) > 0.1            # it left the plane


def test_planar_variant_stays_planar():
    P, p = build(flying_spaghetti_3d.scene, n_elements=4, dt=0.1, t_end=3.0)
    res = run(P, p["dt"], p["t_end"])
    assert np.max(np.abs(res.column("tip_z"))) < 1e-12
    assert np.max(np.abs(res.column("L_x"))) < 1e-12 and abs(res.column("L_z")[-1]) > 10


# -- objectivity -----------------------------------------------------------------------------

def rotation(axis, angle):
    """The rotation by `angle` about `axis` (Rodrigues)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def test_objectivity_under_a_superposed_rotation():
    """A deformed, moving free rod and the same rod rotated rigidly by Q: the motions must agree.

    Rod A starts straight with a non-rigid velocity (bending, stretching and twisting rates) and runs
    10 steps, so that it is deformed and moving (|N| ~ 5, |M| ~ 0.5).  Rod B gets that state with
    every position, director, velocity and director velocity rotated by Q; N, M (body components)
    are unchanged.  Over 20 more steps: the histories of H, N and M agree and every vector of B is Q
    times that of A.  Measured: 4e-16 (H), 6e-15 (N, M) and 3e-15 (vectors) of their scales; bound
    1e-12 (Newton stops at |F| <= 1e-10, but both runs take the same iterations).  Anisotropic
    compliances, so that a formulation with spatial stress resultants (R^T dropped from the strain
    rate and R from the force: energy-consistent, not objective) fails: measured differences of
    1.0 |N|, 0.2 |M| and 0.15 |r| (its H still agrees to 3e-12).
    """
    from rodfem import Problem
    from rodfem.forms.cosserat_rod import RATES, CosseratRod
    vectors = ("r", "d1", "d2", "d3", "v", *RATES)
    E = np.eye(3)

    def director_rate(i):   # w_i = Omega(s) x e_i with a spin varying along s: twist and bending rates
        return lambda x: np.cross(np.vstack([3 * x[0], 1 + 0 * x[0], -2 * np.cos(np.pi * x[0])]).T, E[i]).T
    initial = {"r": lambda x: np.vstack([x[0] - 0.5, 0 * x[0], 0 * x[0]]),
               "v": lambda x: np.vstack([0.3 * np.cos(np.pi * x[0]), 2 * np.sin(np.pi * x[0]),
                                         -1.5 * (x[0] - 0.5) ** 2]),
               **{f"d{i + 1}": (lambda i: lambda x: np.outer(E[i], np.ones(x.shape[1])))(i) for i in range(3)},
               **{w: director_rate(i) for i, w in enumerate(RATES)}}

    def rod_problem():
        rod = CosseratRod(1.0, (0.03, 0.02, 0.01), (1e-3, 4e-3, 2e-3), (0.5, 1.0, 2.0))
        return Problem(rod, 1.0, 4, initial=initial, comm=MPI.COMM_SELF)

    class History:
        def __init__(self):
            self.H, self.fields = [], []

        def record(self, row, problem):
            self.H.append(row["H"])
            self.fields.append({n: problem.space.nodal(problem.x0, n)[1].copy() for n in (*vectors, "N", "M")})

    A, B = rod_problem(), rod_problem()
    run(A, 0.01, 0.1)
    Q = rotation((1.0, 2.0, 3.0), 0.9)
    B.x0.x.array[:] = A.x0.x.array
    for n in vectors:
        _, dofs = B.space.collapse(n)
        B.x0.x.array[dofs] = (B.x0.x.array[dofs].reshape(-1, 3) @ Q.T).ravel()
    B.x1.x.array[:] = B.x0.x.array
    B.t = A.t   # B is A's state at A's time; both go on for 20 steps (run continues from problem.t)
    hA, hB = History(), History()
    run(A, 0.01, 0.3, writer=hA)
    run(B, 0.01, 0.3, writer=hB)
    assert len(hA.H) == 21
    H_A, H_B = np.array(hA.H), np.array(hB.H)
    assert np.max(np.abs(H_A - H_B)) <= 1e-12 * np.max(H_A)
    for n in ("N", "M"):
        a, b = (np.array([f[n] for f in h.fields]) for h in (hA, hB))
        assert np.max(np.ptp(a, axis=0)) > 0.1 * np.max(np.abs(a))   # they change: the rod deforms
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a)), n
    for n in vectors:
        a, b = (np.array([f[n] for f in h.fields]) for h in (hA, hB))
        assert np.max(np.abs(a @ Q.T - b)) <= 1e-12 * np.max(np.abs(a)), n


# -- zero compliances: inextensible, shear-rigid ------------------------------------------

@pytest.mark.parametrize("zero, strain", [(("C_N1",), [0]), (("C_N2", "C_N3"), [1, 2]),
                                          (("C_N1", "C_N2", "C_N3"), [0, 1, 2])],
                         ids=["inextensible", "shear-rigid", "kirchhoff"])
def test_zero_compliance_constrains_strain(zero, strain):
    """C_N entries 0 in the whirling rod (centrifugal tension, so N != 0): the run converges, conserves
    energy (measured drift <= 1e-14 H_0), and the DG1 moments of those strains stay zero (<= 1e-12),
    while the same rod with the compliances left on strains visibly."""
    P, p = build(whirling_rod_3d.scene, n_elements=4, dt=0.01, t_end=1.0, **{z: 0.0 for z in zero})
    res = run(P, p["dt"], p["t_end"])
    H = res.column("H")
    assert np.max(np.abs(H - H[0])) <= 1e-11 * H[0]
    P2, _ = build(whirling_rod_3d.scene, n_elements=4, dt=0.01, t_end=1.0)
    run(P2, 0.01, 1.0)
    X2 = P2.space.split(P2.x0)
    Gamma2 = [ufl.inner(X2[d], X2["r"].dx(0)) - (1.0 if i == 0 else 0.0) for i, d in enumerate(("d1", "d2", "d3"))]
    moments = strain_moments(P)
    for i in strain:
        assert np.max(np.abs(moments[i])) <= 1e-12
        assert abs(integral(P2, Gamma2[i] * Gamma2[i])) > 1e-10


@pytest.mark.parametrize("constraint, zero", [("none", []), ("inextensible", [0]), ("shear-rigid", [1, 2]),
                                              ("kirchhoff", [0, 1, 2])],
                         ids=["none", "inextensible", "shear-rigid", "kirchhoff"])
def test_helix_constraint_parameter_zeroes_the_compliances(constraint, zero):
    """helix-3d's `constraint` switches off exactly the named strains (C_N entries 0), and only those.

    The helix itself cannot tell: its pure end moment keeps N = 0 (measured |N| ~ 1e-22), so the
    tip error is the same with and without a constraint.  The elastica test below checks the
    physics of the constrained rod built by this scene."""
    P, _ = build(helix_3d.scene, n_elements=2, constraint=constraint)
    C_N = P.model.C_N
    assert [i for i in range(3) if C_N[i] == 0.0] == zero
    assert all(C_N[i] > 0 for i in range(3) if i not in zero)


def elastica_tip(Fx, Fy, EI=1.0, L=1.0):
    """Tip (x, y) of the inextensible, shear-rigid planar cantilever (clamped at s = 0 along x) under a
    dead tip force (Fx, Fy): EI theta'' = Fx sin(theta) - Fy cos(theta), theta(0) = 0, theta'(L) = 0.
    Shooting from the tip on theta(L), integrated to 1e-13 (scipy comes with Debian's dolfinx)."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    def rhs(s, u):   # u = (theta, theta', x - x_L, y - y_L), integrated from s = L down to s = 0
        return [u[1], (Fx * np.sin(u[0]) - Fy * np.cos(u[0])) / EI, np.cos(u[0]), np.sin(u[0])]

    def shoot(theta_L):
        return solve_ivp(rhs, (L, 0.0), [theta_L, 0.0, 0.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-15).y[:, -1]
    # theta(L) lies between 0 and the direction of the force
    theta_L = brentq(lambda a: shoot(a)[0], 0.0, np.arctan2(Fy, Fx), xtol=1e-15, rtol=1e-15)
    u = shoot(theta_L)
    return np.array([-u[2], -u[3]])


def test_kirchhoff_rod_under_a_tip_force_matches_the_elastica():
    """The rod of helix-3d with constraint=kirchhoff (C_N = 0: inextensible and shear-rigid; the scene's
    units give EI_2 = EI_3 = GJ = 1) as a clamped unit cantilever under a dead tip force F = (2, 0, -3),
    ramped smoothly over 40 load steps, 8 elements.

    Here N != 0: the constraints carry the axial force (N_1 = F.d_1 ~ 3.1).  Checks: the tip against
    Euler's elastica (measured 2.2e-5 L; discretisation O(h^4)); N = R^T F, the exact stress
    resultant of a rod loaded only at its tip (measured L2 error 1.2e-3 |F|, the DG1 error at 8
    elements); the DG1 moments of Gamma stay zero (measured 2.8e-11: Newton's tolerance 1e-10 on
    the constraint rows).  If the scene ignored `constraint`, C_N1 = 0.11 at slenderness 100 would
    put the tip 0.51 L away; an extensible rod with EA = 1e4 EI/L^2 already ends 3.7e-4 L away.
    """
    from rodfem import Load, Problem, Support
    from rodfem.demos._rod3d import smooth_ramp, straight
    rod = build(helix_3d.scene, n_elements=2, constraint="kirchhoff")[0].model
    assert np.allclose(rod.C_M, 1.0)
    F = np.array([2.0, 0.0, -3.0])
    P = Problem(rod, 1.0, 8, loads=[Load("v", smooth_ramp(F, 1.0), "right", "tip force")],
                supports=[Support("left", "clamped")], initial=straight((0, 0, 0), np.eye(3)), comm=COMM)
    res = run(P, 0.025, 1.0)
    tip = res.rows[-1]
    exact = elastica_tip(F[0], F[2])
    assert np.hypot(tip["tip_x"] - exact[0], tip["tip_z"] - exact[1]) <= 5e-5
    assert abs(tip["tip_y"]) <= 1e-12                      # the load is in the x-z plane
    X = P.space.split(P.x0)
    N, d = X["N"], [X[n] for n in ("d1", "d2", "d3")]
    RtF = ufl.as_vector([ufl.inner(ufl.as_vector(F), di) for di in d])
    assert integral(P, N[0]) > 2.5                          # a real axial force (measured int N_1 ds = 3.10)
    assert np.sqrt(integral(P, ufl.inner(N - RtF, N - RtF))) <= 2e-3 * np.linalg.norm(F)
    assert np.max(np.abs(strain_moments(P))) <= 1e-10


# -- statics: exact solutions, locking ----------------------------------------------------

def test_roll_up_converges_to_circle():
    """Roll-up into a full circle: the tip error of the P2 element falls with order 4 from 8 to 16 elements.

    Measured: 4.73e-2 and 2.96e-3 (order 3.996), the same to 0.2 % at dt = 0.01 (the smooth ramp
    leaves no load-stepping error at t_end).  A drop to order 3 or 2 (an element or quadrature
    error) fails; bounds: order in [3.7, 4.3], error at 16 elements <= 3.5e-3."""
    errors = []
    for n in (8, 16):
        P, p = build(roll_up_3d.scene, n_elements=n, dt=0.02)
        res = run(P, p["dt"], p["t_end"])
        errors.append(tip_error(res.rows[-1], roll_up_3d.reference(p)))
    order = np.log2(errors[0] / errors[1])
    assert errors[1] <= 3.5e-3 and 3.7 <= order <= 4.3, (errors, order)


def test_helix_fourth_order_and_no_locking():
    """Helix: the tip error falls with order 4 from 12 to 24 elements, and it does not depend on the
    slenderness (1e1 and 1e4: EA L^2/EI from 4e3 to 4e9).

    Measured at dt = 1/32: 1.9186 and 0.12182 (order 3.977) at both slendernesses, equal to 2e-13
    relative; the load-stepping part is 4.5e-3 (dt = 1/64 changes the 24-element error by 4 %).
    A locking element would lose accuracy as the slenderness grows; bound 1e-6 relative."""
    errs = {}
    for sl in (1e1, 1e4):
        for n in (12, 24):
            P, p = build(helix_3d.scene, n_elements=n, dt=1 / 32, slenderness=sl)
            res = run(P, p["dt"], p["t_end"])
            errs[sl, n] = tip_error(res.rows[-1], helix_3d.reference(p))
        order = np.log2(errs[sl, 12] / errs[sl, 24])
        assert 3.7 <= order <= 4.3 and errs[sl, 24] <= 0.001 * helix_3d.LENGTH, (sl, errs, order)
    for n in (12, 24):
        assert abs(errs[1e4, n] - errs[1e1, n]) <= 1e-6 * errs[1e1, n], errs


@pytest.mark.parametrize("slenderness", [1e1, 1e2, 1e3, 1e4])
def test_cantilever_tip_force_no_locking(slenderness):
    """Linear cantilever, tip force across the axis, square section t = L/slenderness: the tip
    deflection equals Timoshenko's F (L^3/(3 EI) + L/(GA)) to 1e-6 with 1 and 2 elements at every
    slenderness (a locking element would give ~ (t/L)^2 of it).  Units with EI = 1, E = 2G:
    EA = 12 slenderness^2, GA = 5/6 G A = 5 slenderness^2.  The linear ramp makes the
    load-stepped statics exact in the linear regime (deflection 1e-4 L)."""
    from rodfem import Load, Problem, Support, ramp
    from rodfem.demos._rod3d import straight
    from rodfem.forms.cosserat_rod import CosseratRod
    EI, EA, GA, F = 1.0, 12 * slenderness ** 2, 5 * slenderness ** 2, 3e-4
    exact = -F * (1 / (3 * EI) + 1 / GA)
    for n in (1, 2):
        rod = CosseratRod(0.0, [0.0, 0.0, 0.0], [1 / EA, 1 / GA, 1 / GA], [1 / EI, 1 / EI, 1 / EI])
        P = Problem(rod, 1.0, n, loads=[Load("v", ramp([0.0, 0.0, -F], 1.0), "right")],
                    supports=[Support("left", "clamped")], initial=straight((0, 0, 0), np.eye(3)), comm=COMM)
        tip = run(P, 0.5, 1.0).rows[-1]["tip_z"]
        assert abs(tip - exact) <= 1e-6 * abs(exact), (n, tip, exact)


def test_helix_inextensible_shear_rigid():
    """Kirchhoff rod (C_N = 0): the same helix runs without code change (the zero-compliance rows are
    constraints with multipliers N) and reaches the helix.  N = 0 here, so this does not test the
    constraint itself: see test_kirchhoff_rod_under_a_tip_force_matches_the_elastica."""
    P, p = build(helix_3d.scene, n_elements=16, dt=1 / 32, slenderness=1e3, constraint="kirchhoff")
    res = run(P, p["dt"], p["t_end"])
    assert tip_error(res.rows[-1], helix_3d.reference(p)) < 0.01 * helix_3d.LENGTH


# -- time convergence ---------------------------------------------------------------------------

def test_second_order_in_time():
    """Whirling rod to t = 0.4: errors against dt = 0.000625 fall by ~4 per halving of dt.

    The sudden spin excites every mode; the measured order is 2 once the stiff
    shear/axial modes are resolved (omega dt < 1), hence the softer, heavier
    cross-section here (default data: omega_max ~ 300 rad/s, pre-asymptotic order ~1
    at dt = 0.02).
    """
    soft = dict(rhoJ1=0.2, rhoJ2=0.1, rhoJ3=0.1, C_N1=1e-2, C_N2=1e-2, C_N3=1e-2)

    def tip(dt):
        P, p = build(whirling_rod_3d.scene, n_elements=4, dt=dt, t_end=0.4, **soft)
        r = run(P, dt, 0.4).rows[-1]
        return np.array([r[f"tip_{c}"] for c in "xyz"])
    ref = tip(0.000625)
    e = [np.linalg.norm(tip(dt) - ref) for dt in (0.01, 0.005)]
    order = np.log2(e[0] / e[1])
    assert 1.8 <= order <= 2.3, (e, order)


# -- parameters -----------------------------------------------------------------------------------

def test_bad_parameters_one_line_errors():
    """A negative compliance and a rotary inertia that violates the triangle inequality are rejected
    with a one-line ParameterError naming the parameter; the director masses of a valid one."""
    with pytest.raises(ParameterError, match="C_N1") as e:
        whirling_rod_3d.scene.values({"C_N1": "-1"})
    assert "\n" not in str(e.value) and ">= 0" in str(e.value)
    with pytest.raises(ParameterError, match="rhoJ") as e:
        build(whirling_rod_3d.scene, rhoJ1=1.0, rhoJ2=0.1, rhoJ3=0.1)
    assert "\n" not in str(e.value)
    assert np.allclose(director_masses((0.02, 0.01, 0.01)), (0.0, 0.01, 0.01))


# -- serial vs 2 ranks ------------------------------------------------------------------------------

@pytest.mark.mpi
@pytest.mark.parametrize("material, t_end", [
    ([], 3),
    (["--set", "material=stiffening", "--set", "kappa_lock=0.5", "--set", "integrator=discrete-gradient"], 2),
], ids=["linear", "stiffening-discrete-gradient"])
def test_serial_and_two_ranks_agree(tmp_path, material, t_end):
    """flying-spaghetti-3d (torsional variant, chord Newton) on 1 and 2 ranks, with the linear law and with
    a non-quadratic one (forms/rod_materials.py, its strain fields): the whole histories agree.

    Every column at every time level, against its physical scale (energies: max|H|, positions: the
    length, momenta: max|p|, max|L|).  Measured: <= 3e-15 (linear), <= 1e-14 (stiffening) of the scale,
    the same Newton iterations; bound 1e-11 (the LU solvers differ: PETSc/SuperLU serial, MUMPS parallel)."""
    args = ["run", "flying-spaghetti-3d", "--set", "variant=spatial", "--set", "n_elements=6", "--set", f"t_end={t_end}",
            *material, "--quiet"]
    a, b, _ = serial_and_parallel(tmp_path, args)
    assert list(a) == list(b) and len(a["t"]) == 10 * t_end + 1
    scale = {"H": np.max(np.abs(a["H"])), "tip": flying_spaghetti_3d.LENGTH,
             "p": max(np.max(np.abs(a[f"p_{c}"])) for c in "xyz"), "L": max(np.max(np.abs(a[f"L_{c}"])) for c in "xyz")}
    scale.update(supplied=scale["H"], balance=scale["H"], t=1.0)
    assert np.array_equal(a["newton_its"], b["newton_its"])
    for k in a:
        if k != "newton_its":
            assert np.max(np.abs(a[k] - b[k])) <= 1e-11 * scale[k.split("_")[0]], k


def test_pinned_rod_under_gravity_and_distributed_moment():
    """Pinned end (r, v fixed, directors free), gravity and a distributed moment as 'domain' inputs:
    the rod swings down through the vertical; balance per step, pinned end, orthonormality.
    Measured: balance 2.9e-16 max|H|, drift of H - supplied 1.1e-15 max|H|; bounds 1e-11."""
    from rodfem import Load, Problem, Support, constant_in_time
    from rodfem.demos._rod3d import end_moment, straight
    from rodfem.forms.cosserat_rod import CosseratRod
    rod = CosseratRod(1.0, [0.02, 0.01, 0.01], [1e-4, 1e-4, 1e-4], [1e-2, 1e-2, 1e-2])
    loads = [Load("v", [0.0, 0.0, -9.81], "domain", "gravity"),
             end_moment(constant_in_time([0.0, 0.5, 0.0], until=0.5), "spatial", where="domain",
                        name="distributed moment")]
    P = Problem(rod, 1.0, 4, loads=loads, supports=[Support("left", "pinned")],
                initial=straight((0, 0, 0), np.eye(3)), comm=COMM)
    rec = Recorder()
    res = run(P, 0.01, 2.0, writer=rec)
    H, W = res.column("H"), res.column("supplied")
    assert np.all(np.abs(res.column("balance_error")) <= 1e-11 * np.max(np.abs(H)))
    assert np.max(np.abs((H - W) - (H[0] - W[0]))) <= 1e-11 * np.max(np.abs(H))
    assert max(rec.orth) <= 1e-10
    assert res.column("tip_z").min() < -0.95          # it swung through the bottom
    s, r = P.space.nodal(P.x0, "r")                   # serial: all nodes, sorted by s
    assert s[0] == 0.0 and np.max(np.abs(r[0])) == 0.0  # the pinned end did not move
