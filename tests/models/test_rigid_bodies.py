"""Rigid bodies (forms/rigid_body.py) against independent answers, not only their own balance:
a planar body under a constant force and moment follows the parabolas (the midpoint rule is exact
for a constant load), a free symmetric top precesses at Euler's rate (J3 - J1)/J1 omega_3, and a
compound pendulum swings with the period 2 pi sqrt(J_pivot / (m g d))."""
import numpy as np
import pytest

from rodfem import Load, System, run
from rodfem.core.joints import ground
from rodfem.forms import joints
from rodfem.forms.rigid_body import PlanarRigidBody, RigidBody


def state(system, name, field):
    body = system.body(name)
    return body.space.nodal(body.x0, field)[1].reshape(-1)


@pytest.mark.parametrize("m, J", [(2.0, 0.5), (0.3, 4.0)])
def test_planar_body_under_constant_force_and_moment(m, J):
    """omega = M t / J, phi = M t^2 / (2 J), x = x0 + v0 t + F t^2 / (2 m), to round-off."""
    F, M, v0, t = np.array([1.5, -0.5]), 0.7, np.array([0.2, 0.1]), 1.0
    s = System()
    s.add("body", PlanarRigidBody(m, J), initial=PlanarRigidBody.initial([1.0, 2.0], v=v0),
          loads=[Load("v", F, "domain", "force"), Load("omega", M, "domain", "moment")])
    run(s, 0.05, t)
    assert state(s, "body", "omega") == pytest.approx([M * t / J], abs=1e-13)
    assert state(s, "body", "phi") == pytest.approx([M * t**2 / (2 * J)], abs=1e-13)
    assert np.max(np.abs(state(s, "body", "x") - ([1.0, 2.0] + v0 * t + F * t**2 / (2 * m)))) <= 1e-13


def body_omega(system, name):
    """The angular velocity in the body frame: omega = 1/2 sum_i d_i x w_i, components omega . d_k."""
    d = [state(system, name, f"d{i}") for i in (1, 2, 3)]
    w = [state(system, name, f"w{i}") for i in (1, 2, 3)]
    omega = 0.5 * sum(np.cross(di, wi) for di, wi in zip(d, w))
    return np.array([omega @ dk for dk in d])


def test_free_symmetric_top_precesses_at_eulers_rate():
    """J = (1, 1, 2), omega_0 = (0.3, 0, 1): in the body frame (omega_1, omega_2) = 0.3 (cos t, sin t)
    (Omega = (J3 - J1)/J1 omega_3 = 1), omega_3 = 1.  Second order in h (measured error 3.8e-5 at
    h = 0.02, 9.4e-6 at 0.01, t = 2)."""
    errors = []
    for h in (0.02, 0.01):
        s = System()
        s.add("top", RigidBody(1.0, (1.0, 1.0, 2.0)), initial=RigidBody.initial((0, 0, 0), omega=(0.3, 0.0, 1.0)))
        run(s, h, 2.0)
        exact = np.array([0.3 * np.cos(2.0), 0.3 * np.sin(2.0), 1.0])
        errors.append(np.max(np.abs(body_omega(s, "top") - exact)))
    assert errors[0] <= 1e-4 and 3.5 <= errors[0] / errors[1] <= 4.5, errors


def test_compound_pendulum_period():
    """A box (m = 2, J about its centre (0.1, 0.05, 0.1)) hung from a spherical joint at d = 0.5 above
    its centre, swinging by 0.02 rad about d3: T = 2 pi sqrt((J3 + m d^2) / (m g d)) (small
    amplitude: the period's amplitude correction theta^2/16 = 2.5e-5); measured from the zero
    crossings of the swing angle, with 200 steps a period (midpoint: (omega h)^2/12 = 8.2e-5).  Measured
    1.07e-4 = 8.2e-5 + 2.5e-5 longer, every period; bound 3e-4."""
    m, Jc, d, g, theta0 = 2.0, (0.1, 0.05, 0.1), 0.5, 9.81, 0.02
    T = 2 * np.pi * np.sqrt((Jc[2] + m * d**2) / (m * g * d))
    c, sn = np.cos(theta0), np.sin(theta0)
    R = np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])         # turned about z (= d3)
    centre = R @ np.array([0.0, -d, 0.0])
    s = System()
    box = s.add("box", RigidBody(m, Jc), initial=RigidBody.initial(centre, R=R),
                loads=[Load("v", [0.0, -m * g, 0.0], "domain", "gravity")])
    s.join(joints.spherical, ground((0.0, 0.0, 0.0)), box.point((0.0, d, 0.0)))
    h = T / 200
    crossings, previous = [], state(s, "box", "x")
    for k in range(1, 601):
        run(s, h, k * h)
        x = state(s, "box", "x")
        if previous[0] * x[0] < 0 or x[0] == 0:   # the centre passes below the pivot
            crossings.append((k - 1) * h + h * previous[0] / (previous[0] - x[0]))   # linear interpolation
        previous = x
    periods = 2 * np.diff(crossings)
    assert len(periods) >= 3
    assert np.max(np.abs(periods / T - 1)) <= 3e-4, (periods, T)
