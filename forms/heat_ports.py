"""Heat ports of a thermal model in entropy variables (forms/thermoelastic_string.py).

The thermal row of such a model is the entropy balance, tested with deta,

    int (eta_{n+1} - eta_n)/h deta + ... = sum of the ports' terms,

and its energy test function is the step's temperature theta (the model's field "theta"
in x_{n+1}): testing with deta = theta turns each port's term into its power.  So a heat
input P (W) enters the entropy row as P deta/theta (an entropy flow P/theta):

* `HeatFlux`: a heat flux Q(t) (W) into the end s = 0 or s = L.  Input u = Q, output
  y = the end's temperature, entropy flow Q/theta; power (the energy test) = Q.
* `Convection`: heat exchange with an environment at theta_env(t) (K), coefficient h_c
  (W/(m K), the film coefficient times the perimeter) along the whole length:
  input theta_env, heat flow h_c (theta_env - theta) per length, power
  int h_c (theta_env - theta) ds.

Both are `Load`s (rodfem/core/ports.py) on the field "eta": their work is in the run's
`supplied` column, so H_{n+1} - H_n = h y.u stays exact with them.  Their columns:
`<name>_temperature` (the flux port's output) and `<name>_power` (the heat rate of the
step, W; positive into the string).

The heat supplied (`HEAT`, the model's column `heat_supplied`): the thermal models carry one more
state, the heat q per reference length received through the heat ports since t = 0 (DG0), with
the row (`heat_row`, and each port's power density tested with dq)

    int (q_{n+1} - q_n)/h dq = sum of the ports' powers tested with dq,

so that (dq = 1) int q_{n+1} - int q_n = h (the heat ports' power) exactly: the thermal part of
`supplied`, cumulative, apart from the mechanical ports' work.  q enters neither H nor the
other rows (a meter, not a physical state).
"""
from dataclasses import dataclass

import numpy as np

from rodfem.core.model import Field
from rodfem.core.ports import ENDS, Load
from rodfem.errors import InputError

HEAT = Field("heat", "DG", 0)
HEAT_LABEL = {"heat": ("heat received through the heat ports since t = 0, per reference length", ())}


def heat_row(step, test, dx):
    """(q_{n+1} - q_n)/h dq: the meter's rate (the ports add their power densities)."""
    return step.rate("heat") * test["heat"] * dx


def heat_supplied(x, dx):
    """int q: the heat supplied through the heat ports since t = 0 (J), a history column."""
    return x["heat"] * dx


def _metered(test, density):
    """density dq if the model meters its heat (has the field "heat"), else 0."""
    return density * test["heat"] if "heat" in test else 0


@dataclass
class HeatFlux(Load):
    """A heat flux Q(t) (W, positive into the string) at the end `where` ('left' or 'right')."""
    flow: str = "eta"
    value: object = 0.0
    where: str = "left"
    name: str = ""

    def __post_init__(self):
        if self.where not in ENDS:
            raise InputError(f"HeatFlux.where must be 'left' or 'right' (got {self.where!r})")
        self.name = self.name or f"heat@{self.where}"
        super().__post_init__()

    def input_map(self, step, test, dx, ds):
        """-Q deta/theta at the end (and -Q dq on the heat meter)."""
        return -(self.constant * test["eta"] / step.x1["theta"] + _metered(test, self.constant)) * ds(ENDS[self.where])

    def power(self, step, dx, ds):
        """Q (the entropy flow Q/theta times the energy test theta)."""
        return self.constant * ds(ENDS[self.where])

    def observables(self, X, dx, ds):
        """The output (the end's temperature theta) and the heat rate Q."""
        end = ds(ENDS[self.where])
        return {f"{self.name}_temperature": X["theta"] * end,
                f"{self.name}_power": self.constant * end}


@dataclass
class Convection(Load):
    """Heat exchange h_c (theta_env(t) - theta) per length with an environment at theta_env (K);
    h_c >= 0 in W/(m K)."""
    flow: str = "eta"
    value: object = 293.15
    where: str = "domain"
    name: str = "convection"
    h_c: float = 0.0

    def __post_init__(self):
        if not (np.isfinite(self.h_c) and self.h_c >= 0):
            raise InputError(f"Convection.h_c must be a number >= 0 (got {self.h_c!r})")
        if self.where != "domain":
            raise InputError("Convection acts along the whole string (where='domain')")
        super().__post_init__()

    def bind(self, mesh, space):
        super().bind(mesh, space)
        from dolfinx import fem
        self.coefficient = fem.Constant(mesh, float(self.h_c))
        theta_env = self._value(0.0)
        if not np.all(theta_env > 0):
            raise InputError(f"Convection: theta_env must be a temperature > 0 K (got {theta_env})")

    def _flow(self, theta):
        return self.coefficient * (self.constant - theta)

    def input_map(self, step, test, dx, ds):
        """-h_c (theta_env - theta) deta/theta (and -h_c (theta_env - theta) dq on the heat meter)."""
        theta = step.x1["theta"]
        return -(self._flow(theta) * test["eta"] / theta + _metered(test, self._flow(theta))) * dx

    def power(self, step, dx, ds):
        """h_c (theta_env - theta), the energy test theta of the entropy flow."""
        return self._flow(step.x1["theta"]) * dx

    def observables(self, X, dx, ds):
        return {f"{self.name}_power": self._flow(X["theta"]) * dx}
