# # Thermoelastic damping: the axial vibration of a bar damped by heat conduction
#
# A thermoelastic string (forms/thermoelastic_string.py, kirchhoff material) pinned at both
# ends at its reference length vibrates axially in its first mode, u(s, 0) = U sin(pi s/L),
# starting at theta0 everywhere.  Stretching cools and compression heats (the coupling
# beta = EA alpha); heat then flows from the hot to the cold parts along s (kappa) and the
# vibration loses energy into heat -- the total energy H stays exact, the entropy grows.
#
# ## The analytic damping ratio of the same 1D model
#
# Linearise about C = 1, theta = theta0 with the axial displacement u, strain eps = u'
# (m(C) = (C - 1)/2 = u' + u'^2/2) and temperature change T = theta - theta0:
#
#     rhoA u_tt = (EA eps - beta T)',        N = S sqrt(C) ~ 2 W'(C) - beta T = EA eps - beta T,
#     c T_t + beta theta0 eps_t = kappa T'',  from theta d_t eta = kappa theta'', eta = beta m + c ln(theta/theta0).
#
# Pinned, insulated ends: u = U sin(k s) e^{z t}, T = Theta cos(k s) e^{z t}, k = n pi / L. Then
# Theta = -beta theta0 k z U / (c z + kappa k^2) and
#
#     rhoA z^2 + k^2 EA [1 + Delta tau z / (1 + tau z)] = 0,
#     Delta = beta^2 theta0 / (c EA)   (adiabatic / isothermal stiffness - 1),   tau = c / (kappa k^2),
#
# the standard linear solid of Zener's thermoelastic relaxation:
#
#     tau rhoA z^3 + rhoA z^2 + k^2 EA (1 + Delta) tau z + k^2 EA = 0.
#
# Its complex pair z = -zeta omega_n +- i omega_d gives the damping ratio zeta = -Re z / |z|
# (`analytic`); its real root -1/tau_T is the thermal relaxation of the mode's temperature.  For
# small Delta, zeta ~ (Delta / 2) omega tau / (1 + (omega tau)^2): largest, Delta/4, at omega tau = 1.
#
# ## The measured damping ratio
#
# The history's mean_x - L/2 = (1/L) int u ds = (2U/pi) x (the mode's amplitude) is fitted by least
# squares with the same form, e^{sigma t}(a cos omega t + b sin omega t) + d e^{lambda t}
# (`measured`), zeta_h = -sigma / sqrt(sigma^2 + omega^2).  The scene's parameter `omega_tau`
# sets kappa so that omega_0 tau = omega_tau (omega_0 = k sqrt(EA/rhoA)).
#
# Run it:  rodfem run thermoelastic-damping --out results/thermoelastic-damping

import sys

import numpy as np

from rodfem import Problem, Support
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.demos.heated_bar import thermal_parameters
from rodfem.forms.string_materials import kirchhoff
from rodfem.forms.thermoelastic_string import ThermoelasticString

parameters = common(n_elements=32, dt=2e-3, t_end=0.8, integrator="discrete-gradient", frames=10) + \
    thermal_parameters(alpha=3e-3, c=1.0) + [
    stiffness("EA", 100.0, "N", "axial stiffness (isothermal, small-strain)"),
    stiffness("rhoA", 1.0, "kg/m", "mass per reference length"),
    stiffness("L", 1.0, "m", "reference (unstretched) length"),
    Parameter("mode", 1, "", "axial mode n: u = U sin(n pi s/L)", low=1, high=8),
    Parameter("amplitude", 1e-5, "m", "amplitude U of the initial displacement (small: the linear theory)",
              low=0, low_open=True),
    Parameter("omega_tau", 1.0, "", "omega_0 tau = omega_0 c/(kappa k^2): sets kappa (the parameter kappa "
              "is not used)", low=0, low_open=True),
]


def wavenumber(p):
    return p["mode"] * np.pi / p["L"]


def conductivity(p):
    """kappa with omega_0 tau = omega_tau: kappa = c omega_0 / (omega_tau k^2)."""
    k = wavenumber(p)
    omega0 = k * np.sqrt(p["EA"] / p["rhoA"])
    return p["c"] * omega0 / (p["omega_tau"] * k * k)


def relaxation_strength(p):
    """Delta = beta^2 theta0 / (c EA), beta = EA alpha."""
    return (p["EA"] * p["alpha"]) ** 2 * p["theta0"] / (p["c"] * p["EA"])


def analytic(p):
    """(zeta, omega_d, thermal rate): the roots of tau rhoA z^3 + rhoA z^2 + k^2 EA (1 + Delta) tau z + k^2 EA."""
    k = wavenumber(p)
    tau = p["c"] / (conductivity(p) * k * k)
    EA, rhoA, D = p["EA"], p["rhoA"], relaxation_strength(p)
    roots = np.roots([tau * rhoA, rhoA, k * k * EA * (1 + D) * tau, k * k * EA])
    pair = roots[np.argmax(np.abs(roots.imag))]
    real = roots[np.argmin(np.abs(roots.imag))].real
    return float(-pair.real / abs(pair)), float(abs(pair.imag)), float(real)


def measured(t, x, p):
    """(zeta_h, omega_h): the least-squares fit of x(t) by e^{sigma t}(a cos wt + b sin wt) + d e^{lambda t},
    started from the undamped frequency and no damping (scipy.optimize.curve_fit)."""
    from scipy.optimize import curve_fit
    k = wavenumber(p)
    w0 = k * np.sqrt(p["EA"] / p["rhoA"])
    scale = np.max(np.abs(x))

    def f(t, sigma, w, a, b, d, lam):
        return np.exp(sigma * t) * (a * np.cos(w * t) + b * np.sin(w * t)) + d * np.exp(lam * t)

    tau = p["c"] / (conductivity(p) * k * k)
    popt, _ = curve_fit(f, t, x / scale, p0=[0.0, w0, 1.0, 0.0, 0.0, -1.0 / tau], maxfev=20000)
    sigma, w = popt[0], abs(popt[1])
    return float(-sigma / np.hypot(sigma, w)), float(w)


def build(p, comm):
    model = ThermoelasticString(kirchhoff(EA=p["EA"]), p["rhoA"], p["alpha"], p["c"], conductivity(p), p["theta0"])
    k, U = wavenumber(p), p["amplitude"]
    initial = {"r": lambda x: np.vstack([x[0] + U * np.sin(k * x[0]), 0 * x[0], 0 * x[0]]),
               "theta": lambda x: np.full(x.shape[1], p["theta0"])}
    # The vibration's energy is ~1e-8 J beside c theta0 L = 300 J of heat: Newton's default absolute
    # tolerance (1e-10) would leave the entropy's per-step production (~1e-13) in the noise.
    return Problem(model, p["L"], p["n_elements"], initial=initial,
                   supports=[Support("left", "pinned"), Support("right", "pinned")],
                   integrator=p["integrator"], comm=comm, newton_options={"snes_atol": 1e-14})


scene = Scene("thermoelastic-damping", "axial vibration of a pinned thermoelastic bar damped by heat conduction "
              "(Zener's thermoelastic relaxation of the 1D model)", parameters, build,
              notes="fit mean_x - L/2 with demos/thermoelastic_damping.py:measured, compare with analytic(p).")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
