"""Generalized Maxwell viscoelasticity (forms/viscoelastic.py): the exact discrete dissipation
balance, the standard-linear-solid formulas (relaxation, creep), the midpoint recurrence,
the limits tau -> inf / tau -> 0 / zero stiffness, roll-up creep, stiff dashpots, MPI."""

import numpy as np
import pytest
from processes import serial_and_parallel, tight_newton

from rodfem import Load, Problem, Support, run
from rodfem.app.driver import run_scene
from rodfem.demos._rod3d import NEWTON, end_moment, straight
from rodfem.forms import cosserat_rod, planar_beam, string
from rodfem.forms.string_materials import kirchhoff, logarithmic
from rodfem.forms.viscoelastic import midpoint_factor, sls_creep, sls_relaxation

RULES = ("midpoint", "discrete-gradient")


# -- problems ----------------------------------------------------------------------------

def pulse(value, until):
    value = np.asarray(value, dtype=float)
    return lambda t: value * np.sin(np.pi * t / until) ** 2 if t <= until else 0 * value


def planar_cantilever(branches, integrator="midpoint", law=planar_beam.quadratic, n=6, EA=100.0, GA=100.0, EI=10.0):
    """A soft cantilever (L = 1) hit by a tip force pulse, free afterwards."""
    beam = planar_beam.PlanarBeam(1.0, 0.1, law(EA, GA, EI), branches=branches)
    return Problem(beam, 1.0, n, loads=[Load("v", pulse([0.5, -2.0], 0.5), "right", "tip")],
                   supports=[Support("left", "clamped")], initial={"r": lambda x: np.vstack([x[0], 0 * x[0]])},
                   integrator=integrator)


def planar_branches(tau=0.1):
    """Two branches (the stresses of any number of branches add)."""
    return [planar_beam.maxwell(tau, EA=50.0, GA=30.0, EI=5.0), planar_beam.maxwell(10 * tau, EA=20.0, GA=20.0, EI=2.0)]


def rod_cantilever(integrator="midpoint", tau=0.1, branch=True):
    """An extensible 3D cantilever (4 elements) with a branch on N and M, hit by a tip force pulse."""
    branches = [cosserat_rod.maxwell(tau, C_N=(0.02, 0.05, 0.05), C_M=(0.5, 0.25, 0.25))] if branch else []
    rod = cosserat_rod.CosseratRod(1.0, (0.02, 0.01, 0.01), (0.01, 0.02, 0.02), (0.2, 0.1, 0.1), branches=branches)
    loads = [Load("v", pulse([0.0, 1.0, 0.5], 0.3), "right", "tip"),
             end_moment(pulse([0.2, 0.0, 0.0], 0.3), "body", name="torque")]
    return Problem(rod, 1.0, 4, loads=loads, supports=[Support("left", "clamped")],
                   initial=straight((0.0, 0.0, 0.0), np.eye(3)), integrator=integrator, newton_options=NEWTON)


def field(problem, name):
    """Values of field `name` of x_n (local dofs, components last)."""
    S = problem.space
    f = S.field(name)
    return problem.x0.x.array[S.collapse(name)[1]].reshape(-1, f.size)


class Recorder:
    """A history writer that calls f(problem) at every time level (the state x_n of that level)."""

    def __init__(self, f):
        self.f = f

    def record(self, row, problem):
        self.f(problem)


def lambert_log(c):
    """u > 0 with u + ln u = c (Newton; the solution of the logarithmic string's relaxation)."""
    u = np.exp(c) if c < 1 else c
    for _ in range(100):
        du = (u + np.log(u) - c) / (1 + 1 / u)
        u = max(u - du, 0.5 * u)
        if abs(du) <= 1e-16 * u:
            break
    return u


# -- the balance H_{n+1} - H_n = -h d_n + h y.u ---------------------------------------------

def cases():
    """(name, integrator, run() -> Result): every model, both integrators where exact."""
    out = []
    for rule in RULES:
        out.append(("planar-hooke", rule, lambda r=rule: run(planar_cantilever(planar_branches(), r), 0.05, 2.0)))
        out.append(("string-kirchhoff", rule, lambda r=rule: run_scene(
            "viscoelastic-string", {"t_end": 2.0, "integrator": r, "material": "kirchhoff"})[0]))
        out.append(("rod-extensible", rule, lambda r=rule: run(rod_cantilever(r), 0.02, 0.6)))
    dg = "discrete-gradient"
    out.append(("planar-log-axial", dg, lambda: run(planar_cantilever(
        [planar_beam.maxwell(0.1, EA=50.0, GA=30.0, EI=5.0, law=planar_beam.log_axial)], dg, planar_beam.log_axial),
        0.05, 2.0)))
    out.append(("string-logarithmic", dg, lambda: run_scene("viscoelastic-string", {"t_end": 2.0})[0]))
    out.append(("rod-inextensible", "midpoint", lambda: run_scene(
        "viscoelastic-cantilever-3d", {"t_end": 0.08, "tau1": 0.005, "E1": 3.6e10})[0]))
    return out


