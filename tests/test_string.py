"""Hyperelastic PH string (forms/string.py): energy balance per material, DG vs midpoint,
orders in time and space, wave speed, extreme cases, bad parameters."""
import json
import math
import os

import numpy as np
import pytest
import ufl
from mpi4py import MPI
from ufl.algorithms import expand_derivatives

from rodfem import Load, NewtonFailure, Problem, Support, run
from rodfem.driver import run_scene
from rodfem.scene import ParameterError

from forms.string import String
from rodfem.integrators import Step
from forms.string_materials import MATERIALS, biot, kirchhoff, logarithmic, tension_only

# the scenes by import (the CLI finds them through the entry points in pyproject.toml)
from demos.crane_manoeuvre import scene as crane  # noqa: E402
from demos.hanging_cable import scene as hanging  # noqa: E402
from demos.taut_string_wave import scene as wave  # noqa: E402

SCENES = {s.name: s for s in (hanging, crane, wave)}


def balance_ok(res, tol=1e-9):
    """Every step: |H_{n+1} - H_n - h y.u| <= tol max|H|."""
    H = res.column("H")
    return np.max(np.abs(res.column("balance_error"))) <= tol * np.max(np.abs(H))


def relative_balance(res):
    return np.max(np.abs(res.column("balance_error"))) / np.max(np.abs(res.column("H")))


# -- materials -------------------------------------------------------------------

@pytest.mark.parametrize("lam", [0.8, 1.0001, 1.3, 2.0])
def test_material_tensions(lam):
    EA = 7.0
    assert logarithmic(EA=EA).tension(lam) == pytest.approx(EA / 2 * (lam - 1 / lam), rel=1e-12)
    assert kirchhoff(EA=EA).tension(lam) == pytest.approx(EA / 2 * (lam ** 3 - lam), rel=1e-12)
    assert biot(EA=EA).tension(lam) == pytest.approx(EA * (lam - 1), rel=1e-12)
    t = tension_only(EA=EA).tension(lam)
    if lam >= 1.3:   # taut: the Kirchhoff law up to the transition width delta = 1e-3
        assert t == pytest.approx(EA / 2 * (lam ** 3 - lam), rel=2e-3)
    if lam < 1:      # slack: (almost) no tension, but positive and finite
        assert 0 < t < 1e-5 * EA


@pytest.mark.parametrize("name", sorted(MATERIALS))
def test_materials_same_small_strain_stiffness(name):
    m = MATERIALS[name](EA=3.0)
    eps = 1e-5   # dN/dlambda at lambda = 1 is EA (for tension-only: at the taut side, past the transition)
    lam0 = 1.0 if name != "tension-only" else 1.01
    slope = (m.tension(lam0 + eps) - m.tension(lam0 - eps)) / (2 * eps)
    expected = 3.0 if name != "tension-only" else kirchhoff(EA=3.0).tension(1.01 + eps) / (2 * eps) \
        - kirchhoff(EA=3.0).tension(1.01 - eps) / (2 * eps)
    assert slope == pytest.approx(expected, rel=1e-3 if name == "tension-only" else 1e-6)


@pytest.mark.parametrize("dC", [0.3, 2e-3, 9e-4, 1e-7, 0.0])
def test_scalar_discrete_gradient_property(dC):
    """grad_bar W dC = W(C1) - W(C0) on both sides of the threshold; = W'(C) at dC = 0."""
    W = logarithmic(EA=20.0)
    C0 = 0.7
    step = Step({"C": ufl.as_ufl(C0)}, {"C": ufl.as_ufl(C0 + dC)}, 1.0, "discrete-gradient")
    g = float(expand_derivatives(step.effort(W, ["C"])[0]))
    if dC == 0:
        assert g == pytest.approx(20.0 / 4 * (1 - 1 / C0), rel=1e-14)
    else:
        exact = 20.0 / 4 * (dC - math.log1p(dC / C0)) / dC   # cancellation-free quotient
        assert g == pytest.approx(exact, rel=1e-11, abs=1e-13)


# -- the energy balance ------------------------------------------------------------

