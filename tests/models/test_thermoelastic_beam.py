"""Thermoelastic planar beam (forms/thermoelastic_beam.py): total energy exact and entropy production
>= 0 per step, the closed-form thermal axial force and expansion (demos/heated_beam.py), the heat ports,
bad input, serial = mpirun -n 2."""
import numpy as np
import pytest
from processes import assert_same_history, rodfem, serial_and_parallel

from rodfem import Problem, Support, run
from rodfem.app.driver import run_scene
from rodfem.demos.heated_beam import free_stretch
from rodfem.demos.heated_beam import reference as beam_reference
from rodfem.demos.heated_beam import scene as heated_beam
from rodfem.forms.heat_ports import Convection, HeatFlux
from rodfem.forms.planar_beam import PlanarBeam, log_axial, quadratic
from rodfem.forms.thermoelastic_beam import ThermoelasticBeam

THETA0 = 300.0
SCALE = 2.0 * THETA0   # c theta0 L: the size of the internal energy


def swinging(integrator="discrete-gradient", energy=None, loads=(), alpha=5e-4, kappa_th=0.5, degree=1, n=12):
    """A beam clamped at s = 0 and pinned at s = L, set swinging (transverse and axial velocity) with a
    hot spot of +40 K."""
    W = energy or log_axial(EA=100.0, GA=100.0, EI=1.0)
    model = ThermoelasticBeam(1.0, 0.01, W, alpha=alpha, c=2.0, kappa_th=kappa_th, theta0=THETA0, degree=degree)
    initial = {"r": lambda x: np.vstack([x[0], 0 * x[0]]),
               "v": lambda x: np.vstack([0.3 * np.sin(np.pi * x[0]), 2 * np.sin(np.pi * x[0])]),
               "theta": lambda x: THETA0 + 40 * np.exp(-((x[0] - 0.3) / 0.15) ** 2)}
    return Problem(model, 1.0, n, loads=list(loads), initial=initial, integrator=integrator,
                   supports=[Support("left", "clamped"), Support("right", "pinned")])


@pytest.mark.parametrize("degree", [1, 2])
def test_total_energy_exact_and_entropy_production_nonnegative(degree):
    """Isolated beam, non-quadratic W (log_axial) and e: H_{n+1} = H_n to round-off (measured 4e-14 J =
    7e-17 c theta0 L at degree 1) and every step S_{n+1} - S_n = h int kappa (theta'/theta)^2 > 0 exactly;
    the motion moves the temperature (coupled)."""
    res = run(swinging(degree=degree, n=12 if degree == 1 else 6), 0.01, 0.3)
    assert np.max(np.abs(np.diff(res.column("H")))) <= 1e-13 * SCALE
    assert np.max(np.abs(res.column("balance_error"))) <= 1e-13 * SCALE
    dS = np.diff(res.column("entropy"))
    production = 0.01 * res.column("entropy_production")[1:]
    assert np.all(production > 0) and np.all(dS > 0)
    assert np.max(np.abs(dS - production)) <= 1e-12 * np.max(production)
    assert np.ptp(res.column("mean_temperature")) > 1e-2


def test_midpoint_rule_is_not_exact_for_the_exponential_energy():
    """The midpoint rule on the same run: its energy error is visible (> 1e-9 c theta0 L): the rule matters."""
    res = run(swinging("midpoint"), 0.01, 0.1)
    assert np.max(np.abs(res.column("balance_error"))) > 1e-9 * SCALE


def test_no_expansion_is_the_planar_beam():
    """alpha = 0: the mechanics is the PlanarBeam's to round-off (same W, same rule), kappa = 0: the entropy
    is constant to round-off."""
    W = quadratic(EA=100.0, GA=100.0, EI=1.0)
    thermo = run(swinging(energy=W, alpha=0.0, kappa_th=0.0), 0.01, 0.1)
    init = {"r": lambda x: np.vstack([x[0], 0 * x[0]]),
            "v": lambda x: np.vstack([0.3 * np.sin(np.pi * x[0]), 2 * np.sin(np.pi * x[0])])}
    plain = run(Problem(PlanarBeam(1.0, 0.01, W), 1.0, 12, initial=init, integrator="discrete-gradient",
                        supports=[Support("left", "clamped"), Support("right", "pinned")]), 0.01, 0.1)
    for col in ("mean_x", "mean_y"):
        assert np.max(np.abs(thermo.column(col) - plain.column(col))) <= 1e-12
    S = thermo.column("entropy")
    assert np.max(np.abs(S - S[0])) <= 1e-13 * abs(S[0])


