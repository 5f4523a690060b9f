"""Generalized Maxwell viscoelasticity: branches declared next to the material.

A generalized Maxwell material is an elastic *equilibrium branch* (the
model's own material) in parallel with any number of *Maxwell branches*,
each a spring in series with a dashpot:

    equilibrium branch:  stress sigma_inf = dW_inf/d eps                   (eps: the model's strain)
    Maxwell branch k:    stress sigma_k = dW_k/d e_k,   e_k = eps - eps_v,k  (the branch's elastic strain)
                         dashpot  d_t eps_v,k = sigma_k / eta_k,  eta_k = tau_k * (spring stiffness)

The total stress sigma_inf + sum_k sigma_k drives the balance of momentum.
In port-Hamiltonian form the branch strains e_k are extra states (internal
variables) with energy W_k(e_k), and the dashpot is a dissipation matrix
R_k = 1/eta_k >= 0 on their co-energies:

    d_t e_k = d_t eps - R_k sigma_k          (E x' = (J - R) z + B u)
    d_t H = - sum_k sigma_k . R_k sigma_k + y.u

Discretely (rodfem/core/integrators.py), with z_k = the step's effort of W_k (the
midpoint gradient, or Gonzalez' discrete gradient) tested with itself, the
step's balance is exact:

    H_{n+1} - H_n = - h d_n + h y.u,    h d_n = h int sum_k z_k . R_k z_k ds >= 0

(the model's `dissipation(step, dx, ds)`).  Each branch row is scaled by the
constant tau_k/(tau_k + h) (`row_scale`), which keeps Newton's residual at
round-off also for tau_k << h.  Where the problem is linear
(quadratic W_k, held strain), the branch stress follows the recurrence
sigma_{n+1} = sigma_n (1 - h/2tau)/(1 + h/2tau) of the midpoint rule: a
decay for h < 2 tau, an undamped sign flip as tau/h -> 0 (A-stable, not
L-stable: benchmarks/viscoelastic.md).

Each dashpot is set by the relaxation time tau_k of its branch: its
viscosity per strain component i is eta_k,i = tau_k * k_k,i with k_k,i the
branch's small-strain stiffness, so every component of a branch relaxes a
held strain as exp(-t/tau_k) (standard linear solid).  tau = inf is a spring
without dashpot (the branch adds its stiffness: the elastic limit with the
summed stiffness); tau -> 0 relaxes the branch at once (the equilibrium
branch alone).

Declaring a branch (no engine code involved): each model has a helper:

    from rodfem.forms import string, planar_beam, cosserat_rod
    string.String(logarithmic(EA=10), rhoA, branches=[string.maxwell(tau=0.02, EA=10)])
    planar_beam.PlanarBeam(rhoA, rhoI, quadratic(EA, GA, EI),
                           branches=[planar_beam.maxwell(tau=0.05, EA=0.1 * EA, GA=0.1 * GA, EI=0.1 * EI)])
    cosserat_rod.CosseratRod(rhoA, rhoJ, C_N, C_M, branches=[cosserat_rod.maxwell(tau=0.05, C_M=(...))])

A branch whose stiffnesses are all zero is no branch: the model drops it and
is the elastic model itself (no internal variable, the same compiled forms).
"""
import math

import numpy as np

from rodfem.core.materials import ParameterSet


class Maxwell:
    """One Maxwell branch: a spring (`spring`, what the model needs to build its energy)
    in series with a dashpot of relaxation time `tau` (> 0, inf allowed).

    stiffness: the spring's small-strain stiffness per strain component, in the
    model's strain measure (the branch's viscosities are tau * stiffness); a zero
    entry switches that component's dashpot off (its spring carries no stress).
    """

    def __init__(self, tau, spring, stiffness, name="maxwell"):
        tau = float(tau)
        if not (tau > 0 and not math.isnan(tau)):
            raise ValueError(f"Maxwell branch: tau must be a positive number or inf (got {tau!r})")
        stiffness = np.atleast_1d(np.asarray(stiffness, dtype=float))
        if not np.all(np.isfinite(stiffness)) or np.any(stiffness < 0):
            raise ValueError(f"Maxwell branch: stiffnesses must be finite numbers >= 0 (got {tuple(stiffness)})")
        self.tau, self.spring, self.stiffness, self.name = tau, spring, stiffness, name
        # the dashpot's mobilities 1/eta_i = 1/(tau k_i) and 1/tau, run-time constants (0: no flow)
        self.mobilities = ParameterSet(inv_tau=0.0 if math.isinf(tau) else 1.0 / tau,
                                       **{f"R{i}": self._mobility(k) for i, k in enumerate(stiffness)})

    def _mobility(self, k):
        return 0.0 if (k == 0 or math.isinf(self.tau)) else 1.0 / (self.tau * k)

    @property
    def active(self):
        """False for a branch without stiffness (the model drops it)."""
        return bool(np.any(self.stiffness > 0))

    def mobility(self, domain):
        """[1/eta_i] as UFL constants on `domain`."""
        c = self.mobilities.on(domain)
        return [c[f"R{i}"] for i in range(len(self.stiffness))]

    def row_scale(self, step, domain):
        """tau/(tau + h) = 1/(1 + h/tau), the factor of the branch's rows (see `row_scale`)."""
        return row_scale(step, self.mobilities.on(domain)["inv_tau"])

    def __repr__(self):
        return f"Maxwell(tau={self.tau:g}, {self.spring!r})"


def row_scale(step, inv_tau):
    """The branch rows are multiplied by tau/(tau + h) = 1/(1 + h/tau), a positive constant of
    the step: the same solution and the same energy identity (test with z_k/scale), but the
    row stays O(1) as tau -> 0 (R sigma_k ~ sigma_k/tau would carry the round-off of the
    branch strain times 1/tau: for a string, C_k ~ 1 gives a residual floor ~ 1e-16/tau that
    Newton cannot get below)."""
    return 1.0 / (1.0 + step.h * inv_tau)


def active(branches):
    """The branches that carry stiffness (a list); checks the type."""
    out = []
    for b in branches or ():
        if not isinstance(b, Maxwell):
            raise TypeError(f"branches must be Maxwell branches (the model's maxwell(...) helper), got {b!r}")
        if b.active:
            out.append(b)
    return out


def sls_relaxation(t, strain, k_inf, branches):
    """Stress under a strain held from t = 0: strain (k_inf + sum_k k_k exp(-t/tau_k)); branches = [(k_k, tau_k)]."""
    t = np.asarray(t, dtype=float)
    return strain * (k_inf + sum(k * np.exp(-t / tau) for k, tau in branches))


def sls_creep(t, load, k_inf, k1, tau1):
    """Strain of the standard linear solid under a load held from t = 0:
    (load/k_inf) [1 - k1/(k_inf + k1) exp(-t/tau_c)],  tau_c = tau1 (k_inf + k1)/k_inf."""
    t = np.asarray(t, dtype=float)
    tau_c = tau1 * (k_inf + k1) / k_inf
    return load / k_inf * (1.0 - k1 / (k_inf + k1) * np.exp(-t / tau_c))


def midpoint_factor(h, tau):
    """(1 - h/2tau)/(1 + h/2tau): one midpoint step of x' = -x/tau."""
    return (1.0 - 0.5 * h / tau) / (1.0 + 0.5 * h / tau)
