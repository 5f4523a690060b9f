"""Thermoelastic string: temperature as a port-Hamiltonian state, heat flux as a port.

The hyperelastic string of forms/string.py (r, v, C = d_s r . d_s r) with one more
state, the entropy density eta per reference length (P1, like r), and the thermal
energy in the Hamiltonian.  The thermodynamics follows the GENERIC / port-Hamiltonian
thermoelasticity in entropy variables of Romero, "Thermodynamically consistent
time-stepping algorithms for non-linear thermomechanical systems", Int. J. Numer.
Meth. Eng. 79 (2009) 706-732, doi 10.1002/nme.2588 (total energy conserved, entropy
non-decreasing for the isolated system, by discrete gradients of the energy and entropy).
Here the thermal state is the entropy density and the step's temperature an L2-projected
co-energy (a mixed field), so that the energy test function lies in the thermal test space.

Free energy (Helmholtz, per reference length) with the thermal coupling linear in
the temperature, m(C) = (C - 1)/2 the Green strain,

    psi(C, theta) = W(C) - beta (theta - theta0) m(C) + c (theta - theta0 - theta ln(theta/theta0)),
    beta = EA alpha  (EA the material's small-strain stiffness, alpha the expansion coefficient),

so that eta = -d psi/d theta = beta m(C) + c ln(theta/theta0) is explicit in theta,
and the internal energy e = psi + theta eta is explicit in (C, eta):

    e(C, eta) = W(C) + beta theta0 m(C) + c theta0 [exp((eta - beta m(C))/c) - 1],
    theta(C, eta) = de/d eta = theta0 exp((eta - beta m(C))/c),
    S = 2 de/dC|_eta = 2 dpsi/dC|_theta = 2 W'(C) - beta (theta - theta0).

Why entropy and not temperature: with eta as the state, H = int 1/2 rhoA v.v + e(C, eta) ds
is the total energy with e known in closed form, and the discrete gradient of e in
(C, eta) gives the exact energy balance directly; with theta as the state, e(C, theta)
is not a potential of the thermal row and a conserving scheme needs extra terms.
(The coupling is -beta (theta - theta0) m(C), linear in theta, so that eta(C, theta) is
explicit: W(C) then stays the isothermal energy at theta0;
the expansion form W(eps - alpha (theta - theta0)) + ... differs from it by 1/2 EA alpha^2
(theta - theta0)^2, a change of the heat capacity of relative size EA alpha^2 theta/c.)

Closed forms (any string material with W'(1) = 0): clamped at the reference length
(C = 1) at temperature theta0 + dtheta the tension is N = S = -EA alpha dtheta; free,
the stress-free state has 2 W'(C) = beta dtheta, for kirchhoff a Green strain
(C - 1)/2 = alpha dtheta, length L sqrt(1 + 2 alpha dtheta) = L (1 + alpha dtheta + O(dtheta^2)).

Balance laws (Fourier conduction q = -kappa d_s theta, kappa = conductivity x area):

    d_t r = v,   rhoA d_t v = d_s (S d_s r),   d_t C = 2 d_s r . d_s v,
    theta d_t eta = -d_s q  (+ heat ports),

so d_t int e = int S/2 d_t C + theta d_t eta (mechanical power in, heat flux at the ends)
and d_t int eta = int kappa (d_s theta / theta)^2 >= 0 for an insulated string.

The discrete gradient of e (`efforts`).  e is a sum of terms each a function of ONE linear
combination of (C, eta): W(C), the linear beta theta0 m(C), and T(xi) = c theta0 (exp(xi) - 1)
of xi = (eta - beta m(C))/c.  The sum of their difference quotients along their own variables,

    z_C   = grad_bar W(C) + beta theta0/2 - (beta/2c) T'_bar,      z_eta = T'_bar / c,
    T'_bar = [T(xi_{n+1}) - T(xi_n)] / (xi_{n+1} - xi_n) = c theta0 exp(xi_m) sinh(d xi/2)/(d xi/2),

satisfies z_C dC + z_eta d eta = e(x_{n+1}) - e(x_n) exactly (a discrete gradient in the sense of
Gonzalez, J. Nonlinear Sci. 6 (1996) 449-467, doi 10.1007/BF02440162).  The thermal quotient is
written with sinh, free of cancellation: the heat content c theta0 L is large beside the
elastic energy, and a quotient of differences of e (Gonzalez' formula on e as a whole,
`step.effort`) would carry its round-off eps |e| / |dx| into the stress -- a Newton residual
floor (measured 1.6e-10 at 100 elements, above Newton's absolute tolerance 1e-10: the solve
stopped on the step size after 4 iterations; with the sinh quotient 1e-11 after 3).
grad_bar W is the string's (`step.effort` on W alone); the midpoint rule takes
T'(xi_m) = c theta0 exp(xi_m) (sinh(x)/x -> 1) and W'(C_m).

Weak form of one step (the string's rows, plus two): S = 2 z_C, and theta (P1, the step's
temperature, stored in x_{n+1}) the L2 projection of z_eta,

    int (r_{n+1} - r_n)/h . dr - v_m . dr                                    = 0
    int rhoA (v_{n+1} - v_n)/h . dv + S d_s r_m . d_s dv                     = ports
    int [(C_{n+1} - C_n)/h - 2 d_s r_m . d_s v_m] dC                        = 0   (dC in DG0)
    int (theta - z_eta) dtheta                                               = 0   (dtheta in P1)
    int (eta_{n+1} - eta_n)/h deta + kappa d_s theta d_s(deta / theta)      = heat ports  (deta in P1)

Energy.  Test the C-row with the cell mean of z_C (DG0; the C-row's bracket is cellwise
constant, so this is int z_C [...]), the theta-row with deta_h = (eta_{n+1} - eta_n)/h
(P1: int theta d_t eta = int z_eta d_t eta) and the eta-row with deta = theta:
d_s(theta/theta) = 0, and

    H_{n+1} - H_n = int rhoA (v_{n+1} - v_n).v_m + z_C dC + z_eta d eta = h y.u

exactly (Gonzalez: z . dx = e(x_{n+1}) - e(x_n) pointwise, the same quadrature in H and
the rows).  Entropy: test the eta-row with deta = 1:

    int eta_{n+1} - int eta_n = h int kappa (d_s theta / theta)^2 ds  + h (heat ports' entropy) >= 0 isolated,

exactly per step (`columns`: entropy, entropy_production).

Maxwell branches (forms/viscoelastic.py, `branches=[string.maxwell(tau, EA_k)]`): as in
forms/string.py, the branch strains C_k (DG0) with energies W_k(C_k) in H, their stresses
2 z_k in the v-row and their rows d_t C_k = 2 d_s r . d_s v - R_k z_k; the work the
dashpots take out, sum_k R_k z_k^2 >= 0, is a heat source in the entropy row,

    ... - sum_k R_k z_k^2 deta / theta,

so the total energy stays exact (test with deta = theta: the dashpots' loss is the heat's gain;
nothing is booked as `dissipated`) and the entropy grows by h int sum_k R_k z_k^2 / theta more.

Kelvin-Voigt and Rayleigh damping (forms/damping.py, `damping=string.kelvin_voigt(tau_d, EA)`):
the viscous stress S_v = eta (d_s r . d_s v)_m of forms/string.py in the v-row, and its work
S_v (d_s r . d_s v)_m (+ alpha rhoA |v_m|^2, Rayleigh's mass part) as a heat source in the
entropy row, the same way: the total energy stays exact.

Heat ports (forms/heat_ports.py): a heat flux Q into an end (input Q, output the end's
temperature, power Q) and convection to an environment at theta_env (input theta_env,
power h_c int (theta_env - theta) ds); their work is in `supplied`, and cumulative in the column
`heat_supplied` (the heat meter q of forms/heat_ports.py, one more DG0 state).
"""
import numbers

