"""Scenes: a named, parametrised set-up of a model (the demos register them).

A scene lists its `Parameter`s (default, unit, allowed range) and a
`build(p, comm)` that returns a `Problem`.  Every scene has the common
parameters n_elements, dt, t_end, integrator, frames and section.  Scenes are found
through the entry-point group ``rodfem.scenes`` (see pyproject.toml), so
rodfem itself names no model.
"""
import math
import numbers
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from typing import Callable, Optional

from rodfem.core.integrators import RULES
from rodfem.errors import ParameterError


@dataclass
class Parameter:
    name: str
    default: object
    unit: str = ""
    doc: str = ""
    low: Optional[float] = None       # allowed range: low <(=) value <(=) high
    high: Optional[float] = None
    low_open: bool = False            # True: value > low, False: value >= low
    choices: Optional[tuple] = None
    infinite: bool = False            # True: +inf is allowed too (a limit that has a meaning)
    words: tuple = ()                 # texts allowed besides the numbers (dt: "auto")

    @property
    def kind(self):
        return type(self.default)

    def allowed(self):
        if self.choices:
            return "one of " + ", ".join(map(str, self.choices))
        what = "an integer" if self.kind is int else "a number"
        if self.low is not None and self.high is not None:
            return f"{what} in {'(' if self.low_open else '['}{self.low:g}, {self.high:g}]"
        if self.low is not None:
            what = f"{what} {'>' if self.low_open else '>='} {self.low:g}{' (inf allowed)' if self.infinite else ''}"
        return what + "".join(f" or {w}" for w in self.words)

    def parse(self, text):
        if self.choices:
            if text not in self.choices:
                raise ParameterError(f"parameter '{self.name}' must be {self.allowed()} (got {text!r})")
            return text
        if text in self.words:
            return text
        try:
            value = float(text)
        except (TypeError, ValueError):
            raise ParameterError(f"parameter '{self.name}' must be {self.allowed()} (got {text!r})") from None
        if self.kind is int:
            if not value.is_integer():   # 10.5, inf, nan (10.0 is 10)
                raise ParameterError(f"parameter '{self.name}' must be {self.allowed()} (got {text!r})")
            value = int(value)
        self.check(value)
        return value

    def value(self, given):
        """The value of `given` (a text from --set, or a number from the API), checked; an integer
        parameter as an int."""
        if isinstance(given, str):
            return self.parse(given)
        self.check(given)
        return int(given) if self.kind is int else given

    def check(self, value):
        if self.choices:
            if value not in self.choices:
                raise ParameterError(f"parameter '{self.name}' must be {self.allowed()} (got {value!r})")
            return
        if isinstance(value, str) and value in self.words:
            return
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise ParameterError(f"parameter '{self.name}' must be {self.allowed()} (got {value!r})")
        bad = not (math.isfinite(value) or (self.infinite and value == math.inf))
        bad |= self.kind is int and not bad and value != int(value)
        if self.low is not None:
            bad |= value <= self.low if self.low_open else value < self.low
        if self.high is not None:
            bad |= value > self.high
        if bad:
            raise ParameterError(f"parameter '{self.name}' must be {self.allowed()} (got {value:g})")


def common(n_elements, dt, t_end, integrator="midpoint", frames=101):
    """The parameters every scene has."""
    return [
        Parameter("n_elements", n_elements, "", "number of finite elements (at least one per MPI rank)", low=1),
        Parameter("dt", dt, "s", "time step h (adaptive=true: the first step; auto: adaptive steps starting with "
                  "the first interval between frames, at most t_end/10)", low=0, low_open=True, words=("auto",)),
        Parameter("t_end", t_end, "s", "final time", low=0, low_open=True),
        Parameter("integrator", integrator, "", "time integrator", choices=RULES),
        Parameter("frames", frames, "", "frames written (centreline/, surface/, animation.gif) at t_j = j t_end / "
                  "(frames - 1), t = 0 and t_end included (between two time levels: interpolated; 101: every "
                  "t_end/100; 1: t_end only; every time level when there are fewer steps)", low=1),
        Parameter("section", 0.0, "m", "width of the cross-section drawn in surface/ and the pictures "
                  "(height: half of it; 0: the scene's cross-section if it has one, else a 25th of the "
                  "longest body)", low=0),
        *stepping(),
    ]


def stepping():
    """The step control's parameters (rodfem/analysis/stepping.py)."""
    return [
        Parameter("adaptive", "false", "", "adaptive time steps to the tolerances rtol, atol (step doubling; the "
                  "frames' times are hit exactly)", choices=("false", "true")),
        Parameter("rtol", 1e-3, "", "adaptive: relative tolerance of a step's error, per field", low=0, low_open=True),
        Parameter("atol", 1e-6, "", "adaptive: absolute tolerance of a step's error", low=0),
        Parameter("error_per", "step", "", "adaptive: the error controlled per step, or per unit step (the global "
                  "error within the tolerance, at more steps)", choices=("step", "unit-step")),
        Parameter("dt_min", 0.0, "s", "smallest step: a fixed step whose Newton fails is split down to it, an "
                  "adaptive step shrinks down to it, then the run stops (0: dt/1024, adaptive 1e-9 t_end)", low=0),
    ]


def stiffness(name, default, unit, doc):
    return Parameter(name, default, unit, doc, low=0, low_open=True)


def relaxation_time(name, default, doc):
    """A dashpot's relaxation time tau > 0 in s; inf: no dashpot (the branch is a parallel spring)."""
    return Parameter(name, default, "s", doc, low=0, low_open=True, infinite=True)


def density(name, default, unit, doc):
    return Parameter(name, default, unit, doc, low=0)


@dataclass
class Scene:
    name: str
    description: str
    parameters: list
    build: Callable                      # build(p: dict, comm) -> Problem
    reference: Optional[Callable] = None  # reference(p) -> dict of exact values (for studies)
    reference_is_static: bool = True      # the reference is an equilibrium (`rodfem static` compares with it)
    notes: str = ""
    _index: dict = field(default=None, init=False, repr=False)

    def parameter(self, name):
        if self._index is None:
            self._index = {p.name: p for p in self.parameters}
        if name not in self._index:
            raise ParameterError(f"unknown parameter '{name}' for scene {self.name}; "
                                 f"allowed: {', '.join(self._index)}")
        return self._index[name]

    def values(self, overrides=None):
        """Defaults updated by `overrides` (dict name -> text or value), all checked."""
        p = {q.name: q.default for q in self.parameters}
        for name, value in (overrides or {}).items():
            p[name] = self.parameter(name).value(value)
        return p


def scenes():
    """All registered scenes, by name."""
    found = {}
    for ep in entry_points(group="rodfem.scenes"):
        found[ep.name] = ep
    return dict(sorted(found.items()))


def load(name):
    table = scenes()
    if name not in table:
        raise ParameterError(f"unknown scene '{name}'; available: {', '.join(table)}")
    return table[name].load()