# max |balance error| / max |H| measured with tight_newton (this machine, both integrators);
# the test's bound is 10x that.  (With rodfem's default Newton tolerance, |F| <= 1e-10, the
# errors are the solver tolerance instead: <= 2e-11 max |H| in these cases.)
MEASURED = {"planar-hooke": 3.5e-16, "string-kirchhoff": 6.3e-16, "rod-extensible": 1.9e-14,
            "planar-log-axial": 9.6e-16, "string-logarithmic": 5.2e-16, "rod-inextensible": 1.5e-15}


@pytest.mark.parametrize("name,integrator,runner", cases(), ids=[f"{c[0]}-{c[1]}" for c in cases()])
def test_exact_balance_with_dissipation(name, integrator, runner):
    # the logarithmic string's residual stops at ~2e-12 (round-off of the discrete-gradient quotient)
    with tight_newton(1e-11 if name == "string-logarithmic" else 1e-13):
        res = runner()
    H, D = res.column("H"), res.column("dissipated")
    Hmax = np.max(np.abs(H))
    err = np.abs(res.column("balance_error")[1:])
    bound = 10 * MEASURED[name] * Hmax
    print(f"{name} {integrator}: max balance error {err.max():.2e} = {err.max() / Hmax:.2e} max|H|, "
          f"dissipated {D[-1]:.4g}")
    assert np.all(err <= bound) and bound <= 1e-9 * Hmax
    d = np.diff(D)   # h d_n of each step
    assert np.all(d >= 0.0)
    # the dissipation is not negligible: leaving it out of the balance would fail the bound by far
    assert np.max(d) >= 1e3 * bound
    # the balance error is H_{n+1} - H_n + h d_n - h y.u
    dH = np.diff(H) + d - np.diff(res.column("supplied"))
    assert np.allclose(dH, res.column("balance_error")[1:], rtol=0, atol=1e-15 * Hmax)


def test_midpoint_is_not_exact_for_the_logarithmic_string():
    """The balance test can fail: the midpoint rule with a non-quadratic W misses it by far."""
    with tight_newton(1e-11):
        res = run_scene("viscoelastic-string", {"t_end": 2.0, "integrator": "midpoint"})[0]
    assert res.max_balance_error > 1e3 * 10 * MEASURED["string-logarithmic"] * np.max(np.abs(res.column("H")))


def test_default_tolerance_balance_of_the_scenes():
    """The scenes as a user runs them (rodfem's Newton tolerance): <= 1e-9 max |H| every step."""
    for scene, over in (("viscoelastic-string", {}), ("viscoelastic-cantilever-2d", {"t_end": 0.5}),
                        ("viscoelastic-cantilever-3d", {"t_end": 0.08})):
        res, summary = run_scene(scene, over)
        assert summary["max_balance_error_relative"] <= 1e-9, scene
        assert res.column("dissipated")[-1] > 0


# -- standard linear solid: relaxation under a held strain -----------------------------------
#
# A strain eps0 switched on at t = 0 and held: each branch's elastic strain starts at eps0
# (instantaneous response) and relaxes; the midpoint rule gives exactly e_{n+1} = q e_n,
# q = (1 - h/2tau)/(1 + h/2tau), and the stress eps0 (k_inf + k_1 q^n) is within O(h^2) of
# eps0 (k_inf + k_1 exp(-t/tau)).

def relaxation_errors(h, stress, k_inf, k1, eps0, branch_strain, tau, n):
    """(recurrence error of the branch strain, error of the total stress vs the SLS formula), relative."""
    rec = np.max(np.abs(branch_strain - eps0 * midpoint_factor(h, tau) ** n)) / abs(eps0)
    exact = sls_relaxation(n * h, eps0, k_inf, [(k1, tau)])
    return rec, np.max(np.abs(stress - exact)) / abs(exact)