import numpy as np
import ufl

from rodfem.core.materials import ParameterSet
from rodfem.core.model import Field
from rodfem.core.ports import ENDS
from rodfem.forms.heat_ports import HEAT, HEAT_LABEL, heat_row, heat_supplied
from rodfem.forms.string import String, relaxed


def thermal_slope(rule, xi0, xi1, c, theta0):
    """T'_bar of T(xi) = c theta0 (exp(xi) - 1) between xi0 and xi1 (UFL): the discrete gradient's
    c theta0 exp(xi_m) sinh(d xi/2)/(d xi/2) (its Taylor series where |d xi/2| <= 1e-3, d xi = 0
    included), the midpoint rule's c theta0 exp(xi_m)."""
    half = 0.5 * (xi1 - xi0)
    factor = 1.0
    if rule == "discrete-gradient":
        factor = ufl.conditional(ufl.gt(abs(half), 1e-3), ufl.sinh(half) / ufl.conditional(
            ufl.gt(abs(half), 1e-3), half, 1.0), 1 + half ** 2 / 6 + half ** 4 / 120)
    return c * theta0 * ufl.exp(0.5 * (xi0 + xi1)) * factor


def thermal_parameters(owner, alpha, c, kappa, theta0, conductivity="kappa"):
    """(alpha, c, kappa, theta0) as floats, checked: alpha finite, c > 0, kappa >= 0, theta0 > 0
    (ValueError naming the parameter; the conductivity's name is `conductivity`)."""
    for name, value, low in (("alpha", alpha, None), ("c", c, 0), (conductivity, kappa, -1), ("theta0", theta0, 0)):
        ok = isinstance(value, numbers.Real) and np.isfinite(value) and (low is None or value > low)
        if not ok:
            allowed = {None: "a finite number", 0: "a positive number", -1: "a number >= 0"}[low]
            raise ValueError(f"{owner}: {name} must be {allowed} (got {value!r})")
    return float(alpha), float(c), float(kappa), float(theta0)


