"""Stability of a static equilibrium (rodfem/analysis/stability.py), against the classical buckling
thresholds: Euler's column under a dead end load and Greenhill's column under its own weight."""
import json

import numpy as np
import pytest

from rodfem.app.analyses import run_static

# Greenhill (1881): a clamped vertical column of weight per length q buckles under its own weight
# at q L^3 / (EI) = 7.8373 (Timoshenko & Gere, Theory of Elastic Stability, 2nd ed., sec. 2.10).
GREENHILL = 7.8373
UPRIGHT = {"tension1": 0.0, "tension2": 0.0, "tau_kv": 0.0, "n_elements": 4}   # the tendon arm as a bare column


def greenhill_length(E=1e6, r=0.03, rho=1000.0, g=9.81):
    """L_c = (7.8373 EI / (rho g A))^(1/3) = (7.8373 E r^2 / (4 rho g))^(1/3) for a solid circle."""
    return (GREENHILL * E * r**2 / (4 * rho * g)) ** (1 / 3)


def stability(scene, values, mode="auto"):
    return run_static(scene, values, out=None, stability=mode)[2]["stability"]


@pytest.mark.parametrize("tau_kv", [0.0, 0.03], ids=["undamped", "kelvin-voigt"])
def test_self_weight_column_turns_unstable_at_greenhills_length(tau_kv):
    """The upright 3D rod (shear-deformable Cosserat model, 4 elements) is stable at 0.99 L_c and
    unstable at 1.01 L_c; damping does not change the verdict (Kelvin-Tait-Chetaev).  The discrete
    threshold is 0.14 % below Greenhill's at 4 and 0.17 % at 8 elements (shear flexibility,
    EI/(GA L^2) = 2e-3, lowers it); a wrong sign or a lost gravity stiffness moves it by far more."""
    Lc = greenhill_length()
    below = stability("tendon-arm-dynamic", dict(UPRIGHT, tau_kv=tau_kv, L=0.99 * Lc))
    above = stability("tendon-arm-dynamic", dict(UPRIGHT, tau_kv=tau_kv, L=1.01 * Lc))
    assert below["checked"] and below["stable"], below
    assert above["checked"] and not above["stable"], above
    # the two bending planes: one real growing eigenvalue each (the damped one slower)
    assert len(above["unstable_eigenvalues"]) == 2
    assert all(abs(im) <= 1e-6 * re for re, im in above["unstable_eigenvalues"])
    assert above["growth_rate_1_s"] > 0


def euler_threshold(n):
    """The compressive tip load at which the clamped-free planar beam (cantilever-2d, n elements)
    turns unstable, by bisection on the verdict, over Euler's P_cr = pi^2 EI / (4 L^2)."""
    p_cr = np.pi**2 * 175.0 / 4.0
    lo, hi = 0.98, 1.04
    for _ in range(10):
        mid = 0.5 * (lo + hi)
        s = stability("cantilever-2d", {"fx": -mid * p_cr, "fy": 0.0, "t_load": 2.0, "n_elements": n})
        lo, hi = (mid, hi) if s["stable"] else (lo, mid)
    return 0.5 * (lo + hi)


def test_end_loaded_column_threshold_converges_to_euler_at_second_order():
    """The straight equilibrium is found beyond buckling too (statics does not care); the verdict
    flips at the discrete buckling load, which approaches Euler's at second order in h (P1/DG0:
    1.025 P_cr at 5 elements, 1.006 at 10)."""
    errors = [euler_threshold(n) - 1.0 for n in (5, 10)]
    assert 0 < errors[1] < 0.01, errors
    assert np.log2(errors[0] / errors[1]) > 1.8, errors


def test_cli_prints_the_verdict_and_writes_it(rodfem, tmp_path):
    Lc = greenhill_length()
    args = ["static", "tendon-arm-dynamic"] + [a for k, v in dict(UPRIGHT, L=1.05 * Lc).items()
                                              for a in ("--set", f"{k}={v}")]
    p = rodfem(*args, "--out", str(tmp_path / "up"))
    assert p.returncode == 0, p.stderr[-2000:]
    assert "UNSTABLE equilibrium: 2 eigenvalues" in p.stdout
    summary = json.loads((tmp_path / "up" / "summary.json").read_text())
    assert summary["stability"]["stable"] is False and summary["stability"]["growth_rate_1_s"] > 0
    p = rodfem(*args, "--stability", "off", "--out", str(tmp_path / "off"))
    assert p.returncode == 0 and "stability not checked: --stability off" in p.stdout


def test_too_many_dofs_for_auto_is_said_not_guessed():
    s = stability("cantilever-2d", {"n_elements": 200})
    assert not s["checked"] and "more than the 600" in s["why"] and "--stability on" in s["why"]