@pytest.mark.parametrize("integrator", RULES)
def test_relaxation_bar_axial_and_bending(integrator):
    """Planar bar clamped at both ends: axial strain eps0 and, separately, curvature kappa0 held."""
    EA, EA1, EI, EI1, tau = 100.0, 50.0, 10.0, 5.0, 0.05
    eps0, kappa0 = 1e-2, 0.5
    branch = planar_beam.maxwell(tau, EA=EA1, GA=EA1, EI=EI1)
    beam = planar_beam.PlanarBeam(1.0, 0.1, planar_beam.quadratic(EA, EA, EI), branches=[branch])
    zeros2 = lambda x: np.zeros((2, x.shape[1]))   # noqa: E731
    stretched = {"r": lambda x: np.vstack([(1 + eps0) * x[0], 0 * x[0]]),
                 "Gamma_1": lambda x: np.vstack([np.full(x.shape[1], eps0), 0 * x[0]])}
    bent = {"r": lambda x: np.vstack([np.sin(kappa0 * x[0]) / kappa0, (1 - np.cos(kappa0 * x[0])) / kappa0]),
            "phi": lambda x: kappa0 * x[0], "Gamma": zeros2, "kappa_1": lambda x: np.full(x.shape[1], kappa0)}
    clamped = [Support("left", "clamped"), Support("right", "clamped")]
    for what, initial in (("axial", stretched), ("bending", bent)):
        errs = []
        for h in (0.01, 0.005):
            p = Problem(beam, 1.0, 4, supports=clamped, initial=initial, integrator=integrator)
            res = run(p, h, 0.2)
            n = res.steps
            if what == "axial":
                G, G1 = field(p, "Gamma")[:, 0], field(p, "Gamma_1")[:, 0]
                rec, err = relaxation_errors(h, EA * G + EA1 * G1, EA, EA1, eps0, G1, tau, n)
                assert np.max(np.abs(G - eps0)) <= 1e-14   # the strain is held
            else:
                k, k1 = field(p, "kappa")[:, 0], field(p, "kappa_1")[:, 0]
                rec, err = relaxation_errors(h, EI * k + EI1 * k1, EI, EI1, kappa0, k1, tau, n)
                assert np.max(np.abs(k - kappa0)) <= 1e-14
            print(f"planar {what} relaxation h = {h}: recurrence error {rec:.1e}, SLS error {err:.1e}")
            assert rec <= 1e-13                  # the linear recurrence, exactly
            errs.append(err)
            # all the strain energy the branch loses goes into the dashpot: H_n + dissipated = H_0
            D, H = res.column("dissipated"), res.column("H")
            assert H[-1] + D[-1] == pytest.approx(H[0], rel=1e-13)
            assert D[-1] > 0.5 * (H[0] - H[-1]) > 0
        # vs the SLS formula: second order in h (measured 1.2e-4 and 3.0e-5 of the stress at t = 4 tau)
        assert errs[0] <= 1.5e-4 and errs[1] <= 0.3 * errs[0]


def test_relaxation_rod_axial_and_bending():
    """3D rod (compliance form) clamped at both ends on a held stretch, and on a held arc (curvature
    kappa0 about e3): the branch resultants N_1, M_1 relax by the exact recurrence; the rod stays at rest."""
    EA, EA1, EI, EI1, tau, h, k0, eps0 = 10.0, 5.0, 2.0, 1.0, 0.05, 0.01, 1.0, 1e-2
    const = lambda v: (lambda x: np.outer(v, np.ones(x.shape[1])))   # noqa: E731
    branch = cosserat_rod.maxwell(tau, C_N=(1 / EA1,) * 3, C_M=(1 / EI1,) * 3)
    rod = cosserat_rod.CosseratRod(1.0, (0.02, 0.01, 0.01), (1 / EA,) * 3, (1 / EI,) * 3, branches=[branch])
    stretched = {**straight((0.0, 0.0, 0.0), np.eye(3)),
                 "r": lambda x: np.vstack([(1 + eps0) * x[0], 0 * x[0], 0 * x[0]]),
                 "N": const([EA * eps0, 0, 0]), "N_1": const([EA1 * eps0, 0, 0])}
    c, s = (lambda x: np.cos(k0 * x[0])), (lambda x: np.sin(k0 * x[0]))
    bent = {"r": lambda x: np.vstack([s(x) / k0, (1 - c(x)) / k0, 0 * x[0]]),
            "d1": lambda x: np.vstack([c(x), s(x), 0 * x[0]]), "d2": lambda x: np.vstack([-s(x), c(x), 0 * x[0]]),
            "d3": const([0, 0, 1.0]), "M": const([0, 0, EI * k0]), "M_1": const([0, 0, EI1 * k0])}
    q = midpoint_factor(h, tau)
    for what, initial, name, value in (("axial", stretched, "N_1", EA1 * eps0), ("bending", bent, "M_1", EI1 * k0)):
        p = Problem(rod, 1.0, 4, supports=[Support("left", "clamped"), Support("right", "clamped")],
                    initial=initial, newton_options=NEWTON)
        res = run(p, h, 0.2)
        comp = field(p, name)
        i = 0 if what == "axial" else 2
        rec = np.max(np.abs(comp[:, i] - value * q ** res.steps)) / value
        print(f"rod {what} relaxation: recurrence error {rec:.1e}")
        assert rec <= 1e-13
        assert np.max(np.abs(np.delete(comp, i, axis=1))) <= 1e-13 * value
        assert np.max(np.abs(field(p, "v"))) <= 1e-12          # held: nothing moves
        assert res.max_balance_error <= 1e-13 * np.max(np.abs(res.column("H")))


