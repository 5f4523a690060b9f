"""Thermoelastic string (forms/thermoelastic_string.py, forms/heat_ports.py): total energy exact and
entropy production >= 0 per step, the closed-form thermal expansion and stress, the heat equation's
exact solutions and order in space, convection against its exact discrete recurrence, heat ports,
bad input, serial = mpirun -n 2."""
import numpy as np
import pytest
from processes import assert_same_history, rodfem, serial_and_parallel

from rodfem import Problem, Support, run
from rodfem.app.driver import run_scene
from rodfem.demos.heat_conduction import exact
from rodfem.demos.heat_conduction import scene as conduction
from rodfem.demos.heated_bar import reference as bar_reference
from rodfem.demos.heated_bar import scene as heated_bar
from rodfem.demos.thermoelastic_damping import analytic, measured
from rodfem.demos.thermoelastic_damping import scene as damping
from rodfem.forms.heat_ports import Convection, HeatFlux
from rodfem.forms.string_materials import kirchhoff, logarithmic
from rodfem.forms.thermoelastic_string import ThermoelasticString, stress_free_strain

THETA0 = 300.0


def swinging(integrator="discrete-gradient", material=logarithmic, loads=(), alpha=5e-4, kappa=0.5, n=12):
    """A pinned string pre-stretched by 5 % (tension 4.9 N) swinging with a hot spot (+40 K, thermal stress
    -EA alpha 40 = -2 N: the string stays in tension; in compression it would buckle at the grid scale)."""
    model = ThermoelasticString(material(EA=100.0), 1.0, alpha=alpha, c=2.0, kappa=kappa, theta0=THETA0)
    initial = {"r": lambda x: np.vstack([1.05 * x[0], 0.05 * np.sin(np.pi * x[0]), 0.02 * np.sin(2 * np.pi * x[0])]),
               "theta": lambda x: THETA0 + 40 * np.exp(-((x[0] - 0.3) / 0.15) ** 2)}
    return Problem(model, 1.0, n, loads=list(loads), initial=initial, integrator=integrator,
                   supports=[Support("left", "pinned"), Support("right", "pinned")])


def test_total_energy_exact_and_entropy_production_nonnegative():
    """Isolated string, non-quadratic W and e: H_{n+1} = H_n to round-off (|balance| <= 1e-13 c theta0 L,
    measured 2e-14 relative) and every step S_{n+1} - S_n = h int kappa (theta'/theta)^2 >= 0 exactly;
    the mechanical energy goes into heat and back (the temperature moves)."""
    p = swinging()
    res = run(p, 0.01, 0.3)
    scale = 2.0 * THETA0   # c theta0 L: the size of the internal energy
    assert np.max(np.abs(np.diff(res.column("H")))) <= 1e-13 * scale
    assert np.max(np.abs(res.column("balance_error"))) <= 1e-13 * scale
    dS = np.diff(res.column("entropy"))
    production = 0.01 * res.column("entropy_production")[1:]
    assert np.all(production > 0) and np.all(dS > 0)
    assert np.max(np.abs(dS - production)) <= 1e-12 * np.max(production)
    assert np.ptp(res.column("mean_temperature")) > 1e-4   # coupled: the temperature changes


def test_midpoint_rule_is_not_exact_for_the_exponential_energy():
    """The same run with the midpoint rule: e(C, eta) is not quadratic, its energy error is visible
    (> 1e-9 c theta0 L) where the discrete gradient's is at round-off: the rule matters."""
    res = run(swinging("midpoint"), 0.01, 0.1)
    assert np.max(np.abs(res.column("balance_error"))) > 1e-9 * 2.0 * THETA0


def test_no_conduction_no_entropy_production():
    """kappa = 0 (adiabatic): the entropy is constant to round-off, the energy exact."""
    res = run(swinging(kappa=0.0), 0.01, 0.1)
    S = res.column("entropy")
    assert np.max(np.abs(S - S[0])) <= 1e-13 * max(abs(S[0]), 1.0)
    assert np.max(np.abs(res.column("balance_error"))) <= 1e-13 * 2.0 * THETA0