@pytest.mark.parametrize("material", sorted(MATERIALS))
def test_discrete_gradient_balance_every_material(material):
    """3D swing (tilt + out-of-plane push) under gravity: balance per step to 1e-9 max|H|."""
    res, s = run_scene(hanging, {"material": material, "integrator": "discrete-gradient", "t_end": 2.0,
                                 "vy0": 1.0})
    assert res.steps == 200
    assert balance_ok(res), relative_balance(res)
    assert np.ptp(res.column("tip_x")) > 0.5 and np.ptp(res.column("tip_y")) > 0.1   # it really swings in 3D
    # gravity is an input: H alone changes, H - supplied is the conserved total energy
    assert np.ptp(res.column("H")) > 1.0


def test_midpoint_breaks_balance_for_logarithmic_not_for_kirchhoff():
    err = {}
    for material in ("logarithmic", "kirchhoff"):
        for rule in ("midpoint", "discrete-gradient"):
            res, _ = run_scene(hanging, {"material": material, "integrator": rule, "t_end": 1.0})
            err[material, rule] = relative_balance(res)
    # log law: midpoint violates the balance, by far more than the discrete gradient
    assert err["logarithmic", "midpoint"] > 1e-8
    assert err["logarithmic", "midpoint"] > 1e4 * err["logarithmic", "discrete-gradient"]
    # W quadratic in C: the midpoint rule IS a discrete gradient
    assert err["kirchhoff", "midpoint"] <= 1e-9


def test_crane_balance_with_end_masses_and_compatibility():
    res, s = run_scene(crane, {"trolley_mass": 0.2, "t_end": 3.0})
    assert balance_ok(res), relative_balance(res)
    assert np.max(res.column("tip_x")) > 0.5          # the load is carried along
    assert s["ports"] == ["trolley force", "gravity", "load weight"]


def test_strain_stays_compatible():
    """C_{n+1} = |d_s r_{n+1}|^2 cellwise after many steps (P1 r, DG0 C)."""
    p = hanging.values({"t_end": 1.0, "vy0": 1.0})
    pr = hanging.build(p, MPI.COMM_WORLD)
    run(pr, p["dt"], p["t_end"])
    X = pr.space.split(pr.x1)
    C0 = np.max(pr.space.nodal(pr.x1, "C")[1])
    from dolfinx import fem
    err = fem.assemble_scalar(fem.form((X["C"] - ufl.inner(X["r"].dx(0), X["r"].dx(0))) ** 2 * ufl.dx))
    assert math.sqrt(err) <= 1e-11 * C0


def test_static_equilibrium_stays_at_rest():
    res, _ = run_scene(crane, {"F0": 0.0, "t_end": 1.0})
    assert np.max(np.abs(res.column("tip_x"))) <= 1e-12
    tip_z = res.column("tip_z")
    assert np.ptp(tip_z) <= 1e-10 * abs(tip_z[0])
    assert np.max(np.abs(res.column("H") - res.column("H")[0])) <= 1e-12


# -- orders of convergence -------------------------------------------------------------

def test_second_order_in_time():
    def tip(dt):
        res, _ = run_scene(hanging, {"n_elements": 8, "dt": dt, "t_end": 0.4, "vy0": 1.0})
        return np.array([res.column(c)[-1] for c in ("tip_x", "tip_y", "tip_z")])
    # asymptotic once the axial modes (omega ~ 70/s at 8 elements) are resolved, omega h < 1
    ref = tip(0.4 / 2048)
    errs = [np.linalg.norm(tip(0.4 / k) - ref) for k in (32, 64, 128, 256)]
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all((orders > 1.9) & (orders < 2.1)), orders


def exact_hanging(s, L, EA, rhoA, g):
    """Log law, hanging under its weight: N = rhoA g (L - s), lambda = N/EA + sqrt(1 + (N/EA)^2);
    z(s) = -int_0^s lambda (closed form with asinh)."""
    k = rhoA * g / EA

    def F(u):   # int (u + sqrt(1 + u^2)) du
        return u ** 2 / 2 + (u * np.sqrt(1 + u ** 2) + np.arcsinh(u)) / 2
    u = k * (L - s)
    lam = u + np.sqrt(1 + u ** 2)
    return -(F(k * L) - F(u)) / k, lam ** 2