def test_relaxation_string_logarithmic_and_kirchhoff():
    """A string held at stretch lambda (pinned ends): C_1 relaxes.  Kirchhoff's W is quadratic in C:
    C_1 - 1 follows the recurrence exactly.  The IFAC 2024 paper's logarithmic W: d_t C_1 = -(1 - 1/C_1)/tau,
    whose solution u = C_1 - 1 is u + ln u = u0 + ln u0 - t/tau."""
    lam, tau, h, n = 1.2, 0.05, 0.005, 40
    for law in (kirchhoff, logarithmic):
        model = string.String(law(EA=10.0), 1.0, branches=[string.maxwell(tau, 5.0, law=law)])
        initial = {"r": lambda x: np.vstack([lam * x[0], 0 * x[0], 0 * x[0]]),
                   "C_1": lambda x: np.full(x.shape[1], lam ** 2)}
        p = Problem(model, 1.0, 3, supports=[Support("left", "pinned"), Support("right", "pinned")],
                    initial=initial, integrator="discrete-gradient")
        run(p, h, n * h)
        u, u0 = field(p, "C_1")[:, 0] - 1, lam ** 2 - 1
        assert np.max(np.abs(field(p, "C")[:, 0] - lam ** 2)) <= 1e-14
        if law is kirchhoff:
            rec = np.max(np.abs(u - u0 * midpoint_factor(h, tau) ** n)) / u0
            print(f"string kirchhoff relaxation: recurrence error {rec:.1e}")
            assert rec <= 1e-13
        else:
            err = np.max(np.abs(u - lambert_log(u0 + np.log(u0) - n * h / tau))) / u0
            print(f"string logarithmic relaxation: error {err:.1e} vs the closed form")
            assert err <= 1e-4                  # O(h^2): measured 6.2e-5


# -- standard linear solid: creep under a held load (statics) ------------------------------
#
# Zero densities: every midpoint step is the static equilibrium of the midpoint state.  Started
# in the instantaneous equilibrium (strain N0/(k_inf + k_1) in both branches), the end states stay
# in equilibrium and the strain creeps by the recurrence with the creep time tau_c = tau (k_inf + k_1)/k_inf.

def creep_errors(h, strain, load, k_inf, k1, tau, n):
    eps0, eps_inf = load / (k_inf + k1), load / k_inf
    rec = np.max(np.abs((strain - eps_inf) - (eps0 - eps_inf) * midpoint_factor(h, tau * (k_inf + k1) / k_inf) ** n))
    err = np.max(np.abs(strain - sls_creep(n * h, load, k_inf, k1, tau)))
    return rec / eps_inf, err / eps_inf


def test_creep_bar_axial_planar_and_rod():
    EA, EA1, tau, N0, L = 100.0, 50.0, 0.05, 2.0, 1.0
    e0 = N0 / (EA + EA1)
    const = lambda v: (lambda x: np.outer(v, np.ones(x.shape[1])))   # noqa: E731

    def planar():
        beam = planar_beam.PlanarBeam(0.0, 0.0, planar_beam.quadratic(EA, EA, 10.0),
                                      branches=[planar_beam.maxwell(tau, EA=EA1, GA=EA1, EI=1.0)])
        return Problem(beam, L, 4, loads=[Load("v", [N0, 0.0], "right")], supports=[Support("left", "clamped")],
                       initial={"r": lambda x: np.vstack([(1 + e0) * x[0], 0 * x[0]]), "Gamma": const([e0, 0.0]),
                                "Gamma_1": const([e0, 0.0])})

    def rod3d():
        rod = cosserat_rod.CosseratRod(0.0, (0.0, 0.0, 0.0), (1 / EA, 1 / EA, 1 / EA), (0.1, 0.1, 0.1),
                                       branches=[cosserat_rod.maxwell(tau, C_N=(1 / EA1,) * 3)])
        return Problem(rod, L, 4, loads=[Load("v", [N0, 0.0, 0.0], "right")], supports=[Support("left", "clamped")],
                       initial={**straight((0.0, 0.0, 0.0), np.eye(3)), "N": const([EA * e0, 0, 0]),
                                "N_1": const([EA1 * e0, 0, 0]),
                                "r": lambda x: np.vstack([(1 + e0) * x[0], 0 * x[0], 0 * x[0]])},
                       newton_options=NEWTON)
    for name, make in (("planar", planar), ("rod", rod3d)):
        errs = []
        for h in (0.01, 0.005):
            res = run(make(), h, 0.3)
            strain = res.column("tip_x") / L - 1
            rec, err = creep_errors(h, strain, N0, EA, EA1, tau, np.arange(res.steps + 1))
            print(f"{name} axial creep h = {h}: recurrence error {rec:.1e}, SLS error {err:.1e}")
            assert rec <= 1e-12
            errs.append(err)
        assert errs[0] <= 2.5e-4 and errs[1] <= 0.3 * errs[0]   # O(h^2): measured 1.8e-4, 4.6e-5


