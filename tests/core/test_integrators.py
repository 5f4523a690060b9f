"""The time-integration rules of rodfem/core/integrators.py on energies of their own (no mesh).

Gonzalez' discrete gradient z(x_n, x_{n+1}) must satisfy z . dx = W(x_{n+1}) - W(x_n) for any W
(above the threshold by its exact quotient, below it by the Taylor term, to O(|dx|^5)), be
symmetric in (x_n, x_{n+1}), and reduce to the midpoint effort dW(x_{n+1/2}) when W is quadratic;
the midpoint rule's effort is dW(x_{n+1/2})."""
import numpy as np
import pytest
import ufl
from ufl.algorithms import expand_derivatives

from rodfem.core.integrators import DG_THRESHOLD, Step


def quartic(a, b):
    """A non-quadratic energy of a scalar and a 2-vector, W = a^4/4 + a |b|^2 + exp(b_0) - b_1^3/3."""
    return a**4 / 4 + a * ufl.dot(b, b) + ufl.exp(b[0]) - b[1] ** 3 / 3


def quadratic(a, b):
    return 2 * a**2 + 0.5 * ufl.dot(b, b) - a * b[1]


def value(expr):
    return float(expand_derivatives(expr))


def efforts(energy, x0, x1, rule):
    """The effort (z_a, z_b) of `rule` between the states x0 = (a, b) and x1, as floats."""
    as_state = {"a": lambda v: ufl.as_ufl(v[0]), "b": lambda v: ufl.as_vector([float(c) for c in v[1]])}
    step = Step({k: f(x0) for k, f in as_state.items()}, {k: f(x1) for k, f in as_state.items()}, 1.0, rule)
    za, zb = step.effort(lambda a, b: energy(a, b), ["a", "b"])
    return np.array([value(za), value(zb[0]), value(zb[1])])


def W(energy, x):
    return value(energy(ufl.as_ufl(x[0]), ufl.as_vector([float(c) for c in x[1]])))


X0 = (0.7, (0.2, -0.4))


@pytest.mark.parametrize("size", [0.3, 3 * DG_THRESHOLD, 0.3 * DG_THRESHOLD, 1e-6])
def test_discrete_gradient_gives_the_energy_difference(size):
    """z . dx = W(x1) - W(x0) to round-off of W, on both sides of the threshold."""
    d = size * np.array([1.0, -0.5, 0.8]) / np.linalg.norm([1.0, -0.5, 0.8])
    x1 = (X0[0] + d[0], (X0[1][0] + d[1], X0[1][1] + d[2]))
    z = efforts(quartic, X0, x1, "discrete-gradient")
    dW = W(quartic, x1) - W(quartic, X0)
    assert abs(z @ d - dW) <= 1e-14 * abs(W(quartic, X0)) + 1e-15, (z @ d, dW)
    if size >= 0.1:   # and it is not the midpoint effort, which misses the difference at this size
        zm = efforts(quartic, X0, x1, "midpoint")
        assert abs(zm @ d - dW) > 1e-5


def test_discrete_gradient_is_symmetric_and_midpoint_for_quadratic_energy():
    x1 = (0.2, (0.9, 0.1))
    forward, backward = efforts(quartic, X0, x1, "discrete-gradient"), efforts(quartic, x1, X0, "discrete-gradient")
    assert np.max(np.abs(forward - backward)) <= 1e-14
    dg, mid = efforts(quadratic, X0, x1, "discrete-gradient"), efforts(quadratic, X0, x1, "midpoint")
    assert np.max(np.abs(dg - mid)) <= 1e-14


def test_midpoint_effort_is_the_gradient_at_the_midpoint():
    """dW/dx of quartic at x_m = (x0 + x1)/2, by hand."""
    x1 = (0.2, (0.9, 0.1))
    a = (X0[0] + x1[0]) / 2
    b = (np.array(X0[1]) + np.array(x1[1])) / 2
    by_hand = np.array([a**3 + b @ b, 2 * a * b[0] + np.exp(b[0]), 2 * a * b[1] - b[1] ** 2])
    assert np.max(np.abs(efforts(quartic, X0, x1, "midpoint") - by_hand)) <= 1e-14