def test_spatial_order_static_hanging_cable():
    """Discrete equilibrium (= rest state of the dynamics) against the exact one:
    r in L2 converges with order 2 (P1), C in L2 with order 1 (DG0)."""
    L, EA, rhoA, g = 1.0, 20.0, 1.0, 9.81
    errs = []
    xg, wg = np.polynomial.legendre.leggauss(6)
    for n in (4, 8, 16, 32):
        p = hanging.values({"n_elements": n, "EA": EA, "rhoA": rhoA, "g": g, "angle": 0.0})
        pr = hanging.build(p, MPI.COMM_SELF)
        s, r = pr.space.nodal(pr.x0, "r")
        _, C = pr.space.nodal(pr.x0, "C")     # DG0: one value per cell, sorted by midpoint
        eR = eC = 0.0
        for i in range(n):
            a, b = s[i], s[i + 1]
            q = a + (b - a) * (xg + 1) / 2
            yh = r[i, 2] + (r[i + 1, 2] - r[i, 2]) * (q - a) / (b - a)
            ye, Ce = exact_hanging(q, L, EA, rhoA, g)
            eR += (b - a) / 2 * np.sum(wg * (yh - ye) ** 2)
            eC += (b - a) / 2 * np.sum(wg * (C[i, 0] - Ce) ** 2)
        errs.append((math.sqrt(eR), math.sqrt(eC)))
    errs = np.array(errs)
    orders = np.log2(errs[:-1] / errs[1:])
    assert np.all(np.abs(orders[:, 0] - 2) < 0.1), orders
    assert np.all(np.abs(orders[:, 1] - 1) < 0.1), orders


# -- the wave speed --------------------------------------------------------------

def pulse_peak(pr):
    s, r = pr.space.nodal(pr.x1, "r")
    w = r[:, 1]
    i = int(np.argmax(w))
    a, b, c = w[i - 1], w[i], w[i + 1]
    return s[i] + 0.5 * (s[1] - s[0]) * (a - c) / (a - 2 * b + c)   # parabola through 3 nodes


def test_wave_speed():
    from demos.taut_string_wave import speeds
    p = wave.values({})
    N, c_s, c = speeds(p)
    pr = wave.build(p, MPI.COMM_SELF)
    times, peaks = [], []

    class Track:
        def record(self, row, problem):
            times.append(row["t"])
            peaks.append(pulse_peak(problem))
    res = run(pr, p["dt"], p["t_end"], writer=Track())
    assert balance_ok(res)
    assert peaks[-1] - peaks[0] > 0.4 * p["L"]                  # it crossed a good part of the string
    measured = p["stretch"] * np.polyfit(times, peaks, 1)[0]     # spatial speed: x = lambda_0 s
    mu = p["rhoA"] / p["stretch"]                                # mass per stretched length
    assert abs(measured / math.sqrt(N / mu) - 1) < 0.01
    # the test tells the densities apart: with the reference rhoA it would be 4.9 % off
    assert abs(measured / math.sqrt(N / p["rhoA"]) - 1) > 0.03


# -- extreme cases -------------------------------------------------------------------

def test_stiff_cable():
    """EA / (rhoA g L) = 1.02e6: axial frequencies ~1e4 x those of the swing; no divergence,
    the balance holds and the cable stays (nearly) inextensible while it swings in 3D."""
    p = hanging.values({"EA": 1e7, "t_end": 1.0, "dt": 0.01, "vy0": 0.5})
    assert p["EA"] / (p["rhoA"] * p["g"] * p["L"]) >= 1e6
    pr = hanging.build(p, MPI.COMM_SELF)
    strain = []

    class Track:
        def record(self, row, problem):
            strain.append(np.max(np.abs(problem.space.nodal(problem.x1, "C")[1] - 1)))
    res = run(pr, p["dt"], p["t_end"], writer=Track())
    assert res.steps == 100 and balance_ok(res), relative_balance(res)
    # static strain at the top: C - 1 ~ 2 rhoA g L / EA = 2e-6; swinging changes the tension O(1)
    assert max(strain) < 1e-5
    assert np.ptp(res.column("tip_x")) > 0.3 and np.ptp(res.column("tip_y")) > 0.1


