"""Kelvin-Voigt material damping and Rayleigh damping: a dissipation R >= 0 on the velocities.

Kelvin-Voigt (a dashpot in parallel with the elastic law, per strain component i):

    stress_i = dW/d eps_i + eta_i d_t eps_i,        eta_i >= 0  (the section's viscosities)

with the strain rate d_t eps = B(x) z written through the velocities z = (v, omega, ...)
(B: the model's strain-rate operator, e.g. A^T (d_s v - omega S d_s r), d_s omega for the planar
beam).  The viscous stress D B z (D = diag(eta_i)) enters the balance of momentum beside the
elastic one but NOT the strain rows, so in port-Hamiltonian form

    E x' = (J - R) z + B_u u,     R = B^* D B >= 0   (acting on the velocity efforts),
    d_t H = - int (B z).D (B z) ds + y.u,

and no extra state is needed.  Discretely (rodfem/core/integrators.py) the strain rate is the
step's rate of the mixed element's strain fields, e_n = (eps_{n+1} - eps_n)/h = Pi B(x_m) z_m (Pi: the
L2 projection on the strain/stress space, which the strain rows apply to the midpoint strain rate;
the elastic stresses see the same projected strains, and the pointwise rate would lock), so
R = B^* Pi^* D Pi B >= 0.  The viscous stress D e_n lies in the stress space (D constant), so testing
the momentum rows with the midpoint velocities z_m and the strain rows with D e_n gives, for the
midpoint rule and the discrete gradient alike,

    H_{n+1} - H_n = -h d_n + h y.u,     h d_n = h int e_n.D e_n ds >= 0

exactly (the model's `dissipation`, booked in the history's `dissipated`).  For a straight beam the
linearized damping matrix is then C = tau_d K + alpha M exactly (below), so every mode k has
zeta_k = alpha/(2 omega_k) + tau_d omega_k/2 (tests/models/test_damping.py).

Choice of D: the viscosities are a retardation time tau_d times the section's small-strain
stiffnesses, eta_i = tau_d k_i (k = EA, GA, EI, GJ, ...): a homogeneous Kelvin-Voigt solid
sigma = E eps + eta d_t eps has tau_d = eta/E for every component (its viscous and elastic
moduli have the same Poisson ratio).  This is D = tau_d K, the damping matrix of the soft-robot
codes: soromox (github.com/tud-phi/soromox) writes D = eta diag(J, 3I, 3I, 3A, A, A) for an
incompressible material, E = 3G, i.e. our D with tau_d = eta/G; the SoRoSim toolbox (Mathew,
Ben Hmida, Armanini, Boyer, Renda, "SoRoSim: a MATLAB toolbox for hybrid rigid-soft robots based
on the geometric variable-strain approach", IEEE Robot. Autom. Mag. 30(3)
(2023)) likewise damps the strain rates.  Then every mode of a straight,
unstressed rod has the damping ratio zeta_k = tau_d omega_k / 2 (classical, stiffness-proportional
damping); for the Euler-Bernoulli cantilever zeta_1 = eta omega_1 / (2 E) (strain-rate damping:
Banks, Inman, "On damping mechanisms in beams", J. Appl. Mech. 58 (1991) 716, DOI
10.1115/1.2897253).  Per-component viscosities are allowed too (`KelvinVoigt`).

Rayleigh damping C = alpha M + beta K (Rayleigh, The Theory of Sound, 1877; Chopra, Dynamics of
Structures, Prentice Hall): beta K is Kelvin-Voigt with tau_d = beta; alpha M is a force
-alpha rho v on every mass (R = alpha M on the velocities, dissipating h int alpha z_m.M z_m).
Its modal damping ratio is zeta(omega) = alpha/(2 omega) + beta omega / 2.  The mass part damps
rigid motions too (it is not objective): it is the structural engineer's tool, not a material law.

Zero damping is no damping: the model then builds and assembles nothing of it (the same forms,
bit for bit).
"""
import math

import numpy as np

from rodfem.core.materials import ParameterSet
from rodfem.errors import ParameterError


