"""Step-size control of the time loop (rodfem/analysis/timeloop.py; issue 25).

Two modes, both made of ordinary steps of the rule (midpoint or discrete gradient), each of which
keeps the energy balance H_{n+1} - H_n = -h_n d_n + h_n y.u with its own h_n:

* fixed steps (the default): the grid t_n = n dt the user asked for.  A step whose Newton fails
  (after the retry from x_n) is split into 2, 4, 8, ... equal sub-steps from x_n, down to
  `dt_min` (default dt/1024); below it the run ends with the NewtonFailure (exit 3) as before.
  The history has one row per step of the grid (its `newton_its` the sum over the sub-steps,
  its balance the sum of theirs); the next step tries half as many sub-steps, down to one.
* adaptive (``--set adaptive=true --set rtol=... --set atol=...``): dt is the first step; each
  step is made by step doubling: one step of h and two of h/2 from x_n.  The two half steps are
  kept (two rows of the history, column `h` their size); their error is estimated by Richardson,
  e = |x_{h/2,h/2} - x_h| / (2^p - 1), p = 2, and measured field by field against the field's size,
  per step (the default) or per unit step (``error_per=unit-step``, T = t_end: the sum of the local
  errors over the run, the global error of a problem that does not amplify them, within the tolerance),

      err = max over fields f of  max_i |e_i| / (atol + rtol max(|x_n|_inf,f, |x_{n+1}|_inf,f))  (* T / h)

  (the multipliers, algebraic, left out; the velocities of a body with multipliers or a joint's point,
  index-2 variables with an undamped (-1)^n mode of the midpoint rule's constraint rows, measured by the
  displacement h e_v against their configuration's size: `System.field_groups`).  err <= 1 accepts the
  pair, err > 1 rejects it; the next h is h min(5, max(0.2, 0.9 err^(-1/(p+1)))) (per unit step
  err^(-1/p); no growth right after a rejection).  Measured on the linear oscillator (two periods, rtol =
  1e-2 ... 1e-6): per step the global error grows from 2.7 to 68 rtol |x|, per unit step it is 0.24 rtol
  |x| throughout, at 5 to 22 times the steps.  Per unit step is not the default: where a field starts at
  zero (a body at rest) its error is measured against atol, and Newton's tolerance (1e-10) times T/h then
  keeps err > 1 however small h gets (flying-spaghetti-3d stopped at h = 1e-8); on the robot arm it took
  74 182 steps at rtol = 1e-3 against 2258 per step (benchmarks/stepping.md).  A Newton failure is a
  rejection with h/4.  The steps land exactly on the output times (the frames: `frames` evenly spaced
  times with t = 0 and t_end).  Below `dt_min` (default 1e-9 t_end) the run ends with exit 3.  The inputs
  u(t) are read at each step's midpoint: a variable h samples them at other times than a fixed one.

``dt=auto`` (``run(problem, "auto", t_end, control=StepControl(adaptive=True, ...))``): an adaptive run
whose first step is the scene's time scale as its outputs resolve it, the first interval between output
times (the frames; t_end - t with none), at most (t_end - t)/10; until a step is accepted a rejection
shrinks it by 0.9 err^(-1/(p+1)) with the floor 1e-3 instead of 0.2 (the first step sized by its own
Richardson estimate, as Hairer, Norsett & Wanner, Solving Ordinary Differential Equations I, sec. II.4,
size theirs by an explicit one); a Newton failure quarters it as for any step.

Why step doubling and not the free estimate from the predictor: measured in benchmarks/stepping.md.
"""
import math
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI

ORDER = 2            # the midpoint rule and the discrete gradient are of second order
SAFETY, GROW, SHRINK, FAILED = 0.9, 5.0, 0.2, 0.25
FIRST_SHRINK = 1e-3  # dt=auto: the floor of a rejection's shrinking until a step is accepted
AUTO = "auto"
SPLIT_MAX = 1024     # fixed steps: dt_min = dt / SPLIT_MAX unless given
ADAPTIVE_MIN = 1e-9  # adaptive: dt_min = ADAPTIVE_MIN t_end unless given


