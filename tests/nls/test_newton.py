"""Newton's method (rodfem/nls/newton.py) on forms of its own, then on a scene: quadratic
convergence to a manufactured solution, a failure that names the step and leaves x alone, the
LU chain after a zero pivot, the chord Newton's fallback, and options that do not leak."""
import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI

from rodfem import run
from rodfem.app.scene import load
from rodfem.errors import NewtonFailure
from rodfem.fem import compat
from rodfem.fem.jit import compile_forms
from rodfem.nls.newton import Newton

COMM = MPI.COMM_WORLD


def nonlinear_poisson(n, options=None):
    """-((1 + u^2) u')' = f on (0, 1), u(0) = u(1) = 0, with f made for u = sin(pi x); P2."""
    mesh = dmesh.create_interval(COMM, n, [0.0, 1.0])
    V = compat.functionspace(mesh, compat.element("P", mesh, 2))
    u, v = fem.Function(V), ufl.TestFunction(V)
    x = ufl.SpatialCoordinate(mesh)
    exact = ufl.sin(ufl.pi * x[0])
    f = -ufl.div((1 + exact**2) * ufl.grad(exact))
    F = ((1 + u**2) * ufl.inner(ufl.grad(u), ufl.grad(v)) - f * v) * ufl.dx
    ends = dmesh.locate_entities_boundary(mesh, 0, lambda y: np.isclose(y[0], 0.0) | np.isclose(y[0], 1.0))
    bc = fem.dirichletbc(0.0, fem.locate_dofs_topological(V, 0, ends), V)
    forms = compile_forms({"F": F, "J": ufl.derivative(F, u)})
    newton = Newton(forms["F"], forms["J"], u, [bc], options=options)
    return newton, u, exact


def l2_error(u, exact):
    e = fem.assemble_scalar(compile_forms({"f": (u - exact) ** 2 * ufl.dx})["f"])
    return np.sqrt(COMM.allreduce(e, op=MPI.SUM))


def test_converges_quadratically_to_the_manufactured_solution():
    """From u = 0: the residual norms fall quadratically (|F_k+1| <= 10 |F_k|^2 / |F_0| once below
    |F_0|/10), and the P2 solution's L2 error falls as h^3 (measured order 3.0)."""
    errors = []
    for n in (8, 16):
        newton, u, exact = nonlinear_poisson(n)
        norms = []
        newton.snes.setMonitor(lambda snes, it, norm: norms.append(norm))
        solve = newton.solve(1, 0.0)
        assert solve.residual <= 1e-10 and solve.iterations == len(norms) - 1 <= 8
        for a, b in zip(norms, norms[1:]):
            if a < norms[0] / 10 and b > 1e-13:
                assert b <= 10 * a**2 / norms[0], norms
        errors.append(l2_error(u, exact))
    order = np.log2(errors[0] / errors[1])
    assert 2.8 <= order <= 3.3, (errors, order)


def test_a_failure_names_the_step_and_leaves_x_alone():
    """One iteration allowed: NewtonFailure with the step, the time and the residual; x keeps the
    initial guess (never a half-converged or NaN state)."""
    newton, u, _ = nonlinear_poisson(8, options={"snes_max_it": 1})
    u.x.array[:] = 0.25
    with pytest.raises(NewtonFailure, match=r"step 7 \(t = 0.5\)"):
        newton.solve(7, 0.5)
    assert np.all(u.x.array == 0.25)


