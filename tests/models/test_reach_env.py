"""soft-arm-reach and its gymnasium environment (demos/soft_arm_reach.py, demos/_reach_env.py): the
environment checker, resets, the energy balance of the tendons' ports, a tendon cannot push."""
import numpy as np
import pytest

from rodfem import ParameterError, Simulator

gymnasium = pytest.importorskip("gymnasium")   # the optional extra gym (scripts/install-deps installs it)

SMALL = {"n_elements": 4}


@pytest.fixture(scope="module")
def env():
    from rodfem.demos._reach_env import SoftArmReach
    return SoftArmReach(substeps=2, max_actions=5, params=SMALL)


def test_gymnasium_env_checker_passes(env):
    from gymnasium.utils.env_checker import check_env
    check_env(env, skip_render_check=True)


def test_reset_is_deterministic_and_steps_keep_the_energy_balance(env):
    """reset(seed) gives the same target and observation; an episode's steps keep the discrete balance
    H_{n+1} - H_n = h (sum tau_i y_i + gravity . v) to round-off; the arm hangs still without tensions."""
    a, _ = env.reset(seed=7)
    b, _ = env.reset(seed=7)
    assert np.array_equal(a, b) and env.observation_space.contains(a)
    c, _ = env.reset(seed=8)
    assert not np.array_equal(a[24:27], c[24:27])
    H = []
    for k in range(5):
        obs, reward, terminated, truncated, info = env.step(np.array([0.5, 0.1, 0.0], np.float32))
        H.append(env.sim.history.rows[-1]["H"])
        assert reward < 0 and info["steps"] == k + 1
    assert truncated and not terminated
    assert env.sim.history.max_balance_error <= 1e-12 * max(H)
    env.reset(seed=7)
    still, _, _, _, _ = env.step(np.zeros(3, np.float32))
    assert np.max(np.abs(still[12:24])) <= 1e-9          # the hanging equilibrium: no velocity


def test_a_tendon_cannot_push():
    sim = Simulator("soft-arm-reach", **SMALL)
    sim.step({"tendon1": 0.2})
    with pytest.raises(ParameterError, match="tension must be >= 0"):
        sim.step({"tendon1": -0.1})
    assert sim.ports["tendon1"].held == 0.2 and len(sim.history.rows) == 2
    sim.step()
    assert sim.history.rows[-1]["u[tendon1]"] == 0.2