def rollup_creep(h, n_elements=8, t_end=2.0):
    """Planar cantilever (L = 1, statics) under a constant end moment M0 = pi EI/L: from the
    instantaneous arc kappa0 = M0/(EI + EI1) it creeps towards the half circle kappa = pi."""
    EI, EI1, tau = 100.0, 50.0, 0.5
    M0 = np.pi * EI
    k0 = M0 / (EI + EI1)
    beam = planar_beam.PlanarBeam(0.0, 0.0, planar_beam.quadratic(1e4, 1e4, EI),
                                  branches=[planar_beam.maxwell(tau, EA=5e3, GA=5e3, EI=EI1)])
    initial = {"r": lambda x: np.vstack([np.sin(k0 * x[0]) / k0, (1 - np.cos(k0 * x[0])) / k0]),
               "phi": lambda x: k0 * x[0], "Gamma": lambda x: np.zeros((2, x.shape[1])),
               "kappa": lambda x: np.full(x.shape[1], k0), "kappa_1": lambda x: np.full(x.shape[1], k0)}
    p = Problem(beam, 1.0, n_elements, loads=[Load("omega", M0, "right", "end moment")],
                supports=[Support("left", "clamped")], initial=initial)
    res = run(p, h, t_end)
    return p, res, (M0, EI, EI1, tau)


def circle_deviation(points):
    """max | |x - c| - R | / R of the least-squares circle through `points`."""
    A = np.column_stack([2 * points, np.ones(len(points))])
    c = np.linalg.lstsq(A, (points ** 2).sum(1), rcond=None)[0]
    R = np.sqrt(c[2] + c[0] ** 2 + c[1] ** 2)
    return np.max(np.abs(np.hypot(*(points - c[:2]).T) - R)) / R


def test_rollup_creep_stays_a_circular_arc():
    devs, errs = [], []
    for h in (0.05, 0.025):
        p, res, (M0, EI, EI1, tau) = rollup_creep(h)
        n = res.steps
        kappa = field(p, "kappa")[:, 0]
        assert np.ptp(kappa) <= 1e-12 * np.pi                       # uniform curvature: an arc
        s, phi = p.space.nodal(p.x0, "phi")
        assert np.max(np.abs(phi[:, 0] - kappa.mean() * s)) <= 1e-12  # turning angle kappa s
        rec, err = creep_errors(h, kappa.mean(), M0, EI, EI1, tau, n)
        _, r = p.space.nodal(p.x0, "r")
        devs.append(circle_deviation(r))
        errs.append(err)
        print(f"roll-up creep h = {h}: kappa recurrence error {rec:.1e}, SLS error {err:.1e}, "
              f"nodes off the circle by {devs[-1]:.1e} R")
        assert rec <= 1e-13
        assert err <= 3e-5                       # measured 2.3e-5 (h = 0.05), 5.7e-6 (h = 0.025)
        assert devs[-1] <= 1.5e-5                # measured 9.9e-6, 2.5e-6: the rate form's O(h^2)
    assert errs[1] < 0.3 * errs[0] and devs[1] < 0.3 * devs[0]      # both second order in h


def test_rollup_creep_rod():
    """The same roll-up with the 3D rod (branch on M, compliance form): the tip turns by the creep
    curvature; the analytic start is not the discrete equilibrium of 8 P2 elements (5e-4)."""
    EI, EI1, tau, h, L = 2.0, 1.0, 0.5, 0.05, 1.0
    M0 = np.pi * EI / L
    k0 = M0 / (EI + EI1)
    const = lambda v: (lambda x: np.outer(v, np.ones(x.shape[1])))   # noqa: E731
    c, s = (lambda x: np.cos(k0 * x[0])), (lambda x: np.sin(k0 * x[0]))
    initial = {"r": lambda x: np.vstack([s(x) / k0, (1 - c(x)) / k0, 0 * x[0]]),
               "d1": lambda x: np.vstack([c(x), s(x), 0 * x[0]]), "d2": lambda x: np.vstack([-s(x), c(x), 0 * x[0]]),
               "d3": const([0, 0, 1.0]), "M": const([0, 0, EI * k0]), "M_1": const([0, 0, EI1 * k0])}
    rod = cosserat_rod.CosseratRod(0.0, (0.0, 0.0, 0.0), (1e-3,) * 3, (1 / EI,) * 3,
                                   branches=[cosserat_rod.maxwell(tau, C_M=(1 / EI1,) * 3)])
    p = Problem(rod, L, 8, loads=[end_moment([0.0, 0.0, M0])], supports=[Support("left", "clamped")],
                initial=initial, newton_options=NEWTON)
    res = run(p, h, 1.0)
    s_, d1 = p.space.nodal(p.x0, "d1")
    angle = np.unwrap(np.arctan2(d1[:, 1], d1[:, 0]))
    err = abs(angle[-1] / L - sls_creep(res.steps * h, M0, EI, EI1, tau)) / (M0 / EI)
    print(f"rod roll-up creep: tip angle / L vs the SLS curvature: {err:.1e}")
    assert err <= 1e-3                           # measured 1.9e-4
    assert np.max(np.abs(angle - angle[-1] * s_ / L)) <= 1e-4 * angle[-1]   # uniform turning: an arc


# -- limits ------------------------------------------------------------------------------------

def history_difference(a, b, columns):
    """max over the columns of max_n |a - b| / max_n |a|."""
    return max(np.max(np.abs(a.column(c) - b.column(c))) / max(np.max(np.abs(a.column(c))), 1e-300) for c in columns)