def test_a_zero_pivot_moves_down_the_lu_chain():
    """A multiplier lambda enforcing u = g (P1 x P1, no Dirichlet rows): PETSc's unpivoted LU meets
    a zero pivot, Newton goes on with the partial LU (multipliers after the dofs they constrain),
    and lambda = 1 - u^3 + u'' with u = g = sin(pi x), to O(h^2) at the nodes."""
    errors = []
    for n in (16, 32):
        mesh = dmesh.create_interval(COMM, n, [0.0, 1.0])
        P1 = compat.element("P", mesh, 1)
        W = compat.functionspace(mesh, compat.mixed_element([P1, P1]))
        w = fem.Function(W)
        u, lam = ufl.split(w)
        v, mu = ufl.TestFunctions(W)
        g = ufl.sin(ufl.pi * ufl.SpatialCoordinate(mesh)[0])
        F = (ufl.inner(ufl.grad(u), ufl.grad(v)) + u**3 * v + lam * v - v + (u - g) * mu) * ufl.dx
        forms = compile_forms({"F": F, "J": ufl.derivative(F, w)})
        newton = Newton(forms["F"], forms["J"], w, [])
        assert newton.solve(1, 0.0).residual <= 1e-10
        if COMM.size == 1:
            assert newton.linear_solver == "schur(rcm)"
        xs = W.sub(1).collapse()[0].tabulate_dof_coordinates()[:, 0]
        lam_h = w.x.array[W.sub(1).collapse()[1]]
        s = np.sin(np.pi * xs)
        interior = (xs > 0.1) & (xs < 0.9)   # the natural ends carry an O(h) boundary layer
        errors.append(np.max(np.abs(lam_h - (1 - s**3 - np.pi**2 * s))[interior]))
    assert errors[1] <= errors[0] / 3, errors


def test_backward_error_tells_a_small_pivot_from_an_accurate_factor():
    """[[d, 1], [1, 1]] with d = 1e-18: PETSc's LU in natural order takes d as its pivot (the
    multiplier 1e18 swamps the 1 of the corner: backward error of order 1), SuperLU pivots (round-off);
    the same unpivoted LU with d = 2 is exact.  (Newton's test for handing over to the next LU.)"""
    from petsc4py import PETSc

    from rodfem.la.lu_chain import backward_error

    def error(d, solver, ordering="natural"):
        A = PETSc.Mat().createAIJ([2, 2], nnz=2, comm=PETSc.COMM_SELF)
        A.setValues([0, 1], [0, 1], [d, 1.0, 1.0, 1.0])
        A.assemble()
        ksp = PETSc.KSP().create(PETSc.COMM_SELF)
        ksp.setOperators(A)
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        ksp.getPC().setFactorSolverType(solver)
        if solver == "petsc":
            ksp.getPC().setFactorOrdering(ordering)
        try:
            return backward_error(A, ksp.solve)
        finally:
            ksp.destroy()
            A.destroy()

    assert error(1e-18, "petsc") > 1e-3
    assert error(1e-18, "superlu") <= 1e-15
    assert error(2.0, "petsc") <= 1e-15


@pytest.mark.skipif(COMM.size > 1, reason="the serial LU chain")
def test_a_step_too_large_for_newton_keeps_the_partial_lu():
    """16 rigid links, h = 0.1: Newton fails a step (any LU would: the step control halves it) while
    the partial LU's factor is accurate, so the run keeps it (it used to hand over to SuperLU for the
    rest of the run, 3x slower at 256 links); the trajectory equals a run with SuperLU from the start
    (pivoting: an independent factor) to Newton's tolerance."""
    scene = load("chain-1000")
    p = scene.values({"n_links": 16, "dt": 0.1, "t_end": 1.0})
    problem = scene.build(p, MPI.COMM_WORLD)
    res = run(problem, p["dt"], p["t_end"])
    assert res.stepping["rejected"] >= 1, res.stepping
    assert problem.newton.linear_solver == "schur(rcm)"
    pivoting = scene.build(p, MPI.COMM_WORLD)
    pivoting.build()
    pivoting.newton.use_lu("superlu")
    ref = run(pivoting, p["dt"], p["t_end"])
    assert pivoting.newton.linear_solver == "superlu"
    assert ref.stepping["rejected"] == res.stepping["rejected"]
    for col in ("H", "tip_x", "tip_y"):
        assert np.max(np.abs(res.column(col) - ref.column(col))) <= 1e-8 * np.max(np.abs(ref.column(col)))
    assert res.max_balance_error <= 1e-12 * np.max(np.abs(res.column("H")))


