"""The time loop: x_n -> x_{n+1} by Newton, with the discrete energy balance

    H(x_{n+1}) - H(x_n) = -h d_n + h y.u     (checked every step, recorded in the history)

h d_n >= 0 is the energy dissipated in the step (0 for a conservative model);
only a dissipating problem (`problem.dissipates`) has the column `dissipated`
(the sum of h d_n so far).

What the loop asks of a system (rodfem/core/model.py, `SteppedSystem`; rodfem/core/system.py
is the one implementation): `t` (the time of its state x_n, advanced by the loop), `comm`,
`set_step(h)`, `set_time(t)`, `predict(previous)`, `solve(step, t)`, `accept()`,
`hamiltonian()`, `supplied_work()`, `dissipates`, `dissipated_energy()` and `observe()`; for step-size
control (rodfem/analysis/stepping.py) also `snapshot()`, `restore(snapshot)`, `state()` and `field_groups()`.
"""
import math
import time
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from rodfem.analysis.stepping import (
    AUTO,
    FAILED,
    FIRST_SHRINK,
    SHRINK,
    ErrorNorm,
    StepControl,
    StepState,
    first_step,
    next_step,
    shrunk,
)
from rodfem.common import interrupts
from rodfem.common.limits import check_steps, shown
from rodfem.core.model import SteppedSystem
from rodfem.errors import NewtonFailure