@pytest.mark.parametrize("EA, dt", [(20.0, 0.25), (1e7, 0.1)])
def test_large_time_steps(EA, dt):
    res, s = run_scene(hanging, {"EA": EA, "dt": dt, "t_end": 5.0})
    assert balance_ok(res), relative_balance(res)
    d = np.hypot(res.column("tip_x"), res.column("tip_z"))
    assert np.all(np.isfinite(d)) and np.max(d) < 2.0   # bounded (the stretch at EA = 20 is ~1.3)


def test_slack_cable_no_nans():
    """Tension-only cable, pinned at both ends only half its length apart (C = 0.25): it drops,
    snaps taut and swings; everything stays finite and the balance holds."""
    L = 1.0
    model = String(tension_only(EA=100.0), 1.0)
    pr = Problem(model, L, 20, loads=[Load("v", [0.0, -9.81, 0.0], "domain", "gravity")],
                 supports=[Support("left", "pinned"), Support("right", "pinned")],
                 initial={"r": lambda x: np.vstack([0.5 * x[0], 0 * x[0], 0 * x[0]])},
                 integrator="discrete-gradient", comm=MPI.COMM_SELF)
    C = []

    class Track:
        def record(self, row, problem):
            C.append(problem.space.nodal(problem.x1, "C")[1][:, 0])
    res = run(pr, 0.01, 1.0, writer=Track())
    C = np.array(C)
    assert np.all(np.isfinite(res.column("H"))) and np.all(np.isfinite(C))
    assert C[0].max() < 0.3 and C.max() > 1.0     # slack at the start, taut later
    assert balance_ok(res), relative_balance(res)


# -- bad parameters -----------------------------------------------------------------------

@pytest.mark.parametrize("scene", ["hanging-cable", "crane-manoeuvre", "taut-string-wave"])
@pytest.mark.parametrize("name, value", [("EA", "0"), ("EA", "-5"), ("rhoA", "0"), ("rhoA", "-1")])
def test_bad_material_parameters_scene(scene, name, value):
    with pytest.raises(ParameterError) as e:
        SCENES[scene].values({name: value})
    msg = str(e.value)
    assert "\n" not in msg and f"'{name}'" in msg and "> 0" in msg


def test_bad_material_parameters_model():
    with pytest.raises(ValueError, match="EA must be a positive number"):
        logarithmic(EA=-1.0)
    with pytest.raises(ValueError, match="rhoA must be a positive number"):
        String(kirchhoff(EA=1.0), 0.0)
    with pytest.raises(ValueError, match="end_masses"):
        String(kirchhoff(EA=1.0), 1.0, end_masses={"right": -1.0})


def test_bad_parameter_cli(rodfem, tmp_path):
    out = rodfem("run", "hanging-cable", "--set", "EA=-1", "--out", str(tmp_path / "x"))
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "parameter 'EA' must be a number > 0" in lines[0]


@pytest.mark.mpi
def test_crane_mpi_matches_serial(rodfem, tmp_path):
    args = ["--set", "t_end=1.0", "--quiet"]
    r1 = rodfem("run", "crane-manoeuvre", *args, "--out", str(tmp_path / "s"))
    r2 = rodfem("run", "crane-manoeuvre", *args, "--out", str(tmp_path / "p"), np=2)
    assert r1.returncode == 0 and r2.returncode == 0, r2.stderr
    s1, s2 = (json.load(open(os.path.join(tmp_path, d, "summary.json"))) for d in ("s", "p"))
    assert s2["mpi_ranks"] == 2 and s2["max_balance_error_relative"] <= 1e-9
    for k in ("tip_x", "tip_z", "H"):
        assert s2["final"][k] == pytest.approx(s1["final"][k], rel=1e-9, abs=1e-12)