# -- on a scene: the chord Newton and the options database ------------------------------------

def spaghetti(newton_options=None, **overrides):
    scene = load("flying-spaghetti-2d")
    p = scene.values({"t_end": 5.0, **overrides})
    problem = scene.build(p, MPI.COMM_WORLD)
    if newton_options is not None:  # rebuild the Newton solver with other settings
        problem.set_newton_options(newton_options)
    return problem, p


def test_chord_newton_falls_back_to_full_newton_and_agrees(monkeypatch):
    from rodfem.nls.newton import Newton
    retries = []
    full_newton = Newton._solve_full_newton
    monkeypatch.setattr(Newton, "_solve_full_newton", lambda self, *a: retries.append(a) or full_newton(self, *a))
    full, p = spaghetti()
    ref = run(full, p["dt"], p["t_end"])
    # a chord Newton allowed only 3 iterations cannot converge the loaded steps: each such step is
    # repeated with full Newton, and the trajectory is the same to solver tolerance (measured: identical)
    chord, _ = spaghetti({"snes_lag_jacobian": 8, "snes_lag_jacobian_persists": True, "snes_max_it": 3})
    res = run(chord, p["dt"], p["t_end"])
    assert len(retries) >= 25  # at least every loaded step (t <= 2.5) was repeated
    for col in ("H", "tip_x", "tip_y", "L_z"):
        assert np.max(np.abs(res.column(col) - ref.column(col))) <= 1e-11 * np.max(np.abs(ref.column(col)))
    assert res.max_balance_error <= 1e-11 * np.max(res.column("H"))   # measured 2.0e-15


def test_problem_options_do_not_leak_into_the_next_problem():
    a, _ = spaghetti({"snes_max_it": 3})
    b, _ = spaghetti()
    assert a.newton.snes.getTolerances()[3] == 3
    assert b.newton.snes.getTolerances()[3] == 25


@pytest.mark.skipif(COMM.size > 1, reason="the serial LU chain")
def test_a_pattern_where_petscs_lu_failed_goes_straight_to_the_partial_lu(monkeypatch):
    """The 3D rod's collocated multipliers are zero pivots of PETSc's LU: Newton's first step fails
    the factorization and is solved again with the partial LU (two Newton solves).  The same rod built
    again in the process goes straight to the partial LU (one solve), with the same history (measured:
    equal to the bit) and an exact energy balance.  The four-bar's joint multipliers are zeros on the
    diagonal too, but PETSc's LU gets their pivots from the fill: it keeps PETSc's LU, built again too."""
    from rodfem.nls import newton as module
    monkeypatch.setattr(module, "_ZERO_PIVOTS", {})
    solves = []
    original = Newton._solve
    monkeypatch.setattr(Newton, "_solve", lambda self, *a: solves.append(1) or original(self, *a))
    scene = load("flying-spaghetti-3d")
    p = scene.values({"n_elements": 4})
    histories = []
    for expected in (2, 1):
        problem = scene.build(p, COMM)
        solves.clear()
        res = run(problem, p["dt"], p["dt"])
        assert len(solves) == expected
        assert problem.newton.linear_solver == "schur(rcm)"
        histories.append(run(problem, p["dt"], 4 * p["dt"], result=res))
    a, b = histories
    for c in ("H", "supplied", "tip_x", "L_z"):
        x, y = a.column(c), b.column(c)
        assert np.max(np.abs(x - y)) <= 1e-10 * max(np.max(np.abs(y)), 1.0), c
    assert a.max_balance_error <= 1e-12 * max(abs(h) for h in a.column("H"))
    bars = load("four-bar-2d")
    q = bars.values({})
    for _ in range(2):
        mechanism = bars.build(q, COMM)
        run(mechanism, q["dt"], q["dt"])
        assert mechanism.newton.linear_solver == "petsc"
    beam, q = spaghetti()
    run(beam, q["dt"], q["dt"])
    assert beam.newton.linear_solver == "petsc"