def conduction(kappa, theta, deta):
    """kappa d_s theta d_s(deta/theta): Fourier conduction in the entropy row (UFL); zero for deta = theta,
    kappa (theta'/theta)^2 for deta = 1."""
    return kappa * theta.dx(0) * (deta.dx(0) / theta - deta * theta.dx(0) / theta ** 2)


class ThermoelasticString(String):
    """Thermoelastic PH string: `material` W(C) (a string material with a parameter EA, its
    isothermal energy at theta0), rhoA, the expansion coefficient alpha (1/K), the heat capacity
    c per reference length (J/(K m), > 0), kappa = conductivity x area (W m/K, >= 0), the
    reference temperature theta0 (K, > 0); end_masses as for String."""
    fields = String.fields + [Field("eta", "P", 1), Field("theta", "P", 1), HEAT]
    quadrature_degree = 4   # e(C, eta) has exp(eta): a rule of degree 4 (the same in H and the rows)
    labels = {**String.labels,
              "eta": ("entropy density per reference length (the state's)", ()),
              "theta": ("the step's temperature (L2 projection of de/d eta)", ()),
              "temperature": ("temperature theta(C, eta) = de/d eta", ()), **HEAT_LABEL}
    units = {**String.units, "eta": "J/(K m)", "theta": "K", "temperature": "K", "heat": "J/m"}
    static_fields = None   # no statics: the thermal rows have no total form here

    def __init__(self, material, rhoA, alpha, c, kappa, theta0, end_masses=None, branches=(), damping=None):
        super().__init__(material, rhoA, end_masses, branches, damping)
        if self.branches:   # the branch strains C_k after the thermal fields
            self.fields = ThermoelasticString.fields + [Field(f"C_{k}", "DG", 0)
                                                        for k in range(1, len(self.branches) + 1)]
        EA = material.params.get("EA")
        if EA is None:
            raise ValueError(f"material {material.name} has no parameter EA (the coupling is beta = EA alpha)")
        self.alpha, self.c, self.kappa, self.theta0 = thermal_parameters("ThermoelasticString", alpha, c, kappa, theta0)
        self.beta = self.alpha * float(EA)
        self.thermal = ParameterSet(beta=self.beta, c=self.c, kappa=self.kappa, theta0=self.theta0)

    def _t(self, domain):
        return self.thermal.on(domain)

    # -- energy and temperature ----------------------------------------------------
    @staticmethod
    def coupling(C):
        """m(C) = (C - 1)/2, the Green strain."""
        return 0.5 * (C - 1)

    def internal_energy(self, C, eta, domain):
        """e(C, eta) = W(C) + beta theta0 m + c theta0 [exp((eta - beta m)/c) - 1]."""
        k = self._t(domain)
        m = self.coupling(C)
        return (self.W(C, domain) + k["beta"] * k["theta0"] * m
                + k["c"] * k["theta0"] * (ufl.exp((eta - k["beta"] * m) / k["c"]) - 1))

    def temperature(self, C, eta, domain):
        """theta(C, eta) = theta0 exp((eta - beta m(C))/c)."""
        k = self._t(domain)
        return k["theta0"] * ufl.exp((eta - k["beta"] * self.coupling(C)) / k["c"])

    def entropy_of(self, C, theta, domain):
        """eta(C, theta) = beta m(C) + c ln(theta/theta0)."""
        k = self._t(domain)
        return k["beta"] * self.coupling(C) + k["c"] * ufl.ln(theta / k["theta0"])

    def stored(self, x, dom):
        """The internal energy per length e(C, eta) and the Maxwell branches' springs: with the kinetic
        energy (String.hamiltonian) the total energy H."""
        e = self.internal_energy(x["C"], x["eta"], dom)
        for k, b in enumerate(self.branches, 1):
            e = e + b.spring(x[f"C_{k}"])
        return e

    # -- the step ------------------------------------------------------------------
    def residual(self, step, test, dx, ds):
        """The five rows of the module docstring (and the Maxwell branches' rows, their heat)."""
        dom = dx.ufl_domain()
        k = self._t(dom)
        dr, dv, dC, deta, dth = test["r"], test["v"], test["C"], test["eta"], test["theta"]
        rs, v = step.mid("r").dx(0), step.mid("v")
        zC, zeta = self.efforts(step, dom)
        theta = step.x1["theta"]
        S = 2 * zC
        branches = self._branch_efforts(step, dom)
        heat = 0   # the Maxwell dashpots' dissipation sum_k R_k z_k^2, a heat source in the entropy row
        for Wk, R in branches:
            S, heat = S + 2 * Wk, heat + R * Wk ** 2
        end_heat = None   # Rayleigh's mass part at lumped end masses: heat at the end points
        if self.damping is not None:   # Kelvin-Voigt (and Rayleigh): the viscous work becomes heat too
            Sv, Edot = self._viscous(step, dom)
            S, heat = S + Sv, heat + Sv * Edot
            if self.damping.alpha > 0:
                a = self.damping.mass_rate(dom)
                heat = heat + a * self.constants(dom)["rhoA"] * ufl.inner(v, v)
                end_heat = self._lumped(ds, a * ufl.inner(v, v) * deta / theta)
        F = (ufl.inner(step.rate("r") - v, dr)
             + self.constants(dom)["rhoA"] * ufl.inner(step.rate("v"), dv) + S * ufl.inner(rs, dv.dx(0))
             + (step.rate("C") - 2 * ufl.inner(rs, v.dx(0))) * dC
             + (theta - zeta) * dth
             + step.rate("eta") * deta + conduction(k["kappa"], theta, deta)
             - heat * deta / theta) * dx + heat_row(step, test, dx)
        for i, ((Wk, R), b) in enumerate(zip(branches, self.branches), 1):   # as in forms/string.py
            row = step.rate(f"C_{i}") - 2 * ufl.inner(rs, v.dx(0)) + R * Wk
            F += b.row_scale(step, dom) * row * test[f"C_{i}"] * dx
        if self.damping is not None and self.damping.alpha > 0:   # Rayleigh's mass part, as in forms/string.py
            a = self.damping.mass_rate(dom)
            F += a * self.constants(dom)["rhoA"] * ufl.inner(v, dv) * dx
            ends_v = self._lumped(ds, a * ufl.inner(v, dv))
            F = F + ends_v if ends_v is not None else F
            F = F - end_heat if end_heat is not None else F
        ends = self._lumped(ds, ufl.inner(step.rate("v"), dv))
        return F + ends if ends is not None else F

    def efforts(self, step, domain):
        """(z_C, z_eta): the discrete gradient of e(C, eta) of the module docstring (UFL)."""
        k = self._t(domain)
        (zW,) = step.effort(lambda C: self.W(C, domain), ["C"])
        xi = [(x["eta"] - k["beta"] * self.coupling(x["C"])) / k["c"] for x in (step.x0, step.x1)]
        dT = thermal_slope(step.rule, xi[0], xi[1], k["c"], k["theta0"])   # T'_bar
        zC = zW + 0.5 * k["beta"] * k["theta0"] - 0.5 * k["beta"] / k["c"] * dT
        return zC, dT / k["c"]

    def dissipation(self, step, dx, ds):
        """None: the total energy is conserved (conduction moves heat, the dashpots and the Kelvin-Voigt
        or Rayleigh damping turn work into heat)."""
        return None

    def compatible_strains(self, x):
        """C = |d_s r|^2; theta = theta0 unless given; eta = eta(C, theta)."""
        dom = ufl.domain.extract_unique_domain(x["r"])
        C = ufl.inner(x["r"].dx(0), x["r"].dx(0))
        branches = {f"C_{k}": relaxed for k in range(1, len(self.branches) + 1)}
        return {"C": C, "theta": lambda s: np.full(s.shape[1], self.theta0),
                "eta": self.entropy_of(C, x["theta"], dom), **branches}

    # -- what a run writes -----------------------------------------------------------
    def columns(self, x, dx, ds, length):
        """History columns of x_{n+1}: entropy int eta, mean_temperature (1/L) int theta(C, eta),
        entropy_production int kappa (d_s theta / theta)^2 of the step (theta: the step's field),
        heat_supplied int q (forms/heat_ports.py),
        temperature_left, temperature_right theta(C, eta) at the ends, arc_length int sqrt(C),
        mean_tension (1/L) int N."""
        dom = dx.ufl_domain()
        k = self._t(dom)
        th = x["theta"]
        theta = self.temperature(x["C"], x["eta"], dom)
        return {"entropy": x["eta"] * dx, "heat_supplied": heat_supplied(x, dx),
                "mean_temperature": theta / length * dx,
                "entropy_production": k["kappa"] * (th.dx(0) / th) ** 2 * dx,
                "temperature_left": theta * ds(ENDS["left"]), "temperature_right": theta * ds(ENDS["right"]),
                "arc_length": ufl.sqrt(x["C"]) * dx,
                "mean_tension": self.tension_at(x["C"], theta, dom, x) / length * dx}

    def outputs(self, x):
        """The string's outputs and the temperature theta(C, eta)."""
        out = super().outputs(x)
        dom = ufl.domain.extract_unique_domain(x["C"])
        out["temperature"] = self.temperature(x["C"], x["eta"], dom)
        out["tension"] = self.tension_at(x["C"], out["temperature"], dom, x)
        return out

    def tension_at(self, C, theta, domain, x=None):
        """N = S sqrt(C), S = 2 W'(C) - beta (theta - theta0) (+ the Maxwell branches' 2 W_k'(C_k), from x) (UFL)."""
        k = self._t(domain)
        Cv = ufl.variable(C)
        S = 2 * ufl.diff(self.W(Cv, domain), Cv) - k["beta"] * (theta - k["theta0"])
        for i, b in enumerate(self.branches if x is not None else (), 1):
            Ck = ufl.variable(x[f"C_{i}"])
            S = S + 2 * ufl.diff(b.spring(Ck), Ck)
        return S * ufl.sqrt(C)


def stress_free_strain(material, beta, dtheta):
    """C > 0 with 2 W'(C) = beta dtheta (a number): the free string's strain at theta0 + dtheta
    (bisection on the material's S(C) = 2 W'(C), increasing; kirchhoff: C = 1 + 2 alpha dtheta)."""
    target = beta * dtheta
    lo, hi = 1e-6, 1.0
    while material.stress(hi) < target:
        hi *= 2.0
        if hi > 1e6:
            raise ValueError(f"no stress-free strain: 2 W'(C) = {target:g} has no root with C < 1e6")
    if material.stress(lo) > target:
        raise ValueError(f"no stress-free strain: 2 W'(C) = {target:g} has no root with C > 1e-6")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if material.stress(mid) < target else (lo, mid)
        if hi - lo <= 4e-16 * hi:
            break
    return 0.5 * (lo + hi)
