"""The port layer: inputs u, conjugate outputs y = B^T z, and supports.

A `Load` is an input u(t) paired with a flow field of the model (for a rod:
force <-> velocity v, moment <-> angular velocity).  It enters the balance
rows as

    - <u(t_{n+1/2}), B(x_{n+1/2})^T delta_x>_Gamma   (Gamma = an end point or the whole rod)

and its output is y = B(x_{n+1/2})^T z, so that the work supplied in one
step is h u.y, assembled with the same measure.  By default B^T picks the
flow field (<u, B^T w> = u . w[flow]); a `pairing(u, xm, w)` gives any other
(state-dependent) input map, e.g. a moment acting on director velocities.
A scene adds only the loads it uses.

A `Support` fixes fields at an end (Dirichlet rows): 'clamped' or 'pinned'
name a set of fields given by the model.
"""
from dataclasses import dataclass, field
from typing import Callable, Optional, Union

import numpy as np
import ufl
from dolfinx import fem

from rodfem.errors import InputError

ENDS = {"left": 1, "right": 2}  # facet tags of s = 0 and s = L


def constant_in_time(value, until: Optional[float] = None) -> Callable[[float], np.ndarray]:
    """u(t) = value for t <= until (all t if until is None), zero after."""
    value = np.asarray(value, dtype=float)

    def u(t):
        return value if until is None or t <= until else np.zeros_like(value)
    return u


def ramp(value, t_ramp: float) -> Callable[[float], np.ndarray]:
    """u(t) = value * min(t / t_ramp, 1)."""
    value = np.asarray(value, dtype=float)
    return lambda t: value * min(t / t_ramp, 1.0)


@dataclass
class Load:
    """Input u(t) acting on the balance row of `flow` at `where` ('left', 'right' or 'domain').

    `value` is an array (constant) or a callable t -> array; for 'domain' it is
    a force/moment per unit length.  `name` labels the port in outputs.
    `pairing(u, xm, w)` (optional): the density <u, B(xm)^T w>, with xm the
    midpoint fields and w either test functions or midpoint flows (dicts by name).
    """
    flow: str
    value: Union[Callable, np.ndarray, float]
    where: str = "right"
    name: str = ""
    pairing: Optional[Callable] = None
    constant: fem.Constant = field(default=None, init=False, repr=False)
    steady: Optional[Callable] = field(default=None, init=False, repr=False)   # a value given as an array

    def __post_init__(self):
        if self.where not in ("left", "right", "domain"):
            raise InputError(f"Load.where must be 'left', 'right' or 'domain' (got {self.where!r})")
        if not callable(self.value):
            self.value = self.steady = constant_in_time(self.value)
        self.name = self.name or f"{self.flow}@{self.where}"

    def bind(self, mesh, space):
        if self.pairing is None and self.flow not in space.names:
            raise InputError(f"load {self.name}: Load.flow must be one of the fields {', '.join(space.names)} "
                             f"(got {self.flow!r})")
        u0 = self._value(0.0)
        if self.pairing is None:
            shape = space.field(self.flow).shape
            if u0.shape != tuple(shape):
                raise InputError(f"load {self.name}: value has shape {u0.shape}, field {self.flow!r} has {tuple(shape)}")
        self.constant = fem.Constant(mesh, u0)

    def _value(self, t):
        """u(t) as a finite array (InputError naming the load otherwise)."""
        try:
            u = np.asarray(self.value(t), dtype=float)
        except (TypeError, ValueError) as e:
            raise InputError(f"load {self.name}: its value at t = {t:g} is not an array of numbers ({e})") from None
        if not np.isfinite(u).all():
            raise InputError(f"load {self.name}: its value at t = {t:g} is not finite ({u})")
        return u

    def _pair(self, step, w):
        if self.pairing is None:
            return ufl.inner(self.constant, w[self.flow])
        return self.pairing(self.constant, {n: step.mid(n) for n in step.x0}, w)

    def measure(self, dx, ds):
        return dx if self.where == "domain" else ds(ENDS[self.where])

    def update(self, t):
        if self.value is self.steady and self.constant is not None:   # (its constant holds u(0), set by bind;
            return                                                     # a value swapped in later is read)
        u = self._value(t)
        if u.shape != self.constant.value.shape:
            raise InputError(f"load {self.name}: its value at t = {t:g} has shape {u.shape}, at t = 0 it had "
                             f"{self.constant.value.shape}")
        self.constant.value = u

    def input_map(self, step, test, dx, ds):
        """B u: the load's term in the residual, -<u, B^T delta_x>."""
        return -self._pair(step, test) * self.measure(dx, ds)

    def power(self, step, dx, ds):
        """y.u = <u, B^T z> with the midpoint flows z on the port."""
        return self._pair(step, {n: step.mid(n) for n in step.x0}) * self.measure(dx, ds)


@dataclass
class Support:
    """Fix the model's `kind` fields ('clamped', 'pinned', ...) at `end` to their initial values."""
    end: str
    kind: str = "clamped"

    def __post_init__(self):
        if self.end not in ENDS:
            raise ValueError(f"Support.end must be 'left' or 'right' (got {self.end!r})")

    def conditions(self, space, model, facets, state0):
        names = model.supports.get(self.kind)
        if names is None:
            raise ValueError(f"support kind must be one of {sorted(model.supports)} (got {self.kind!r})")
        bcs = []
        for name in names:
            base, _, comp = name.partition(".")
            sub = space.sub(base) if not comp else space.sub(base).sub(int(comp))
            dofs = fem.locate_dofs_topological(sub, 0, facets[self.end])
            bcs.append(fem.dirichletbc(state0, dofs))
        return bcs