def limit_pairs(tau):
    """(viscoelastic, elastic) problems: tau = inf vs the summed stiffness, tau -> 0 vs the equilibrium branch."""
    EA, GA, EI, EA1, GA1, EI1 = 100.0, 100.0, 10.0, 50.0, 30.0, 5.0
    both = planar_cantilever([planar_beam.maxwell(tau, EA=EA1, GA=GA1, EI=EI1)])
    alone = planar_cantilever([], EA=EA + EA1, GA=GA + GA1, EI=EI + EI1) if np.isinf(tau) else planar_cantilever([])
    strings = []
    for branches, EA_eq in (([string.maxwell(tau, 5.0)], 10.0), ([], 15.0 if np.isinf(tau) else 10.0)):
        model = string.String(logarithmic(EA=EA_eq), 1.0, branches=branches)   # W(C; k) is linear in k
        strings.append(Problem(model, 1.0, 4, loads=[Load("v", pulse([0.0, 0.0, -3.0], 0.4), "right")],
                               supports=[Support("left", "pinned")], integrator="discrete-gradient",
                               initial={"r": lambda x: np.vstack([x[0], 0 * x[0], 0 * x[0]])}))
    return [("planar", both, alone, ("H", "tip_x", "tip_y")), ("string", *strings, ("H", "tip_x", "tip_z"))]


def test_limit_tau_infinite_is_elastic_with_summed_stiffness():
    for name, visco, elastic, cols in limit_pairs(np.inf):
        a, b = run(visco, 0.05, 1.0), run(elastic, 0.05, 1.0)
        assert np.all(a.column("dissipated") == 0.0)
        assert history_difference(a, b, cols) <= 1e-13, name    # measured 2.6e-15: the same solution


def test_limit_tau_zero_is_the_equilibrium_branch_alone():
    """tau = 1e-9 (2e-8 h): the branch carries stress ~ tau/h; ten times tau, ten times the difference."""
    diffs = {}
    for tau in (1e-9, 1e-8):
        for name, visco, elastic, cols in limit_pairs(tau):
            a, b = run(visco, 0.05, 1.0), run(elastic, 0.05, 1.0)
            diffs[name, tau] = history_difference(a, b, cols)
            assert a.max_balance_error <= 1e-9 * np.max(np.abs(a.column("H")))
    for name in ("planar", "string"):
        assert diffs[name, 1e-9] <= 1e-6                     # measured 2.4e-8 (planar), 7.0e-8 (string)
        assert 5 < diffs[name, 1e-8] / diffs[name, 1e-9] < 20


def test_zero_branch_stiffness_is_the_elastic_model_bit_for_bit():
    """A branch without stiffness is dropped: no internal variable, the same forms, the same history."""
    def string_problem(branches):
        model = string.String(logarithmic(EA=10.0), 1.0, branches=branches)
        return Problem(model, 1.0, 4, loads=[Load("v", pulse([0.0, 0.0, -3.0], 0.4), "right")],
                       supports=[Support("left", "pinned")], integrator="discrete-gradient",
                       initial={"r": lambda x: np.vstack([x[0], 0 * x[0], 0 * x[0]])})

    def rod_problem(branches):
        rod = cosserat_rod.CosseratRod(1.0, (0.02, 0.01, 0.01), (0.01, 0.02, 0.02), (0.2, 0.1, 0.1), branches=branches)
        return Problem(rod, 1.0, 4, supports=[Support("left", "clamped")],
                       loads=[Load("v", pulse([0.0, 1.0, 0.5], 0.3), "right")],
                       initial=straight((0.0, 0.0, 0.0), np.eye(3)), newton_options=NEWTON)
    pairs = {"planar": (planar_cantilever([planar_beam.maxwell(0.1, EA=0.0, GA=0.0, EI=0.0)]), planar_cantilever([])),
             "string": (string_problem([string.maxwell(0.1, 0.0)]), string_problem([])),
             "rod": (rod_problem([cosserat_rod.maxwell(0.1)]), rod_problem([]))}
    for name, (zero, elastic) in pairs.items():
        assert zero.space.names == elastic.space.names and not zero.dissipates, name
        a, b = run(zero, 0.05, 0.6), run(elastic, 0.05, 0.6)
        assert a.rows == b.rows, name            # every column, every step, bit for bit (no 'dissipated')


def test_elastic_forms_unchanged_by_the_feature():
    """Without (active) branches a model builds the very forms it builds without the argument:
    the same UFL signatures, so the same compiled kernels.  (Built by Body, nothing compiled in
    between: a compilation advances UFL's counters, see rodfem/core/problem.py: compile_forms.)"""
    from rodfem.core.body import Body
    init = {"r": lambda x: np.vstack([x[0], 0 * x[0]])}
    for rule in RULES:
        bodies = [Body(planar_beam.PlanarBeam(1.0, 0.1, planar_beam.quadratic(1.0, 2.0, 3.0), branches=br), 1.0, 2,
                       initial=init, integrator=rule) for br in ((), [planar_beam.maxwell(0.1)])]
        fa, fb = (b.forms() for b in bodies)
        assert sorted(fa) == sorted(fb) and "dissipation" not in fa
        for k in fa:
            if fa[k] is not None:   # 'work' is None without loads
                assert fa[k].signature() == fb[k].signature(), (rule, k)