@pytest.mark.parametrize("material", ["kirchhoff", "logarithmic"])
def test_heated_bar_free_expansion_closed_form(material):
    """Free bar at theta0 + 50 K, started at its stress-free length: it stays there (v = 0, N = 0) and
    its length is the closed form (kirchhoff: L sqrt(1 + 2 alpha dtheta) = L (1 + alpha dtheta) + O(dtheta^2))."""
    over = {"ends": "free", "material": material}
    res, _ = run_scene(heated_bar, over)
    ref = bar_reference(heated_bar.values(over))
    if material == "kirchhoff":
        assert ref["arc_length"] == pytest.approx(np.sqrt(1 + 2 * 1e-3 * 50.0), rel=1e-14)
    assert np.max(np.abs(res.column("arc_length") - ref["arc_length"])) <= 1e-10
    assert np.max(np.abs(res.column("mean_tension"))) <= 1e-10 * 100.0
    assert np.max(np.abs(res.column("mean_temperature") - (THETA0 + 50.0))) <= 1e-10 * THETA0


@pytest.mark.parametrize("dtheta", [50.0, -80.0])
def test_heated_bar_clamped_thermal_stress(dtheta):
    """Clamped at the reference length: N = -EA alpha dtheta exactly (compression heated, tension cooled)."""
    res, _ = run_scene(heated_bar, {"ends": "clamped", "dtheta": dtheta, "EA": 70.0, "alpha": 2e-3})
    assert np.max(np.abs(res.column("mean_tension") + 70.0 * 2e-3 * dtheta)) <= 1e-10 * 70.0 * 2e-3 * abs(dtheta)
    assert np.max(np.abs(res.column("arc_length") - 1.0)) <= 1e-12


def test_released_free_bar_expands_with_energy_exact():
    """The free bar released at its reference length expands past its stress-free length (axial waves;
    no mechanical damping): H conserved to round-off, entropy non-decreasing, the expansion cools it
    (the mean temperature drops below theta0 + dtheta: the thermoelastic effect)."""
    res, _ = run_scene(heated_bar, {"ends": "free", "start": "reference", "t_end": 0.3, "dt": 0.005})
    C_free = stress_free_strain(kirchhoff(EA=100.0), 100.0 * 1e-3, 50.0)
    length = res.column("arc_length")
    assert length.max() > np.sqrt(C_free) > length.min() == pytest.approx(1.0)
    assert np.max(np.abs(res.column("balance_error"))) <= 1e-13 * THETA0
    assert np.all(np.diff(res.column("entropy")) >= 0)
    assert res.column("mean_temperature")[1:].max() < THETA0 + 50.0


@pytest.mark.parametrize("start", ["cosine", "flux"])
def test_heat_equation_order_two_in_space(start):
    """P1 entropy: the end temperatures at t_end against the exact solution converge with order 2
    (observed 1.96-2.04 for n = 8, 16, 32, 64); dt small enough that the time error is far below."""
    errors = []
    for n in (8, 16, 32):
        over = {"start": start, "n_elements": n, "dt": 1e-3 if start == "cosine" else 2.5e-4}
        res, _ = run_scene(conduction, over)
        p = conduction.values(over)
        errors.append(max(abs(res.column("temperature_left")[-1] - float(exact(p, 0.0, p["t_end"]))),
                          abs(res.column("temperature_right")[-1] - float(exact(p, p["L"], p["t_end"])))))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 1.9) and np.all(orders < 2.1), orders
    assert errors[-1] < 1e-2


def test_heat_flux_port_energy_and_mean_temperature():
    """A heat flux Q into s = 0: H - supplied constant to round-off, supplied = Q t, and (alpha = 0)
    the mean temperature theta0 + Q t/(c L) to round-off; the port's output is the end's temperature."""
    res, _ = run_scene(conduction, {"start": "flux", "n_elements": 16, "t_end": 0.02, "Q": 50.0})
    t = res.column("t")
    assert np.max(np.abs(res.column("supplied") - 50.0 * t)) <= 1e-12 * 50.0
    assert np.max(np.abs(res.column("H") - res.column("H")[0] - res.column("supplied"))) <= 1e-12 * THETA0
    assert np.max(np.abs(res.column("mean_temperature") - THETA0 - 50.0 * t)) <= 1e-12 * THETA0
    # the output is the step's temperature, between theta(t_n) and theta(t_{n+1}) at the end
    out, end = res.column("heat_temperature"), res.column("temperature_left")
    assert np.max(np.abs(out[1:] - 0.5 * (end[1:] + end[:-1]))) < 0.01 * np.max(end - THETA0)