@dataclass
class StepControl:
    """How the loop chooses its steps (see the module docstring).  `output_times`: the times an adaptive run
    lands on exactly (the frames); t_end always."""
    adaptive: bool = False
    rtol: float = 1e-3
    atol: float = 1e-6
    dt_min: float = 0.0
    output_times: tuple = ()
    per_unit_step: bool = False

    def minimum(self, dt, t_end):
        if self.dt_min > 0:
            return self.dt_min
        return ADAPTIVE_MIN * t_end if self.adaptive else dt / SPLIT_MAX


@dataclass
class StepState:
    """The controller's state, kept in checkpoints (a resumed run makes the same steps)."""
    h_prev: float = 0.0       # the last accepted (sub-)step: the predictor's ratio
    split: int = 1            # fixed steps: sub-steps the next step starts with
    h: float = 0.0            # adaptive: the next step proposed
    after_reject: bool = False
    rejected: int = 0         # attempts rejected (error) or failed (Newton), so far
    split_steps: int = 0      # fixed steps completed in sub-steps
    substeps: int = 0         # ordinary steps accepted (sub-steps counted one by one)
    max_substep_balance: float = 0.0
    solves: int = 0           # Newton solves, the rejected and the doubling's coarse ones included (the work)
    iterations: int = 0       # their Newton iterations

    def to_dict(self):
        return {k: getattr(self, k) for k in ("h_prev", "split", "h", "after_reject", "rejected", "split_steps",
                                              "substeps", "max_substep_balance", "solves", "iterations")}

    @classmethod
    def from_dict(cls, d):
        s = cls()
        for k, v in (d or {}).items():
            if hasattr(s, k):
                setattr(s, k, type(getattr(s, k))(v))
        return s


def exponent(per_unit_step):
    """err ~ h^(p+1) per step, h^p per unit step."""
    return 1.0 / ORDER if per_unit_step else 1.0 / (ORDER + 1)


def next_step(h, err, after_reject, per_unit_step=False):
    """The step after an accepted step h with error `err` (<= 1)."""
    fac = GROW if err <= 0 else min(GROW, max(SHRINK, SAFETY * err ** -exponent(per_unit_step)))
    return h * (min(fac, 1.0) if after_reject else fac)


def shrunk(h, err, per_unit_step=False, floor=SHRINK):
    """The step to retry after a rejected step h with error `err` > 1 (inf: a Newton failure); `floor`: the
    smallest factor (FIRST_SHRINK for the first step of dt=auto)."""
    if not math.isfinite(err):
        return FAILED * h
    return h * max(floor, min(1.0, SAFETY * err ** -exponent(per_unit_step)))


def first_step(t, t_end, output_times=()):
    """dt=auto: the first interval between the output times after t (t_end - t with none), at most (t_end - t)/10."""
    later = sorted(x for x in output_times if t < x < t_end) + [t_end]
    return min(later[0] - t, 0.1 * (t_end - t))


class ErrorNorm:
    """err of the module docstring, for a system's state vectors (owned entries; collective)."""

    def __init__(self, problem, rtol, atol, span=None):
        self.comm, self.rtol, self.atol, self.span = problem.comm, rtol, atol, span
        self.groups = problem.field_groups()

    def __call__(self, x0, x1, x_coarse, h):
        diff, size = np.zeros(len(self.groups)), np.zeros(len(self.groups))
        scaled = np.array([paired is not None for _, paired in self.groups], dtype=bool)
        for k, (idx, paired) in enumerate(self.groups):
            if len(idx):
                diff[k] = np.max(np.abs(x1[idx] - x_coarse[idx]))
            against = idx if paired is None else paired   # an index-2 velocity: h e_v against its configuration
            if len(against):
                size[k] = max(np.max(np.abs(x0[against])), np.max(np.abs(x1[against])))
        self.comm.Allreduce(MPI.IN_PLACE, diff, op=MPI.MAX)
        self.comm.Allreduce(MPI.IN_PLACE, size, op=MPI.MAX)
        diff[scaled] *= h
        e = diff / (2 ** ORDER - 1) / (self.atol + self.rtol * size) * (self.span / h if self.span else 1.0)
        if not np.all(np.isfinite(e)):
            return math.inf
        return float(np.max(e)) if len(e) else 0.0