def test_system_of_bodies_sums_the_dissipation():
    """A mechanism (rodfem/core/system.py): a viscoelastic beam pinned to an elastic one; the system's
    balance includes the dissipating body's h d_n and stays exact."""
    from rodfem.core.system import System
    from rodfem.forms import joints
    sys_ = System()
    visco = planar_beam.PlanarBeam(1.0, 0.1, planar_beam.quadratic(100.0, 100.0, 10.0), branches=planar_branches())
    elastic = planar_beam.PlanarBeam(1.0, 0.1, planar_beam.quadratic(100.0, 100.0, 10.0))
    length, init_a = planar_beam.straight((0.0, 0.0), (1.0, 0.0))
    _, init_b = planar_beam.straight((1.0, 0.0), (2.0, 0.0))
    a = sys_.add("a", visco, length, 4, supports=[Support("left", "clamped")], initial=init_a)
    b = sys_.add("b", elastic, length, 4, loads=[Load("v", pulse([0.0, -2.0], 0.5), "right")], initial=init_b)
    sys_.join(joints.pin, a.end, b.start)
    with tight_newton():
        res = run(sys_, 0.05, 1.5)
    H = res.column("H")
    assert sys_.dissipates and res.column("dissipated")[-1] > 1e-3 * np.max(H)
    print(f"system: balance error {res.max_balance_error / np.max(np.abs(H)):.1e} max|H|")
    assert res.max_balance_error <= 1e-13 * np.max(np.abs(H))   # measured 3.1e-16


# -- stiff dashpots -----------------------------------------------------------------------------

def test_midpoint_at_tau_much_smaller_than_h_flips_the_branch_stress():
    """tau << h: the midpoint factor (1 - h/2tau)/(1 + h/2tau) -> -1: the held branch strain flips
    sign every step and hardly decays (A-stable, not L-stable) -- exactly as the recurrence says."""
    tau, h, eps0 = 1e-5, 0.01, 1e-2
    beam = planar_beam.PlanarBeam(1.0, 0.1, planar_beam.quadratic(100.0, 100.0, 10.0),
                                  branches=[planar_beam.maxwell(tau, EA=50.0, GA=50.0, EI=5.0)])
    p = Problem(beam, 1.0, 2, supports=[Support("left", "clamped"), Support("right", "clamped")],
                initial={"r": lambda x: np.vstack([(1 + eps0) * x[0], 0 * x[0]]),
                         "Gamma_1": lambda x: np.vstack([np.full(x.shape[1], eps0), 0 * x[0]])})
    values = []
    run(p, h, 10 * h, writer=Recorder(lambda prob: values.append(field(prob, "Gamma_1")[0, 0])))
    values = values[1:]   # the rows after t = 0
    q = midpoint_factor(h, tau)
    assert q == pytest.approx(-0.996, abs=1e-3)
    assert np.allclose(values, eps0 * q ** np.arange(1, 11), rtol=1e-12, atol=0)
    assert abs(values[-1]) > 0.95 * eps0        # exp(-t/tau) would be 0 (e^-10000)


@pytest.mark.parametrize("scene,over", [
    ("viscoelastic-cantilever-2d", {"t_end": 0.3, "tau1": 1e-8}),      # tau = 1e-5 h
    ("viscoelastic-cantilever-2d", {"t_end": 0.3, "tau1": 1e9}),       # tau = 3e9 T
    ("viscoelastic-string", {"t_end": 2.0, "tau1": 5e-7}),             # tau = 1e-5 h
    ("viscoelastic-string", {"t_end": 2.0, "tau1": 1e9}),
])
def test_stiff_and_slow_dashpots_run_stably(scene, over):
    res, summary = run_scene(scene, over)
    assert summary["status"] == "completed" and res.steps == round(over["t_end"] / summary["parameters"]["dt"])
    assert summary["max_balance_error_relative"] <= 1e-9
    H = res.column("H")
    assert np.all(np.isfinite(H)) and np.max(np.abs(H)) <= 10 * max(abs(H[0]), np.max(np.abs(res.column("supplied"))))
    assert np.all(np.diff(res.column("dissipated")) >= 0)


# -- parallel -----------------------------------------------------------------------------

@pytest.mark.mpi
def test_mpi_two_ranks_match_serial(tmp_path):
    args = ["run", "viscoelastic-cantilever-2d", "--set", "n_elements=12", "--set", "t_end=0.3",
            "--set", "dt=5e-3", "--set", "fy=-10", "--quiet"]   # 60 steps: the load and its release
    a, b, _ = serial_and_parallel(tmp_path, args)
    for col in ("H", "supplied", "dissipated", "tip_x", "tip_y"):
        scale = max(np.max(np.abs(a[col])), 1e-300)
        assert np.max(np.abs(a[col] - b[col])) <= 1e-8 * scale, col
    assert a["dissipated"][-1] > 0


