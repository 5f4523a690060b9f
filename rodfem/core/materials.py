"""Materials: a stored energy W(strains; parameters) written as one UFL function.

    @material
    def logarithmic(C, EA):
        return EA / 4 * (C - ufl.ln(C) - 1)

`logarithmic(EA=20.0)` is then a `Material`, called as W(C) inside the forms
(``@material(strains=2)`` for W(Gamma, kappa, ...), and so on).
Its parameters enter the compiled forms as run-time constants (one
fem.Constant per parameter and mesh, found from the strains' mesh), so a new
parameter value does not recompile anything.  Every parameter must be a
positive number, except those named in ``signed`` (reference strains, ...),
which may be any number or a UFL expression.
"""
import inspect
import math

import ufl
from dolfinx import fem


class ParameterSet:
    """Named numbers that become fem.Constants on a mesh (cached per mesh)."""

    def __init__(self, **values):
        self.values = values
        self._on = []  # (domain, constants): by identity (an id() could be reused by a new mesh)

    def on(self, domain):
        """dict name -> fem.Constant on `domain` (UFL expressions are passed through)."""
        for d, consts in self._on:
            if d is domain:
                return consts
        consts = {k: v if isinstance(v, ufl.core.expr.Expr) else fem.Constant(domain, float(v))
                  for k, v in self.values.items()}
        self._on.append((domain, consts))
        return consts


def _domain(exprs):
    for e in exprs:
        if isinstance(e, ufl.core.expr.Expr):
            domain = ufl.domain.extract_unique_domain(e)
            if domain is not None:
                return domain
    return None


class Material(ParameterSet):
    """A stored energy W(*strains; params) with its parameter values."""

    def __init__(self, name, function, params, signed=()):
        super().__init__(**params)
        self.name, self.function, self.params = name, function, dict(params)
        for key, value in self.params.items():
            if key in signed:
                ok = isinstance(value, ufl.core.expr.Expr) or (isinstance(value, (int, float)) and math.isfinite(value))
                what = "a finite number"
            else:
                ok = isinstance(value, (int, float)) and math.isfinite(value) and value > 0
                what = "a positive number"
            if not ok:
                raise ValueError(f"material {name}: parameter {key} must be {what} (got {value!r})")

    def __call__(self, *strains, constants=None):
        """W(*strains) in UFL: the parameters are constants on the strains' mesh (numbers for numbers)."""
        if constants is None:
            domain = _domain(strains)
            constants = self.on(domain) if domain is not None else self.params
        return self.function(*strains, **constants)

    def __repr__(self):
        return f"{self.name}({', '.join(f'{k}={v}' for k, v in self.params.items())})"


def material(function=None, *, strains=1, signed=(), cls=Material):
    """Decorator: turn W(strain_1, ..., strain_k, **params) (k = `strains`) into a factory
    params -> Material (or the subclass `cls`); call it with the parameters, by position or name."""
    def wrap(f):
        sig = inspect.signature(f)
        names = list(sig.parameters)[strains:]

        def factory(*args, **kwargs):
            bound = sig.bind(*([None] * strains), *args, **kwargs)
            bound.apply_defaults()
            return cls(f.__name__, f, {k: bound.arguments[k] for k in names}, signed=signed)
        factory.__name__, factory.__doc__ = f.__name__, f.__doc__
        factory.energy_function = f
        return factory
    return wrap(function) if function is not None else wrap
