"""A planar chain of N uniform links (a compound N-pendulum) in minimal coordinates, by scipy's solve_ivp.

The independent reference of the chain-1000 scene.  Link k (k = 0..N-1, mass m, length l,
inertia J about its centre, perpendicular to the plane) has the angle theta_k from the
horizontal, in the (x, z) plane with e(theta) = (cos theta, sin theta); its centre is

    c_k = sum_{i<k} l e(theta_i) + l/2 e(theta_k) = sum_i a_ki e(theta_i),   a_ki = l (i < k), l/2 (i = k), 0.

With mu_ij = m sum_k a_ki a_kj the kinetic energy is 1/2 theta'.M(theta) theta',
M_ij = mu_ij cos(theta_i - theta_j) + J delta_ij, the potential V = m g sum_k c_k.e_z, and Lagrange's
equations read

    sum_j M_ij theta_j'' + sum_j mu_ij sin(theta_i - theta_j) theta_j'^2 = -m g cos(theta_i) sum_k a_ki.
"""
import numpy as np


def lever_arms(N, l):
    """a_ki (N x N)."""
    return np.tril(np.full((N, N), l), -1) + np.diag(np.full(N, 0.5 * l))


def rhs(N, m, l, J, g):
    """f(t, y) of y = (theta, theta')."""
    a = lever_arms(N, l)
    mu, arm = m * a.T @ a, a.sum(axis=0)

    def f(t, y):
        th, om = y[:N], y[N:]
        diff = th[:, None] - th[None, :]
        M = mu * np.cos(diff) + J * np.eye(N)
        rhs = -m * g * np.cos(th) * arm - (mu * np.sin(diff)) @ (om * om)
        return np.concatenate([om, np.linalg.solve(M, rhs)])
    return f


def energy(N, m, l, J, g, y):
    """T + V of the state y = (theta, theta')."""
    a = lever_arms(N, l)
    mu = m * a.T @ a
    th, om = y[:N], y[N:]
    M = mu * np.cos(th[:, None] - th[None, :]) + J * np.eye(N)
    return 0.5 * om @ M @ om + m * g * np.sum(a @ np.sin(th))


def tip(N, l, theta):
    """The free end sum_i l e(theta_i): (x, z)."""
    return np.array([l * np.sum(np.cos(theta)), l * np.sum(np.sin(theta))])


def falling_chain(N, L, mass, J, g, times, rtol=1e-12, atol=1e-12):
    """The chain released at rest along +x: the tip (x, z) at `times` (solve_ivp, DOP853)."""
    from scipy.integrate import solve_ivp
    l, m = L / N, mass / N
    sol = solve_ivp(rhs(N, m, l, J, g), (0.0, float(np.max(times))), np.zeros(2 * N), method="DOP853",
                    t_eval=np.atleast_1d(times), rtol=rtol, atol=atol)
    assert sol.success, sol.message
    return np.array([tip(N, l, sol.y[:N, k]) for k in range(sol.y.shape[1])]), sol