@dataclass
class Result:
    """History of a run: one dict per time level (t = 0 included).  `stepping`: the step control's counts
    (rodfem/analysis/stepping.py: rejected, split_steps, substeps, max_substep_balance)."""
    rows: list = field(default_factory=list)
    wall_time: float = 0.0
    steps: int = 0
    stepping: dict = field(default_factory=dict)

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
        result: Optional[Result] = None, start=None, after_step: Optional[Callable] = None,
        control: Optional[StepControl] = None) -> Result:
    """Integrate `problem` from its current time `problem.t` to t_end with step dt.

    A new Problem starts at t = 0.  A second call continues from where the first
    stopped, with the load clock going on (``run(p, 0.01, 1.0); run(p, 0.01, 2.0)``
    is the same as ``run(p, 0.01, 2.0)``); a t_end not after `problem.t` is refused
    (ValueError).  The returned history starts at `problem.t`.

    `control` (rodfem/analysis/stepping.py): fixed steps dt (the default), a step whose Newton
    fails split into 2, 4, ... sub-steps down to `control.dt_min`; or adaptive steps (dt the
    first one; dt = "auto": chosen by the rule of `stepping.first_step`) to the tolerances rtol,
    atol, landing on `control.output_times`.

    Restart (rodfem/io/checkpoint.py): `start` (with .step, .t = problem.t, .H, .supplied,
    .dissipated, .previous, .stepping) continues a run whose state x_n at step n = `start.step`
    is in the problem, with the loop's own state as it was (no row for t_n is written again;
    fixed steps: times are n dt as in the uninterrupted run, to the bit; adaptive: the step
    controller's state restored); `after_step(n, previous, H, supplied, dissipated, stepping=...)`
    is called after every accepted step n (checkpoints; `stepping`: the controller's state and t).

    `writer` (optional) receives every row (`writer.record(row, problem)`);
    on Newton failure the history written so far stays on disk (and in
    `result`, if one was passed in) and the NewtonFailure propagates.  Inside
    `rodfem.common.interrupts.deferred` a signal stops the loop between two steps
    (`rodfem.errors.Interrupted`).
    """
    control = control or StepControl()
    t_start = problem.t
    if not t_end > t_start:
        raise ValueError(f"t_end = {t_end:g} is not after the problem's time t = {t_start:g} "
                         f"(run continues from where the last run stopped)")
    auto = isinstance(dt, str) and dt == AUTO and start is None
    if isinstance(dt, str) and dt == AUTO:
        if not control.adaptive:
            raise ValueError("dt = auto needs adaptive steps (control=StepControl(adaptive=True, ...))")
        dt = first_step(t_start, t_end, control.output_times)
    if control.adaptive:
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a number > 0 (got {dt!r})")
        n_steps = None
    else:
        n_steps = steps_for(dt, t_end - t_start)
    problem.set_step(dt)
    res = result if result is not None else Result()
    dissipates = getattr(problem, "dissipates", False)
    adaptive = control.adaptive
    first = 0
    if start is None:
        H = problem.hamiltonian()
        row = {"t": t_start, "H": H, "supplied": 0.0, **({"dissipated": 0.0} if dissipates else {}),
               "newton_its": 0, "balance_error": 0.0, **({"h": 0.0, "error_estimate": 0.0} if adaptive else {}),
               **problem.observe()}
        res.rows.append(row)
        if writer:
            writer.record(row, problem)
    elif adaptive:
        first, t_start = start.step, start.t
    else:   # the run's own clock: t_n = 0 + n dt, as in the uninterrupted run
        first, t_start = start.step, 0.0
    state = StepState.from_dict(getattr(start, "stepping", None))
    state.h_prev, state.h = state.h_prev or dt, state.h or dt
    h_min = control.minimum(dt, t_end)
    bar = None
    if progress and problem.comm.rank == 0:
        from tqdm import tqdm
        bar = (tqdm(total=t_end, initial=t_start, unit="s", dynamic_ncols=True) if adaptive else
               tqdm(total=first + n_steps, initial=first, unit="step", dynamic_ncols=True))
    supplied = dissipated = 0.0
    previous = None  # x_{n-1}, for the Newton start x_{n+1}^0 = x_n + (h_n/h_{n-1}) (x_n - x_{n-1})
    if start is not None:
        H, supplied, dissipated, previous = start.H, start.supplied, start.dissipated, start.previous

    def one(h, t, t1, previous, ratio, step):
        return attempt(problem, state, h, t, t1, previous, ratio, step, dissipates)

    def record(row, n, loop=None):
        """The row of accepted step n; `loop` = (previous, H, supplied, dissipated): a checkpoint may follow."""
        res.rows.append(row)
        res.steps = n
        if writer:
            writer.record(row, problem)
        if after_step and loop:
            after_step(n, *loop, stepping=dict(state.to_dict(), t=problem.t))

    def split(t, t_next, k, previous, step, H):
        """[t, t_next] in k equal sub-steps from x_n (k = 1: the step itself), the last one not accepted:
        (iterations, H, work, dissipated, largest sub-step balance); on a failure the state is put back
        at x_n and the NewtonFailure raised."""
        h = dt / k
        snap = problem.snapshot() if k > 1 else None
        its, work, lost, worst, ratio = 0, 0.0, 0.0, 0.0, h / state.h_prev
        for i in range(k):
            t0, t1 = t + i * h, (t_next if i == k - 1 else t + (i + 1) * h)
            try:
                s_its, H_new, w, d = one(h, t0, t1, previous, ratio, step)
            except NewtonFailure:
                if snap is not None:
                    problem.restore(snap)
                raise
            its, work, lost = its + s_its, work + w, lost + d
            worst, H = max(worst, abs(H_new - H + d - w)), H_new
            if i < k - 1:
                previous, ratio = problem.accept(), 1.0
        return its, H, work, lost, worst

    t0 = time.perf_counter()
    try:
        if adaptive:
            run_adaptive(problem, t_start, t_end, first, one, record, state, control, h_min,
                         H, previous, dissipates, bar, (supplied, dissipated), auto)
            return res
        for n in range(first, first + n_steps):
            t, t_next = t_start + n * dt, t_start + (n + 1) * dt
            interrupts.check(problem.comm, n, t)
            k, failed = state.split, False
            while True:
                try:
                    its, H_new, work, lost, worst = split(t, t_next, k, previous, n + 1, H)
                    break
                except NewtonFailure as e:
                    state.rejected += 1
                    if dt / (2 * k) < h_min * (1 - 1e-12):
                        raise NewtonFailure(e.step, e.t, e.residual, e.iterations,
                                            e.reason + (f"; split into {k} sub-steps of {dt / k:.3g}, dt_min = {h_min:.3g}"
                                                        if dt / 2 >= h_min * (1 - 1e-12) else
                                                        f"; dt_min = {h_min:.3g} allows no sub-steps")) from None
                    k, failed = 2 * k, True
            state.split = k if failed else max(1, k // 2)
            state.split_steps += k > 1
            state.substeps += k
            state.h_prev = dt / k
            state.max_substep_balance = max(state.max_substep_balance, worst)
            supplied += work
            dissipated += lost
            row = {"t": t_next, "H": H_new, "supplied": supplied,
                   **({"dissipated": dissipated} if dissipates else {}), "newton_its": its,
                   "balance_error": H_new - H + lost - work, **problem.observe()}
            H = H_new
            previous = problem.accept()
            problem.t = t_next
            record(row, n + 1, (previous, H, supplied, dissipated))
            if bar:
                bar.update()
    finally:
        res.wall_time = time.perf_counter() - t0
        res.stepping = dict(state.to_dict(), adaptive=adaptive, dt_min=h_min)
        if bar:
            bar.close()
    return res


def attempt(problem, state, h, t, t1, previous, ratio, step, dissipates):
    """One ordinary step of size h of `problem` from x_n at t to t1 (Newton from the predictor
    x_n + ratio (x_n - previous), retried once from x_n): (iterations, H_{n+1}, h y.u, h d_n), with
    x_{n+1} not accepted; `state` (StepState) counts the solves and iterations.  The time loop's step
    and the step interface's (rodfem/app/simulator.py)."""
    problem.set_step(h)
    problem.set_time(t + 0.5 * h)
    state.solves += 1
    try:
        problem.predict(previous, ratio)
        solve = problem.solve(step, t1)
    except NewtonFailure as e:
        state.iterations += e.iterations
        if previous is None:
            raise
        state.solves += 1
        problem.predict(None)  # retry from x_n
        try:
            solve = problem.solve(step, t1)
        except NewtonFailure as e:
            state.iterations += e.iterations
            raise
    state.iterations += solve.iterations
    H_new = problem.hamiltonian()
    if not np.isfinite(H_new):
        raise NewtonFailure(step, t1, float("nan"), solve.iterations, "non-finite energy")
    return solve.iterations, H_new, problem.supplied_work(), problem.dissipated_energy() if dissipates else 0.0


def run_adaptive(problem, t, t_end, n, one, record, state, control, h_min, H, previous, dissipates, bar, sums,
                 auto=False):
    """The adaptive loop of `run` (rodfem/analysis/stepping.py): step doubling from x_n, the two half steps
    kept when the error estimate is within the tolerance (`auto`: dt=auto, the first step shrinks freely)."""
    supplied, dissipated = sums
    norm = ErrorNorm(problem, control.rtol, control.atol, t_end if control.per_unit_step else None)
    outputs = sorted({float(x) for x in control.output_times if t_end > x} | {float(t_end)})
    while t < t_end:
        interrupts.check(problem.comm, n, t)
        target = next(x for x in outputs if x > t)
        proposed = state.h
        clipped = t + 1.1 * proposed >= target
        t_next = target if clipped else t + proposed
        t_mid = t + 0.5 * (t_next - t)
        h, h_a, h_b = t_next - t, t_mid - t, t_next - t_mid
        snap = problem.snapshot()
        try:
            one(h, t, t_next, previous, h / state.h_prev, n + 1)
            coarse = problem.state()
            its_a, H_a, w_a, d_a = one(h_a, t, t_mid, previous, h_a / state.h_prev, n + 1)
            row_a = {"t": t_mid, "H": H_a, "supplied": supplied + w_a,
                     **({"dissipated": dissipated + d_a} if dissipates else {}), "newton_its": its_a,
                     "balance_error": H_a - H + d_a - w_a, "h": h_a, "error_estimate": 0.0, **problem.observe()}
            middle = problem.accept()
            its_b, H_b, w_b, d_b = one(h_b, t_mid, t_next, middle, h_b / h_a, n + 2)
            err = norm(snap[0], problem.state(), coarse, h)
        except NewtonFailure as e:
            problem.restore(snap)
            state.rejected += 1
            state.after_reject = True
            state.h = FAILED * h
            if state.h < h_min:
                raise NewtonFailure(e.step, e.t, e.residual, e.iterations,
                                    f"{e.reason}; step {h:.3g} at the minimum dt_min = {h_min:.3g}") from None
            continue
        if err > 1.0:
            problem.restore(snap)
            state.rejected += 1
            state.after_reject = True
            state.h = shrunk(h, err, control.per_unit_step, FIRST_SHRINK if auto else SHRINK)
            if state.h < h_min:
                raise NewtonFailure(n + 1, t_next, float("nan"), 0, f"error estimate {err:.3g} times the tolerance "
                                    f"at step {h:.3g}: dt_min = {h_min:.3g} reached")
            continue
        row_a["error_estimate"] = err
        supplied += w_a + w_b
        dissipated += d_a + d_b
        row_b = {"t": t_next, "H": H_b, "supplied": supplied, **({"dissipated": dissipated} if dissipates else {}),
                 "newton_its": its_b, "balance_error": H_b - H_a + d_b - w_b, "h": h_b, "error_estimate": err,
                 **problem.observe()}
        step = next_step(h, err, state.after_reject, control.per_unit_step)
        state.h = max(step, proposed) if clipped and not state.after_reject else step
        state.after_reject = auto = False
        state.h_prev = h_b
        state.substeps += 2
        state.max_substep_balance = max(state.max_substep_balance, abs(row_a["balance_error"]),
                                        abs(row_b["balance_error"]))
        previous = problem.accept()
        problem.t = t = t_next
        n += 2
        record(row_a, n - 1)   # (no checkpoint between the two halves: its x is gone)
        record(row_b, n, (previous, H_b, supplied, dissipated))
        H = H_b
        if bar:
            bar.update(h)
