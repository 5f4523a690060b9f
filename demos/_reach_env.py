# The reaching task of soft-arm-reach as a gymnasium environment (the optional extra gym = gymnasium):
# the scene stepped through rodfem.Simulator, the three tendon tensions the action.  See
# demos/soft_arm_reach.py for the task; registered as "rodfem/SoftArmReach-v0".
import gymnasium
import numpy as np
from gymnasium import spaces
from mpi4py import MPI

from rodfem import Simulator
from rodfem.demos._multibody import nodal

PORTS = ("tendon1", "tendon2", "tendon3")


class SoftArmReach(gymnasium.Env):
    """Soft-arm reaching: action = three tendon tensions in [0, tau_max] (N), held for `substeps` steps;
    observation = positions and velocities of the centreline at s = L/4, L/2, 3L/4, L, the target and
    the tendons' outputs -dl_i/dt (their mean over the last action; the ports' conjugate outputs) (30
    numbers, float32); reward = -|tip - target| / L - effort |tau / tau_max|^2; an episode ends when
    the tip is within `tolerance` of the target (terminated) or after `max_actions` actions (truncated).
    `params`: the scene's parameter values (e.g. n_elements, dt).  Serial (one process)."""
    metadata = {"render_modes": []}

    def __init__(self, tau_max=0.5, substeps=5, max_actions=40, effort=0.05, tolerance=5e-3, params=None):
        self.sim = Simulator("soft-arm-reach", comm=MPI.COMM_SELF, **(params or {}))
        self.tau_max, self.substeps, self.max_actions = float(tau_max), int(substeps), int(max_actions)
        self.effort, self.tolerance = float(effort), float(tolerance)
        self.L = self.sim.values["L"]
        self.action_space = spaces.Box(0.0, self.tau_max, shape=(3,), dtype=np.float32)
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(30,), dtype=np.float32)
        body = self.sim.system.body("")
        s, _ = nodal(body, "r")
        self.samples = [int(np.argmin(np.abs(s - f * self.L))) for f in (0.25, 0.5, 0.75, 1.0)]
        self.target = np.array([0.0, 0.0, -self.L])
        self.count = 0
        self.outputs = np.zeros(3)

    def _positions(self):
        body = self.sim.system.body("")
        r, v = nodal(body, "r")[1], nodal(body, "v")[1]
        return r[self.samples], v[self.samples]

    def _observation(self):
        r, v = self._positions()
        return np.concatenate([r.ravel(), v.ravel(), self.target, self.outputs]).astype(np.float32)

    def _distance(self):
        return float(np.linalg.norm(self._positions()[0][-1] - self.target))

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.sim.reset()
        polar = self.np_random.uniform(0.05, 0.2)
        azimuth = self.np_random.uniform(0.0, 2 * np.pi)
        self.target = self.L * np.array([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth),
                                         -np.cos(polar)])
        self.count, self.outputs = 0, np.zeros(3)
        return self._observation(), {"distance": self._distance(), "steps": 0}

    def step(self, action):
        tau = np.clip(np.asarray(action, dtype=float), 0.0, self.tau_max)
        y = np.zeros(3)
        for _ in range(self.substeps):
            out = self.sim.step(dict(zip(PORTS, tau)))
            y += np.array([out.y[p][0] for p in PORTS]) / self.substeps
        self.outputs = y
        self.count += 1
        distance = self._distance()
        reward = -distance / self.L - self.effort * float(np.sum((tau / self.tau_max) ** 2))
        terminated = distance <= self.tolerance
        truncated = self.count >= self.max_actions and not terminated
        return self._observation(), float(reward), bool(terminated), bool(truncated), {"distance": distance,
                                                                                       "steps": self.count}


gymnasium.register(id="rodfem/SoftArmReach-v0", entry_point="rodfem.demos._reach_env:SoftArmReach")