@pytest.mark.parametrize("dtheta", [50.0, -80.0])
@pytest.mark.parametrize("material", ["hooke", "log-axial"])
def test_clamped_thermal_axial_force(dtheta, material):
    """Clamped at both ends at the reference length: N_1 = -EA alpha dtheta exactly, the beam at rest."""
    over = {"ends": "clamped", "dtheta": dtheta, "EA": 70.0, "alpha": 2e-3, "material": material}
    res, _ = run_scene(heated_beam, over)
    N = -70.0 * 2e-3 * dtheta
    assert beam_reference(heated_beam.values(over))["mean_axial_force"] == N
    assert np.max(np.abs(res.column("mean_axial_force") - N)) <= 1e-12 * abs(N)
    assert np.max(np.abs(res.column("arc_length") - 1.0)) <= 1e-13


@pytest.mark.parametrize("material", ["hooke", "log-axial"])
def test_free_thermal_expansion(material):
    """Free beam at theta0 + 50 K started at its stress-free length: stays there with N_1 = 0; hooke:
    Delta L = alpha L dtheta exactly (the law of this energy), log-axial L/(1 - alpha dtheta)."""
    over = {"ends": "free", "material": material}
    res, _ = run_scene(heated_beam, over)
    expected = 1.0 + 1e-3 * 50.0 if material == "hooke" else 1.0 / (1.0 - 1e-3 * 50.0)
    assert free_stretch(heated_beam.values(over)) == pytest.approx(expected, rel=1e-15)
    assert np.max(np.abs(res.column("arc_length") - expected)) <= 1e-12
    assert np.max(np.abs(res.column("mean_axial_force"))) <= 1e-12 * 100.0
    assert np.max(np.abs(res.column("mean_temperature") - (THETA0 + 50.0))) <= 1e-12 * THETA0


def test_released_free_beam_expands_and_cools():
    """Released at its reference length, the free heated beam vibrates about its expanded length
    L (1 + alpha dtheta): H exact, entropy non-decreasing, the expansion cools it (thermoelastic effect)."""
    res, _ = run_scene(heated_beam, {"ends": "free", "start": "reference", "t_end": 0.3, "dt": 0.005})
    length = res.column("arc_length")
    assert length.max() > 1.05 > length.min() == pytest.approx(1.0)
    assert np.max(np.abs(res.column("balance_error"))) <= 1e-13 * SCALE
    assert np.all(np.diff(res.column("entropy")) >= 0)
    assert res.column("mean_temperature")[1:].max() < THETA0 + 50.0


def test_ports_energy_balance_exact():
    """Swinging beam with a time-dependent heat flux at s = L and convection: H_{n+1} - H_n = h y.u to
    round-off, and the heat supplied moves the energy."""
    ports = [HeatFlux(value=lambda t: np.array(20.0 * np.sin(10 * t)), where="right", name="heater"),
             Convection(value=310.0, h_c=0.5)]
    res = run(swinging(loads=ports), 0.01, 0.2)
    assert np.max(np.abs(res.column("balance_error"))) <= 1e-13 * SCALE
    assert np.ptp(res.column("supplied")) > 0.1


@pytest.mark.parametrize("bad", [{"c": 0.0}, {"c": -1.0}, {"kappa_th": -1.0}, {"theta0": 0.0},
                                 {"alpha": float("nan")}])
def test_bad_model_parameters(bad):
    kw = {**dict(alpha=1e-3, c=1.0, kappa_th=1.0, theta0=THETA0), **bad}
    with pytest.raises(ValueError, match=next(iter(bad))):
        ThermoelasticBeam(1.0, 0.01, quadratic(EA=1.0, GA=1.0, EI=1.0), **kw)