@pytest.mark.parametrize("integrator", ["discrete-gradient", "midpoint"])
def test_convection_exact_recurrence(integrator):
    """Uniform string, convection to theta_env only (no gradient, no conduction): the step's temperature
    theta_bar is the logarithmic mean of theta_n, theta_{n+1} (the discrete gradient of c theta0 exp(eta/c)),
    with the midpoint rule the temperature at eta_m, the geometric mean; the entropy row is
    theta_bar c ln(theta_{n+1}/theta_n) = h h_c (theta_env - theta_bar), exactly (for the log mean:
    c (theta_{n+1} - theta_n), the energy).  Both within O(h^2) of theta_env + (theta0 - theta_env) exp(-h_c t/c)."""
    c, hc, env, h = 2.0, 3.0, 400.0, 0.05
    model = ThermoelasticString(kirchhoff(EA=10.0), 1.0, alpha=0.0, c=c, kappa=1.0, theta0=THETA0)
    p = Problem(model, 1.0, 4, loads=[Convection(value=env, h_c=hc)], integrator=integrator,
                initial={"r": lambda x: np.vstack([x[0], 0 * x[0], 0 * x[0]])},
                supports=[Support("left", "pinned"), Support("right", "pinned")])
    res = run(p, h, 1.0)
    th = res.column("mean_temperature")
    if integrator == "discrete-gradient":
        mean = (th[1:] - th[:-1]) / np.log(th[1:] / th[:-1])
    else:
        mean = np.sqrt(th[1:] * th[:-1])
    assert np.max(np.abs(mean * c * np.log(th[1:] / th[:-1]) - h * hc * (env - mean))) <= 1e-12 * c * THETA0
    exact_t = env + (THETA0 - env) * np.exp(-hc * res.column("t") / c)
    assert 1e-5 < np.max(np.abs(th - exact_t)) <= 1e-3 * (env - THETA0)
    if integrator == "discrete-gradient":
        assert np.max(np.abs(res.column("balance_error"))) <= 1e-13 * c * THETA0


def test_ports_and_coupled_energy_balance_exact():
    """Swinging coupled string with a heat flux (time-dependent) and convection: H_{n+1} - H_n = h y.u
    to round-off."""
    ports = [HeatFlux(value=lambda t: np.array(20.0 * np.sin(10 * t)), where="right", name="heater"),
             Convection(value=310.0, h_c=0.5)]
    res = run(swinging(loads=ports), 0.01, 0.2)
    assert np.max(np.abs(res.column("balance_error"))) <= 1e-13 * 2.0 * THETA0
    assert np.ptp(res.column("supplied")) > 0.1


@pytest.mark.parametrize("kind", ["kelvin-voigt", "rayleigh"])
def test_viscous_damping_work_becomes_heat(kind):
    """Kelvin-Voigt / Rayleigh damping (forms/damping.py) on the thermoelastic string with alpha = 0: the
    motion is the damped String's to round-off, the heat gained is its `dissipated`, H exact."""
    from rodfem.forms.string import String, kelvin_voigt, rayleigh
    damping = kelvin_voigt(0.01, 100.0) if kind == "kelvin-voigt" else rayleigh(0.5, 0.005, 100.0)
    init = {"r": lambda x: np.vstack([1.05 * x[0], 0.05 * np.sin(np.pi * x[0]), 0.02 * np.sin(2 * np.pi * x[0])])}
    sup = [Support("left", "pinned"), Support("right", "pinned")]
    plain = run(Problem(String(logarithmic(EA=100.0), 1.0, damping=damping), 1.0, 12, initial=init, supports=sup,
                        integrator="discrete-gradient"), 0.01, 0.3)
    model = ThermoelasticString(logarithmic(EA=100.0), 1.0, alpha=0.0, c=2.0, kappa=0.5, theta0=THETA0,
                                damping=damping)
    thermo = run(Problem(model, 1.0, 12, initial=init, supports=sup, integrator="discrete-gradient"), 0.01, 0.3)
    assert "dissipated" not in thermo.rows[0]
    for col in ("mean_x", "mean_y", "mean_z"):
        assert np.max(np.abs(thermo.column(col) - plain.column(col))) <= 1e-12
    heat, lost = 2.0 * (thermo.column("mean_temperature") - THETA0), plain.column("dissipated")
    # measured 1.8e-11 J (Rayleigh) = 3e-14 of c theta0 L: the Newton tolerances of both runs summed over the steps
    assert lost[-1] > 1e-3 and np.max(np.abs(heat - lost)) <= 1e-13 * 2.0 * THETA0
    assert np.max(np.abs(thermo.column("balance_error"))) <= 1e-13 * 2.0 * THETA0


