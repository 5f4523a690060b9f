"""The time loop: x_n -> x_{n+1} by Newton, with the discrete energy balance

    H(x_{n+1}) - H(x_n) = -h d_n + h y.u     (checked every step, recorded in the history)

h d_n >= 0 is the energy dissipated in the step (0 for a conservative model);
only a dissipating problem (`problem.dissipates`) has the column `dissipated`
(the sum of h d_n so far).

What the loop asks of a system (rodfem/core/model.py, `SteppedSystem`; rodfem/core/system.py
is the one implementation): `t` (the time of its state x_n, advanced by the loop), `comm`,
`set_step(h)`, `set_time(t)`, `predict(previous)`, `solve(step, t)`, `accept()`,
`hamiltonian()`, `supplied_work()`, `dissipates`, `dissipated_energy()` and `observe()`.
"""
import math
import time
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from rodfem.common import interrupts
from rodfem.common.limits import check_steps, shown
from rodfem.core.model import SteppedSystem
from rodfem.errors import NewtonFailure


@dataclass
class Result:
    """History of a run: one dict per time level (t = 0 included)."""
    rows: list = field(default_factory=list)
    wall_time: float = 0.0
    steps: int = 0

    def column(self, name: str) -> np.ndarray:
        return np.array([r[name] for r in self.rows])

    @property
    def max_balance_error(self) -> float:
        return max((abs(r["balance_error"]) for r in self.rows[1:]), default=0.0)


def steps_for(dt: float, t_end: float) -> int:
    """Number of steps n with n*dt = t_end to a relative 1e-9; at most MAX_STEPS (ValueError otherwise)."""
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a number > 0 (got {dt!r})")
    if not (math.isfinite(t_end) and t_end > 0):
        raise ValueError(f"t_end must be a number > 0 (got {t_end!r})")
    ratio = t_end / dt
    check_steps(ratio)  # also an overflow to inf
    n = int(round(ratio))
    if n < 1 or abs(n * dt - t_end) > 1e-9 * t_end:
        raise ValueError(f"dt must divide t_end into a whole number of steps (t_end/dt = {shown(ratio, n)})")
    return n


def run(problem: SteppedSystem, dt: float, t_end: float, writer=None, progress: bool = False,
        result: Optional[Result] = None, start=None, after_step: Optional[Callable] = None) -> Result:
    """Integrate `problem` from its current time `problem.t` to t_end with step dt.

    A new Problem starts at t = 0.  A second call continues from where the first
    stopped, with the load clock going on (``run(p, 0.01, 1.0); run(p, 0.01, 2.0)``
    is the same as ``run(p, 0.01, 2.0)``); a t_end not after `problem.t` is refused
    (ValueError).  The returned history starts at `problem.t`.

    Restart (rodfem/io/checkpoint.py): `start` (with .step, .t = problem.t, .H, .supplied,
    .dissipated, .previous) continues a run whose state x_n at step n = `start.step` of its
    own clock t_n = n dt is in the problem, with the loop's own state as it was (no row
    for t_n is written again; times are n dt as in the uninterrupted run, to the bit);
    `after_step(n, previous, H, supplied, dissipated)` is called after every accepted
    step n (checkpoints).

    `writer` (optional) receives every row (`writer.record(row, problem)`);
    on Newton failure the history written so far stays on disk (and in
    `result`, if one was passed in) and the NewtonFailure propagates.  Inside
    `rodfem.common.interrupts.deferred` a signal stops the loop between two steps
    (`rodfem.errors.Interrupted`).
    """
    t_start = problem.t
    if not t_end > t_start:
        raise ValueError(f"t_end = {t_end:g} is not after the problem's time t = {t_start:g} "
                         f"(run continues from where the last run stopped)")
    n_steps = steps_for(dt, t_end - t_start)
    problem.set_step(dt)
    res = result if result is not None else Result()
    dissipates = getattr(problem, "dissipates", False)
    first = 0
    if start is None:
        H = problem.hamiltonian()
        row = {"t": t_start, "H": H, "supplied": 0.0, **({"dissipated": 0.0} if dissipates else {}),
               "newton_its": 0, "balance_error": 0.0, **problem.observe()}
        res.rows.append(row)
        if writer:
            writer.record(row, problem)
    else:   # the run's own clock: t_n = 0 + n dt, as in the uninterrupted run
        first, t_start = start.step, 0.0
    bar = None
    if progress and problem.comm.rank == 0:
        from tqdm import tqdm
        bar = tqdm(total=first + n_steps, initial=first, unit="step", dynamic_ncols=True)
    supplied = dissipated = 0.0
    previous = None  # x_{n-1}, for the Newton start x_{n+1}^0 = 2 x_n - x_{n-1}
    if start is not None:
        H, supplied, dissipated, previous = start.H, start.supplied, start.dissipated, start.previous
    t0 = time.perf_counter()
    try:
        for n in range(first, first + n_steps):
            t, t_next = t_start + n * dt, t_start + (n + 1) * dt
            interrupts.check(problem.comm, n, t)
            problem.set_time(t + 0.5 * dt)
            try:
                problem.predict(previous)
                solve = problem.solve(n + 1, t_next)
            except NewtonFailure:
                if previous is None:
                    raise
                problem.predict(None)  # retry from x_n
                solve = problem.solve(n + 1, t_next)
            H_new = problem.hamiltonian()
            work = problem.supplied_work()
            supplied += work
            lost = problem.dissipated_energy() if dissipates else 0.0
            dissipated += lost
            row = {"t": t_next, "H": H_new, "supplied": supplied,
                   **({"dissipated": dissipated} if dissipates else {}), "newton_its": solve.iterations,
                   "balance_error": H_new - H + lost - work, **problem.observe()}
            if not np.isfinite(H_new):
                raise NewtonFailure(n + 1, t_next, float("nan"), solve.iterations, "non-finite energy")
            H = H_new
            previous = problem.accept()
            problem.t = t_next
            res.rows.append(row)
            res.steps = n + 1
            if writer:
                writer.record(row, problem)
            if after_step:
                after_step(n + 1, previous, H, supplied, dissipated)
            if bar:
                bar.update()
    finally:
        res.wall_time = time.perf_counter() - t0
        if bar:
            bar.close()
    return res
