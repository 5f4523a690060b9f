"""Thermoelastic planar beam: entropy density as a port-Hamiltonian state, heat flux as a port.

The planar Simo-Reissner beam of forms/planar_beam.py (Kinon, Betsch & Eugster, Multibody
Syst. Dyn. (2025), doi 10.1007/s11044-025-10087-9) with the thermal state of the thermoelastic
string (forms/thermoelastic_string.py, after Romero, Int. J. Numer. Meth. Eng. 79 (2009) 706-732,
doi 10.1002/nme.2588): the entropy density eta per reference length (P_k, like r) and the step's
temperature theta (P_k, the L2 projection of de/d eta).

Free energy (per reference length) with thermal expansion of the axial strain Gamma_1
(Gamma = A^T d_s r - e1, Gamma_1 = stretch - 1 for a straight beam), beta = EA alpha:

    psi(Gamma, kappa, theta) = W(Gamma, kappa) - beta (theta - theta0) Gamma_1
                               + c (theta - theta0 - theta ln(theta/theta0)),

so eta = -d psi/d theta = beta Gamma_1 + c ln(theta/theta0) and the internal energy is explicit:

    e(Gamma, kappa, eta) = W(Gamma, kappa) + beta theta0 Gamma_1 + c theta0 [exp(xi) - 1],
    xi = (eta - beta Gamma_1)/c,   theta = de/d eta = theta0 exp(xi),
    N = de/d Gamma = dW/d Gamma - beta (theta - theta0) e1,   M = dW/d kappa.

Closed forms (quadratic W): clamped at the reference length (Gamma = 0) at theta0 + dtheta,
N_1 = -EA alpha dtheta exactly; free, N_1 = 0 gives Gamma_1 = alpha dtheta, the length
L (1 + alpha dtheta) exactly (log_axial: EA (1 - 1/lambda) = EA alpha dtheta, lambda = 1/(1 - alpha dtheta)).
(No through-thickness temperature gradient: no thermal curvature.)

Balance laws: those of forms/planar_beam.py with the resultants N above, and the entropy balance
with Fourier conduction (kappa_th = conductivity x area) and the heat ports (forms/heat_ports.py),

    theta d_t eta = d_s (kappa_th d_s theta)  (+ heat ports).

Discrete gradient (`energy_efforts`): e is W(Gamma, kappa) + the linear beta theta0 Gamma_1 + T(xi),
T(xi) = c theta0 (exp(xi) - 1); the sum of the difference quotients of each term along its own
variable (Gonzalez, J. Nonlinear Sci. 6 (1996) 449-467, doi 10.1007/BF02440162),

    z_Gamma = grad_bar W + (beta theta0 - beta T'_bar / c) e1,   z_kappa = grad_bar W,   z_eta = T'_bar / c,

with T'_bar the sinh quotient of forms/thermoelastic_string.py (`thermal_slope`), satisfies
z . (x_{n+1} - x_n) = e(x_{n+1}) - e(x_n) pointwise.

Weak form: the beam's rows with (N, M) the L2 projection on DG_{k-1} of (z_Gamma, z_kappa) at every
degree (z_Gamma varies inside a cell with eta, and the beam's strain-row bracket A^T (v' - omega S r')
does too: only a DG_{k-1} effort turns it into the strain increment), and the string's thermal rows

    int (theta - z_eta) dtheta = 0,
    int (eta_{n+1} - eta_n)/h deta + kappa_th d_s theta d_s(deta/theta) = heat ports.

Energy: test the beam's rows as in forms/planar_beam.py (the strain rows with (N, M): the projection
gives int N.dGamma = int z_Gamma.dGamma since dGamma is in DG_{k-1}), the theta-row with
(eta_{n+1} - eta_n)/h and the eta-row with theta (the conduction term vanishes):

    H_{n+1} - H_n = h y.u,

H = int 1/2 rhoA v.v + 1/2 rhoI omega^2 + e ds the total energy, exact for the discrete gradient.

Maxwell branches and Kelvin-Voigt / Rayleigh damping (forms/viscoelastic.py, forms/damping.py): their work
d_n >= 0 of forms/planar_beam.py (`dissipation_density`: sum_j N_j.R_j N_j + R_j M_j^2 + e.D e
+ alpha (rhoA v.v + rhoI omega^2)) is a heat source in the entropy row, - d_n deta/theta, as in
forms/thermoelastic_string.py: the mechanical loss is the heat's gain (deta = theta), the total energy
stays exact, nothing is booked as `dissipated`, and the entropy grows by h int d_n/theta more.
The heat ports' work is in `supplied`, and cumulative in the column `heat_supplied` (the heat meter q
of forms/heat_ports.py, one more DG0 state).
Entropy: the eta-row with deta = 1: int eta_{n+1} - int eta_n = h int kappa_th (theta'/theta)^2 + ports >= 0.
"""
import ufl