def test_tau_inf_from_the_command_line_is_the_parallel_spring(tmp_path):
    """`--set tau1=inf` (the README's parallel spring; it was refused) runs cantilever-2d with the
    summed stiffnesses EA + EA1, GA + GA1, EI + EI1: the same tip history, nothing dissipated;
    -inf and nan stay refused."""
    from processes import history

    from rodfem.app.cli import main
    common = ["--set", "t_end=0.1", "--set", "n_elements=6", "--quiet"]
    assert main(["run", "viscoelastic-cantilever-2d", "--set", "tau1=inf", *common, "--out", str(tmp_path / "v")]) == 0
    summed = [f"{k}={float(v) * 1.1!r}" for k, v in (("EA", 21e6), ("GA", 6.73e6), ("EI", 175.0))]
    assert main(["run", "cantilever-2d", *sum((["--set", s] for s in summed), []), *common,
                 "--out", str(tmp_path / "e")]) == 0
    a, b = history(tmp_path / "v"), history(tmp_path / "e")
    assert np.max(a["dissipated"]) == 0.0
    for k in ("tip_x", "tip_y", "H"):
        assert np.max(np.abs(a[k] - b[k])) <= 1e-12 * np.max(np.abs(b[k])), k
    for bad in ("-inf", "nan"):
        assert main(["run", "viscoelastic-cantilever-2d", "--set", f"tau1={bad}", *common,
                     "--out", str(tmp_path / "x")]) == 2


@pytest.mark.parametrize("axis", [1, 2], ids=["about-d2", "about-d3"])
def test_anisotropic_rod_branch_creeps_per_component(axis):
    """A massless 3D rod with anisotropic compliances, equilibrium (GJ, EI2, EI3) = (3, 2, 1) and branch
    (3.5, 1.5, 0.5), clamped, under an end moment M0 about d2 or d3 held from t = 0 (starting in its
    instantaneous equilibrium, a circular arc): the bending stress M_axis of the equilibrium branch creeps by
    the scalar recurrence of *that* component, tau_c = tau (k + k1)/k with k = EI_axis, k1 = EI1_axis
    (the branch built from its first compliance only passed every isotropic test: its tau_c is then
    off by a factor (k + 3.5)/(k + k1), a recurrence error of order 1)."""
    tau, h, n, M0 = 0.05, 0.01, 20, 0.1
    K_eq, K_branch = np.array([3.0, 2.0, 1.0]), np.array([3.5, 1.5, 0.5])
    k, k1 = K_eq[axis], K_branch[axis]
    kappa0 = M0 / (k + k1)
    branch = cosserat_rod.maxwell(tau, C_N=(1e-2,) * 3, C_M=tuple(1 / K_branch))
    rod = cosserat_rod.CosseratRod(0.0, (0.0, 0.0, 0.0), (1e-3,) * 3, tuple(1 / K_eq), branches=[branch])
    e = np.eye(3)
    a, b = (e[0], e[2 if axis == 1 else 1])                     # the arc's plane: d1 and the other bending axis
    sign = -1.0 if axis == 1 else 1.0                            # (d1 x d3 = -d2)
    c, s = (lambda x: np.cos(kappa0 * x[0])), (lambda x: np.sin(kappa0 * x[0]))
    arc = {"r": lambda x: np.outer(a, s(x) / kappa0) + sign * np.outer(b, (1 - c(x)) / kappa0),
           "d1": lambda x: np.outer(a, c(x)) + sign * np.outer(b, s(x)),
           f"d{1 + (2 if axis == 1 else 1)}": lambda x: -sign * np.outer(a, s(x)) + np.outer(b, c(x)),
           f"d{1 + axis}": lambda x: np.outer(e[axis], np.ones(x.shape[1])),
           "M": lambda x: np.outer(k * kappa0 * e[axis], np.ones(x.shape[1])),
           "M_1": lambda x: np.outer(k1 * kappa0 * e[axis], np.ones(x.shape[1]))}
    moment = end_moment(lambda t: M0 * e[axis], "body")
    p = Problem(rod, 1.0, 4, loads=[moment], supports=[Support("left", "clamped")], initial=arc,
                newton_options=NEWTON)
    res = run(p, h, n * h)
    strain = field(p, "M")[:, axis] / k                          # the equilibrium branch's curvature
    rec, _ = creep_errors(h, strain, M0, k, k1, tau, n)
    assert rec <= 1e-4, rec          # measured 7.9e-7 (d2), 3.2e-6 (d3): the discrete arc's start
    assert np.max(np.abs(np.delete(field(p, "M"), axis, axis=1))) <= 1e-6 * M0
    assert res.max_balance_error <= 1e-12 * max(np.max(np.abs(res.column("H"))), 1e-300)
