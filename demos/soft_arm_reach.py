# # A soft arm reaching for a target with three tendons (a reinforcement-learning environment)
#
# The silicone arm of soft-arm-swing (Dragon Skin 10, L = 0.1755, outer
# radius 8 mm) hangs from its clamped base at the origin along -z under
# gravity, at rest in its static equilibrium.  Three tendons run in its wall
# at 6.5 mm from the axis, 120 degrees apart (at 90, 210 and 330 degrees in
# the section), each fixed at the tip and pulled at the base: each is an input
# port (forms/actuators.py: input its tension tau_i >= 0, output -dl_i/dt), and
# every step keeps H_{n+1} - H_n = h (sum_i tau_i (-ldot_i) + gravity . v).
# The scene's tensions are zero: something outside drives them -- the step
# interface (rodfem.Simulator) or the gymnasium environment below.
#
# The task (demos/_reach_env.py, `SoftArmReach`, a `gymnasium.Env`; needs the
# optional extra gym = gymnasium): a target is drawn on the sphere the tip
# can sweep (polar angle 0.15 - 0.5 rad from the hanging direction, any
# azimuth); every action sets the three tensions in [0, tau_max], held for
# `substeps` steps of dt (0.05 s by default); the observation is the
# centreline at 4 points (s = L/4, L/2, 3L/4, L: positions and velocities)
# and the target; the reward is -|tip - target| / L - effort |tau / tau_max|^2.
# An episode lasts 40 actions (2 s) and ends early when the tip is within
# 5 mm of the target.  `gymnasium.utils.env_checker.check_env` passes
# (tests/models/test_reach_env.py).
#
# The scripted controller of `__main__` (no learning, not tuned): a bias
# tension on every tendon plus the tip's error in the horizontal plane,
# projected on the three tendon directions, clipped to [0, tau_max]; the
# arm has no damping of its own, so it swings about the pose it is pulled
# to.  The demo prints its return against zero tensions.  A learned policy
# plugs in at the same place: `action = policy(observation)`.
#
# Run it:  rodfem run soft-arm-reach --out results/soft-arm-reach       (nothing pulls: the arm hangs still)
#          python demos/soft_arm_reach.py                               (the scripted controller, 3 targets)

import sys

import numpy as np

from rodfem import Load, Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Scene, common, density, stiffness
from rodfem.demos._actuated import soft_arm_parameters, soft_arm_stiffness, soft_rod
from rodfem.demos.soft_arm_swing import hanging
from rodfem.forms import actuators

ANGLES = np.deg2rad([90.0, 210.0, 330.0])   # the tendons in the section (d2, d3)

parameters = common(n_elements=6, dt=0.01, t_end=2.0) + soft_arm_parameters() + [
    stiffness("tendon_offset", 6.5e-3, "m", "distance of the tendons from the axis"),
    density("g", 9.81, "m/s^2", "gravity, acting in -z"),
]


def build(p, comm):
    *_, rhoA, _ = soft_arm_stiffness(p)
    loads = [actuators.Tendon(0.0, actuators.on_circle(p["tendon_offset"], a), radius=p["R_out"], name=f"tendon{i + 1}")
             for i, a in enumerate(ANGLES)]
    if p["g"] != 0:
        loads.append(Load("v", [0.0, 0.0, -rhoA * p["g"]], "domain", "gravity"))
    return Problem(soft_rod(p, statics=False), p["L"], p["n_elements"], loads=loads,
                   supports=[Support("left", "clamped")], initial=hanging(p), integrator=p["integrator"], comm=comm)


scene = Scene("soft-arm-reach", "hanging silicone arm with three tendons as input ports (zero tension: driven from "
              "outside, e.g. the gymnasium environment of demos/_reach_env.py)", parameters, build,
              notes="The tendons' tensions are the inputs of rodfem.Simulator (ports tendon1, tendon2, tendon3).")


# ## The scripted controller
#
# In the hanging frame d2 = e_x, d3 = -e_y, a tendon at angle a sits at
# cos(a) e_x - sin(a) e_y and pulls the tip towards that side.

def tendon_directions():
    return np.array([[np.cos(a), -np.sin(a)] for a in ANGLES])


def scripted(observation, tau_max, gain=5.0, damping=0.0, bias=0.4):
    """Tensions: a bias (all tendons pulled: they can then also let go), the tip's horizontal error
    projected on the tendons' directions, and optional damping injection at the tendons' own ports,
    -damping y_i (y_i = -dl_i/dt, the collocated output; off by default: y is the mean over the last
    action and acts during the next one, and that delay made damping = 15 N s/m pump energy into the
    arm instead) (observation: see `SoftArmReach`)."""
    tip, target, y = observation[9:12], observation[24:27], observation[27:30]
    tau = bias * tau_max + tendon_directions() @ (gain * (target[:2] - tip[:2])) - damping * y
    return np.clip(tau, 0.0, tau_max).astype(np.float32)


def demo(targets=3, seed=0):
    from rodfem.demos._reach_env import SoftArmReach
    env = SoftArmReach()
    for k in range(targets):
        for name, policy in (("scripted", lambda o: scripted(o, env.tau_max)), ("zero", lambda o: np.zeros(3, np.float32))):
            obs, info = env.reset(seed=seed + k)
            total, done = 0.0, False
            while not done:
                obs, reward, terminated, truncated, info = env.step(policy(obs))
                total += reward
                done = terminated or truncated
            print(f"target {k + 1}: {name:8s} return {total:8.3f}, final distance {1e3 * info['distance']:6.1f} mm, "
                  f"{info['steps']} actions, max |balance| {env.sim.history.max_balance_error:.1e} J")


if __name__ == "__main__":
    if len(sys.argv) > 1:
        sys.exit(main(["run", scene.name, *sys.argv[1:]]))
    demo()
