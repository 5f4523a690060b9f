"""The heat meter of forms/heat_ports.py: the history column `heat_supplied` is the cumulative heat the
heat ports supplied, exactly (the flux port's int Q dt, the convection's sum of h times its power), apart
from the mechanical ports' work in `supplied`; string and beam."""
import numpy as np
import pytest

from rodfem import Problem, Support, run
from rodfem.app.driver import run_scene
from rodfem.core.ports import Load
from rodfem.demos.heat_conduction import scene as conduction
from rodfem.demos.heated_beam import scene as heated_beam
from rodfem.forms.heat_ports import Convection, HeatFlux
from rodfem.forms.planar_beam import log_axial
from rodfem.forms.thermoelastic_beam import ThermoelasticBeam

THETA0 = 300.0


@pytest.mark.parametrize("scene, over", [(conduction, {"start": "flux", "n_elements": 16, "t_end": 0.02, "Q": 50.0}),
                                         (heated_beam, {"start": "reference", "Q": 50.0, "t_end": 0.05}),
                                         (heated_beam, {"start": "reference", "Q": 50.0, "t_end": 0.05,
                                                        "adaptive": "true"})])
def test_constant_flux_heat_supplied_is_q_t(scene, over):
    """A constant heat flux Q = 50 W into s = 0 (string: heat-conduction, beam: heated-beam released, also with
    adaptive steps): heat_supplied = Q t to round-off, and it is all of `supplied` (no mechanical port),
    starting at 0."""
    res, _ = run_scene(scene, over)
    t, q = res.column("t"), res.column("heat_supplied")
    assert q[0] == 0.0
    assert np.max(np.abs(q - 50.0 * t)) <= 1e-13 * 50.0 * t[-1]
    assert np.max(np.abs(q - res.column("supplied"))) <= 1e-13 * 50.0 * t[-1]


def test_heat_supplied_apart_from_mechanical_work():
    """A swinging beam with a time-dependent heat flux, convection and a mechanical end force: heat_supplied
    is the sum of h times the ports' step powers (the columns heater_power, convection_power) to round-off,
    supplied - heat_supplied the force's work (non-zero), and H - H_0 = supplied exactly."""
    h = 0.01
    model = ThermoelasticBeam(1.0, 0.01, log_axial(EA=100.0, GA=100.0, EI=1.0), alpha=5e-4, c=2.0, kappa_th=0.5,
                              theta0=THETA0)
    ports = [HeatFlux(value=lambda t: np.array(20.0 * np.sin(10 * t)), where="right", name="heater"),
             Convection(value=310.0, h_c=0.5),
             Load("v", lambda t: np.array([0.0, 3.0 * np.sin(20 * t)]), "right", name="push")]
    initial = {"r": lambda x: np.vstack([x[0], 0 * x[0]]),
               "theta": lambda x: THETA0 + 40 * np.exp(-((x[0] - 0.3) / 0.15) ** 2)}
    res = run(Problem(model, 1.0, 12, loads=ports, initial=initial, integrator="discrete-gradient",
                      supports=[Support("left", "clamped")]), h, 0.2)
    q = res.column("heat_supplied")
    powers = res.column("heater_power") + res.column("convection_power")
    expected = np.concatenate([[0.0], np.cumsum(h * powers[1:])])
    assert np.max(np.abs(q - expected)) <= 1e-13 * np.max(np.abs(q))
    mechanical = res.column("supplied") - q
    assert np.max(np.abs(mechanical)) > 1e-3 and np.max(np.abs(q)) > 1e-2
    assert np.max(np.abs(res.column("H") - res.column("H")[0] - res.column("supplied"))) <= 1e-13 * 2.0 * THETA0
