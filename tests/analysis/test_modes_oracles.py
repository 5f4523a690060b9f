"""Linearization of a constrained, loaded system against a hand derivation: the double pendulum of
two point masses on massless links (distance joints), linearized about its hanging equilibrium
(the joints' geometric stiffness lambda . Q carries the whole restoring force), has the natural
frequencies of det(K - omega^2 M) = 0 with

    M = [[(m1 + m2) l1^2, m2 l1 l2], [m2 l1 l2, m2 l2^2]],  K = diag((m1 + m2) g l1, m2 g l2)

(small angles theta_1, theta_2 of the links from the vertical)."""
import numpy as np
import pytest

from rodfem import Load, System
from rodfem.analysis.linearize import Linearization, natural_modes
from rodfem.analysis.statics import Statics
from rodfem.core.joints import ground
from rodfem.forms import joints
from rodfem.forms.rigid_body import PointMass


def hanging_double_pendulum(m1, m2, l1, l2, g=9.81):
    s = System()
    a = s.add("a", PointMass(m1, dim=2), initial=PointMass.initial([0.0, -l1]),
              loads=[Load("v", [0.0, -m1 * g], "domain", "gravity a")])
    b = s.add("b", PointMass(m2, dim=2), initial=PointMass.initial([0.0, -l1 - l2]),
              loads=[Load("v", [0.0, -m2 * g], "domain", "gravity b")])
    s.join(joints.distance, ground((0.0, 0.0)), a.point(), name="link_a")
    s.join(joints.distance, a.point(), b.point(), name="link_b")
    return s


def exact(m1, m2, l1, l2, g=9.81):
    M = np.array([[(m1 + m2) * l1**2, m2 * l1 * l2], [m2 * l1 * l2, m2 * l2**2]])
    K = np.diag([(m1 + m2) * g * l1, m2 * g * l2])
    return np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real))


@pytest.mark.parametrize("m1, m2, l1, l2", [(1.0, 2.0, 1.0, 1.0), (3.0, 0.5, 0.4, 1.3)])
def test_double_pendulum_frequencies(m1, m2, l1, l2):
    s = hanging_double_pendulum(m1, m2, l1, l2)
    Statics(s).solve(t=0.0)            # the links' tensions: the multipliers lambda
    omega, _, _ = natural_modes(Linearization(s), 2, "dense")
    assert np.allclose(np.sort(omega), exact(m1, m2, l1, l2), rtol=1e-10), (omega, exact(m1, m2, l1, l2))