class KelvinVoigt:
    """Viscosities eta_i >= 0 per strain component (the model's order) and a mass-proportional
    rate alpha >= 0 (Rayleigh's alpha, 1/s).  A zero viscosity switches its dashpot off."""

    def __init__(self, viscosities, alpha=0.0):
        eta = np.atleast_1d(np.asarray(viscosities, dtype=float))
        if not np.all(np.isfinite(eta)) or np.any(eta < 0):
            raise ParameterError(f"damping: the viscosities eta must be finite numbers >= 0 (got {tuple(eta)})")
        alpha = float(alpha)
        if not (math.isfinite(alpha) and alpha >= 0):
            raise ParameterError(f"damping: the mass-proportional rate alpha must be a finite number >= 0 (got {alpha!r})")
        self.viscosities, self.alpha = eta, alpha
        self.constants = ParameterSet(alpha=alpha, **{f"eta{i}": e for i, e in enumerate(eta)})

    @property
    def active(self):
        """False when every coefficient is zero (the model builds nothing)."""
        return bool(np.any(self.viscosities > 0) or self.alpha > 0)

    def eta(self, domain):
        """[eta_i] as UFL constants on `domain`, None for a zero entry (no term)."""
        c = self.constants.on(domain)
        return [c[f"eta{i}"] if e > 0 else None for i, e in enumerate(self.viscosities)]

    def mass_rate(self, domain):
        """alpha as a UFL constant on `domain`, None if zero."""
        return self.constants.on(domain)["alpha"] if self.alpha > 0 else None

    def __repr__(self):
        return f"KelvinVoigt(eta={tuple(self.viscosities)}, alpha={self.alpha:g})"


def viscous(eta, rates):
    """The viscous stresses [eta_i e_i] of the strain rates e_i (0 where eta_i is None)."""
    return [0.0 if c is None else c * e for c, e in zip(eta, rates)]


def checked(damping, components):
    """The model's damping: None (also for zero damping), or a KelvinVoigt with `components` viscosities."""
    if damping is None:
        return None
    if not isinstance(damping, KelvinVoigt):
        raise TypeError(f"damping must be a KelvinVoigt (the model's kelvin_voigt(...) or rayleigh(...)), got {damping!r}")
    if len(damping.viscosities) != components:
        raise ParameterError(f"damping: this model needs {components} viscosities (got {len(damping.viscosities)})")
    return damping if damping.active else None


def retardation(tau, stiffnesses, alpha=0.0):
    """KelvinVoigt with eta_i = tau k_i (tau = tau_d = eta/E >= 0, the retardation time; k_i >= 0 the
    small-strain stiffnesses; an infinite k_i -- a constrained strain -- gets no dashpot)."""
    tau = float(tau)
    if not (math.isfinite(tau) and tau >= 0):
        raise ParameterError("damping: the retardation time tau (= eta/E, or Rayleigh's beta) must be a finite "
                             f"number >= 0 (got {tau!r})")
    k = np.asarray(stiffnesses, dtype=float)
    return KelvinVoigt(np.where(np.isinf(k), 0.0, tau * np.where(np.isinf(k), 0.0, k)), alpha=alpha)


def zeta_rayleigh(omega, alpha, beta):
    """The modal damping ratio alpha/(2 omega) + beta omega/2 of C = alpha M + beta K."""
    omega = np.asarray(omega, dtype=float)
    return alpha / (2 * omega) + beta * omega / 2


def log_decrement_zeta(t, y, average_over=None):
    """zeta from the logarithmic decrement of the successive maxima of a free decay y(t) (numbers, equal
    steps): delta = ln(y_k / y_{k+1}) averaged over the peaks found, zeta = delta / sqrt(4 pi^2 + delta^2)
    (a damped mode exp(-zeta omega t) cos(omega_d t) has y_k / y_{k+1} = exp(2 pi zeta / sqrt(1 - zeta^2))).
    The peaks are refined by a parabola through the three samples around each.

    average_over: a moving average over that time first (e.g. the period of mode 2, which a released
    cantilever carries at 2.5 % of its tip deflection and which would modulate the peaks).  The average
    is linear and time-invariant: it multiplies every damped mode exp(lambda t) by a constant G(lambda),
    so the decrement of mode 1 is unchanged."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    if average_over:
        m = max(1, int(round(average_over / (t[1] - t[0]))))
        t, y = t[m - 1:], np.convolve(y, np.ones(m) / m, mode="valid")
    i = np.where((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:]) & (y[1:-1] > 0))[0] + 1
    if len(i) < 2:
        raise ValueError("log_decrement_zeta: fewer than two maxima")
    a, b, c = y[i - 1], y[i], y[i + 1]
    peaks = b - 0.125 * (c - a) ** 2 / (a - 2 * b + c)
    delta = np.log(peaks[0] / peaks[-1]) / (len(peaks) - 1)
    return float(delta / math.sqrt(4 * math.pi ** 2 + delta ** 2))