def test_maxwell_dashpot_work_becomes_heat():
    """A Maxwell branch on the thermoelastic string with alpha = 0 (mechanics blind to temperature): the
    motion is that of the viscoelastic String (forms/string.py) to round-off, the heat gained
    c L (mean theta - theta0) equals that String's `dissipated` column at every time, nothing is booked as
    dissipated, H (with the branch's energy) is exact, and the entropy grows."""
    from rodfem.forms.string import String, maxwell
    br = [maxwell(0.05, 50.0)]
    init = {"r": lambda x: np.vstack([1.05 * x[0], 0.05 * np.sin(np.pi * x[0]), 0.02 * np.sin(2 * np.pi * x[0])])}
    sup = [Support("left", "pinned"), Support("right", "pinned")]
    visco = run(Problem(String(logarithmic(EA=100.0), 1.0, branches=br), 1.0, 12, initial=init, supports=sup,
                        integrator="discrete-gradient"), 0.01, 0.3)
    model = ThermoelasticString(logarithmic(EA=100.0), 1.0, alpha=0.0, c=2.0, kappa=0.5, theta0=THETA0, branches=br)
    thermo = run(Problem(model, 1.0, 12, initial=init, supports=sup, integrator="discrete-gradient"), 0.01, 0.3)
    assert "dissipated" not in thermo.rows[0]
    for col in ("mean_x", "mean_y", "mean_z"):
        assert np.max(np.abs(thermo.column(col) - visco.column(col))) <= 1e-12
    heat = 2.0 * (thermo.column("mean_temperature") - THETA0)
    lost = visco.column("dissipated")
    # to the round-off of the heat content c theta0 L = 600 J (measured 1.8e-12 J = 3e-15 of it)
    assert lost[-1] > 1e-3 and np.max(np.abs(heat - lost)) <= 2e-14 * 2.0 * THETA0
    assert np.max(np.abs(thermo.column("balance_error"))) <= 1e-13 * 2.0 * THETA0
    assert np.all(np.diff(thermo.column("entropy")) > 0)


@pytest.mark.parametrize("omega_tau", [0.3, 1.0, 3.0])
def test_thermoelastic_damping_ratio_against_zener(omega_tau):
    """Axial mode 1 of a pinned bar with conduction: the fitted damping ratio and frequency against the
    roots of the linear 1D model's cubic (Zener's relaxation; demos/thermoelastic_damping.py).  Measured
    at n = 16, dt = 4e-3: zeta within 0.8 %, omega within 0.07 % (n = 32, dt = 2e-3: 0.2 %, 0.02 %)."""
    over = {"omega_tau": omega_tau, "n_elements": 16, "dt": 4e-3}
    res, _ = run_scene(damping, over)
    p = damping.values(over)
    zeta, omega, _ = analytic(p)
    zeta_h, omega_h = measured(res.column("t"), res.column("mean_x") - 0.5 * p["L"], p)
    assert zeta > 0.02 and abs(zeta_h - zeta) <= 0.012 * zeta
    assert abs(omega_h - omega) <= 1e-3 * omega
    assert np.all(np.diff(res.column("entropy")) >= 0)


@pytest.mark.parametrize("bad", [{"c": 0.0}, {"c": -1.0}, {"kappa": -1.0}, {"theta0": 0.0}, {"alpha": float("nan")}])
def test_bad_model_parameters(bad):
    kw = {**dict(alpha=1e-3, c=1.0, kappa=1.0, theta0=THETA0), **bad}
    name = next(iter(bad))
    with pytest.raises(ValueError, match=name):
        ThermoelasticString(kirchhoff(EA=1.0), 1.0, **kw)


def test_bad_ports():
    from rodfem.errors import InputError
    with pytest.raises(InputError, match="h_c"):
        Convection(value=300.0, h_c=-1.0)
    with pytest.raises(InputError, match="where"):
        HeatFlux(value=1.0, where="domain")


@pytest.mark.parametrize("args, message", [
    (["--set", "dtheta=-400"], "parameter 'dtheta' must be > -theta0"),
    (["--set", "c=0"], "parameter 'c' must be a number > 0"),
])
def test_bad_scene_parameters_one_line(args, message):
    p = rodfem("run", "heated-bar", *args, "--quiet", timeout=120)
    assert p.returncode == 2 and message in p.stderr and "Traceback" not in p.stderr, p.stderr


@pytest.mark.mpi
def test_mpi_two_ranks_match_serial(tmp_path):
    """heat-conduction with a flux port and heated-bar released: serial = 2 ranks to solver tolerance."""
    for args in (["run", "heat-conduction", "--set", "n_elements=16", "--set", "t_end=0.01", "--quiet"],
                 ["run", "heated-bar", "--set", "start=reference", "--set", "t_end=0.05", "--quiet"]):
        a, b, _ = serial_and_parallel(tmp_path / args[1], args, timeout=300)
        assert_same_history(a, b, 1e-9, skip=("newton_its", "balance_error"))