@pytest.mark.parametrize("args, message", [
    (["--set", "dtheta=-400"], "parameter 'dtheta' must be > -theta0"),
    (["--set", "material=log-axial", "--set", "dtheta=2000"], "parameter 'dtheta' must be < 1/alpha"),
    (["--set", "c=0"], "parameter 'c' must be a number > 0"),
])
def test_bad_scene_parameters_one_line(args, message):
    p = rodfem("run", "heated-beam", *args, "--quiet", timeout=120)
    assert p.returncode == 2 and message in p.stderr and "Traceback" not in p.stderr, p.stderr


@pytest.mark.mpi
def test_mpi_two_ranks_match_serial(tmp_path):
    """heated-beam released, with a heat flux at the left end: serial = 2 ranks to solver tolerance."""
    args = ["run", "heated-beam", "--set", "start=reference", "--set", "Q=20", "--set", "t_end=0.05", "--quiet"]
    a, b, _ = serial_and_parallel(tmp_path / "beam", args, timeout=300)
    assert_same_history(a, b, 1e-9, skip=("newton_its", "balance_error"))


@pytest.mark.parametrize("kind", ["maxwell", "kelvin-voigt", "rayleigh"])
def test_dashpot_work_becomes_heat(kind):
    """A Maxwell branch, Kelvin-Voigt or Rayleigh damping on the thermoelastic beam with alpha = 0: the motion
    is the damped PlanarBeam's to round-off, the heat gained c L (mean theta - theta0) equals that beam's
    `dissipated` at every time, nothing is booked as dissipated, H is exact and the entropy grows.  Newton to
    |F| <= 1e-13 (both runs): the entropy row's residual enters the energy times theta = 300 K, and at the
    default |F| <= 1e-10 the viscous heat left 1.4e-10 J per step (measured; 2e-14 J at 1e-13/1e-14)."""
    from rodfem.forms.planar_beam import kelvin_voigt, maxwell, rayleigh
    extra = {"maxwell": {"branches": [maxwell(0.05, 50.0, 50.0, 0.5)]},
             "kelvin-voigt": {"damping": kelvin_voigt(0.01, 100.0, 100.0, 1.0)},
             "rayleigh": {"damping": rayleigh(0.5, 0.005, 100.0, 100.0, 1.0)}}[kind]
    W = log_axial(EA=100.0, GA=100.0, EI=1.0)
    init = {"r": lambda x: np.vstack([x[0], 0 * x[0]]),
            "v": lambda x: np.vstack([0.3 * np.sin(np.pi * x[0]), 2 * np.sin(np.pi * x[0])])}
    sup = [Support("left", "clamped"), Support("right", "pinned")]
    tight = {"snes_atol": 1e-13}
    # the plain beam to 1e-12: on DOLFINx 0.9 its Kelvin-Voigt residual stalls just above 1e-13, and the
    # sub-steps that follow would change its time steps (not its physics)
    plain = run(Problem(PlanarBeam(1.0, 0.01, W, **extra), 1.0, 12, initial=init, supports=sup,
                        integrator="discrete-gradient", newton_options={"snes_atol": 1e-12}), 0.01, 0.3)
    model = ThermoelasticBeam(1.0, 0.01, W, alpha=0.0, c=2.0, kappa_th=0.5, theta0=THETA0, **extra)
    thermo = run(Problem(model, 1.0, 12, initial=init, supports=sup, integrator="discrete-gradient",
                         newton_options=tight), 0.01, 0.3)
    assert "dissipated" not in thermo.rows[0]
    for col in ("mean_x", "mean_y"):
        assert np.max(np.abs(thermo.column(col) - plain.column(col))) <= 1e-12
    heat, lost = 2.0 * (thermo.column("mean_temperature") - THETA0), plain.column("dissipated")
    assert lost[-1] > 1e-3 and np.max(np.abs(heat - lost)) <= 1e-13 * SCALE
    assert np.max(np.abs(thermo.column("balance_error"))) <= 1e-13 * SCALE
    assert np.all(np.diff(thermo.column("entropy")) > 0)