from rodfem.core.materials import ParameterSet
from rodfem.core.model import Field
from rodfem.core.ports import ENDS
from rodfem.forms.heat_ports import HEAT, HEAT_LABEL, heat_row, heat_supplied
from rodfem.forms.planar_beam import E1, PlanarBeam
from rodfem.forms.thermoelastic_string import conduction, thermal_parameters, thermal_slope


class ThermoelasticBeam(PlanarBeam):
    """Thermoelastic planar beam: `energy` W(Gamma, kappa) (a planar-beam material with a parameter EA,
    its isothermal energy at theta0), rhoA, rhoI, the expansion coefficient alpha (1/K), the heat
    capacity c per reference length (J/(K m), > 0), kappa_th = conductivity x area (W m/K, >= 0),
    the reference temperature theta0 (K, > 0); degree, gauss_points, branches, damping as for PlanarBeam."""
    projects = True
    supports = PlanarBeam.supports
    labels = {**PlanarBeam.labels,
              "eta": ("entropy density per reference length (the state's)", ()),
              "theta": ("the step's temperature (L2 projection of de/d eta)", ()),
              "temperature": ("temperature theta(Gamma, eta) = de/d eta", ()), **HEAT_LABEL}
    units = {**PlanarBeam.units, "eta": "J/(K m)", "theta": "K", "temperature": "K", "heat": "J/m"}
    static_fields = None   # no statics: the thermal rows have no total form

    def __init__(self, rhoA, rhoI, energy, alpha, c, kappa_th, theta0, degree=1, gauss_points=None,
                 branches=(), damping=None):
        EA = getattr(energy, "params", {}).get("EA")
        if EA is None:
            raise ValueError(f"ThermoelasticBeam: energy {energy!r} has no parameter EA (the coupling is beta = EA alpha)")
        self.alpha, self.c, self.kappa_th, self.theta0 = thermal_parameters("ThermoelasticBeam", alpha, c, kappa_th,
                                                                            theta0, "kappa_th")
        super().__init__(rhoA, rhoI, energy, degree, gauss_points, branches, damping)
        k = self.degree
        self.fields = self.fields + [Field("eta", "P", k), Field("theta", "P", k), HEAT]
        self.beta = self.alpha * float(EA)
        self.thermal = ParameterSet(beta=self.beta, c=self.c, kappa=self.kappa_th, theta0=self.theta0)

    # -- energy and temperature ------------------------------------------------------
    def internal_energy(self, Gamma, kappa, eta, domain):
        """e = W(Gamma, kappa) + beta theta0 Gamma_1 + c theta0 [exp((eta - beta Gamma_1)/c) - 1]."""
        k = self.thermal.on(domain)
        return (self.energy(Gamma, kappa) + k["beta"] * k["theta0"] * Gamma[0]
                + k["c"] * k["theta0"] * (ufl.exp((eta - k["beta"] * Gamma[0]) / k["c"]) - 1))

    def temperature(self, Gamma, eta, domain):
        """theta = theta0 exp((eta - beta Gamma_1)/c)."""
        k = self.thermal.on(domain)
        return k["theta0"] * ufl.exp((eta - k["beta"] * Gamma[0]) / k["c"])

    def entropy_of(self, Gamma, theta, domain):
        """eta = beta Gamma_1 + c ln(theta/theta0)."""
        k = self.thermal.on(domain)
        return k["beta"] * Gamma[0] + k["c"] * ufl.ln(theta / k["theta0"])

    def hamiltonian(self, x, dx, ds):
        """H = int 1/2 rhoA v.v + 1/2 rhoI omega^2 + e(Gamma, kappa, eta) (+ branch energies) ds."""
        dom = dx.ufl_domain()
        thermal = self.internal_energy(x["Gamma"], x["kappa"], x["eta"], dom) - self.energy(x["Gamma"], x["kappa"])
        return super().hamiltonian(x, dx, ds) + thermal * dx

    # -- the step --------------------------------------------------------------------
    def _xi(self, x, k):
        return (x["eta"] - k["beta"] * x["Gamma"][0]) / k["c"]

    def energy_efforts(self, step, domain):
        """(z_Gamma, z_kappa) of the module docstring (UFL); z_eta in `entropy_effort`."""
        k = self.thermal.on(domain)
        N, M = super().energy_efforts(step, domain)
        dT = thermal_slope(step.rule, self._xi(step.x0, k), self._xi(step.x1, k), k["c"], k["theta0"])
        return N + (k["beta"] * k["theta0"] - k["beta"] / k["c"] * dT) * E1, M

    def entropy_effort(self, step, domain):
        """z_eta = T'_bar / c."""
        k = self.thermal.on(domain)
        return thermal_slope(step.rule, self._xi(step.x0, k), self._xi(step.x1, k), k["c"], k["theta0"]) / k["c"]

    def residual(self, step, test, dx, ds):
        """The beam's rows (with the thermal resultant) and the two thermal rows of the module docstring."""
        dom = dx.ufl_domain()
        k = self.thermal.on(dom)
        deta, dth, theta = test["eta"], test["theta"], step.x1["theta"]
        thermal = ((theta - self.entropy_effort(step, dom)) * dth
                   + step.rate("eta") * deta + conduction(k["kappa"], theta, deta)) * dx + heat_row(step, test, dx)
        heat = self.dissipation_density(step, dom)   # the dashpots' work becomes heat
        if heat is not None:
            thermal -= heat * deta / theta * dx
        return super().residual(step, test, dx, ds) + thermal

    def dissipation(self, step, dx, ds):
        """None: the total energy is conserved (the dashpots and the damping turn work into heat)."""
        return None

    def compatible_strains(self, x):
        """Gamma, kappa of the configuration; theta = theta0 unless given; eta = eta(Gamma, theta)."""
        out = super().compatible_strains(x)
        dom = ufl.domain.extract_unique_domain(x["r"])
        out["theta"] = lambda s: 0 * s[0] + self.theta0
        out["eta"] = self.entropy_of(out["Gamma"], x["theta"], dom)
        return out

    # -- what a run writes -----------------------------------------------------------
    def outputs(self, x):
        """The beam's outputs with the thermal axial force -beta (theta - theta0), and the temperature."""
        out = super().outputs(x)
        dom = ufl.domain.extract_unique_domain(x["Gamma"])
        k = self.thermal.on(dom)
        theta = self.temperature(x["Gamma"], x["eta"], dom)
        out["N"] = out["N"] - k["beta"] * (theta - k["theta0"]) * E1
        out["temperature"] = theta
        return out

    def columns(self, x, dx, ds, length):
        """History columns of x_{n+1}: entropy int eta, mean_temperature (1/L) int theta(Gamma, eta),
        entropy_production int kappa_th (theta'/theta)^2 (theta: the step's field), heat_supplied int q
        (forms/heat_ports.py), temperature_left,
        temperature_right, arc_length int |d_s r|, mean_axial_force (1/L) int N_1."""
        dom = dx.ufl_domain()
        k = self.thermal.on(dom)
        th = x["theta"]
        theta = self.temperature(x["Gamma"], x["eta"], dom)
        N = self.outputs(x)["N"]
        return {"entropy": x["eta"] * dx, "heat_supplied": heat_supplied(x, dx),
                "mean_temperature": theta / length * dx,
                "entropy_production": k["kappa"] * (th.dx(0) / th) ** 2 * dx,
                "temperature_left": theta * ds(ENDS["left"]), "temperature_right": theta * ds(ENDS["right"]),
                "arc_length": ufl.sqrt(ufl.inner(x["r"].dx(0), x["r"].dx(0))) * dx,
                "mean_axial_force": N[0] / length * dx}

