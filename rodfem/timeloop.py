"""The time loop: x_n -> x_{n+1} by Newton, with the discrete energy balance

    H(x_{n+1}) - H(x_n) = -h d_n + h y.u     (checked every step, recorded in the history)

h d_n >= 0 is the energy dissipated in the step (0 for a conservative model);
only a dissipating problem (`problem.dissipates`) has the column `dissipated`
(the sum of h d_n so far).
"""
import time
from dataclasses import dataclass, field

import numpy as np

from .newton import NewtonFailure


@dataclass
class Result:
    """History of a run: one dict per time level (t = 0 included)."""
    rows: list = field(default_factory=list)
    wall_time: float = 0.0
    steps: int = 0

    def column(self, name):
        return np.array([r[name] for r in self.rows])

    @property
    def max_balance_error(self):
        return max((abs(r["balance_error"]) for r in self.rows[1:]), default=0.0)


def steps_for(dt, t_end):
    """Number of steps n with n*dt = t_end (dt must divide t_end to 1e-9)."""
    n = int(round(t_end / dt))
    if n < 1 or abs(n * dt - t_end) > 1e-9 * max(t_end, 1.0):
        raise ValueError(f"dt must divide t_end into a whole number of steps (t_end/dt = {t_end / dt:.6g})")
    return n


def run(problem, dt, t_end, writer=None, progress=False, result=None):
    """Integrate `problem` from t = 0 to t_end with step dt.

    `writer` (optional) receives every row (`writer.record(row, problem)`);
    on Newton failure the history written so far stays on disk (and in
    `result`, if one was passed in) and the NewtonFailure propagates.
    """
    n_steps = steps_for(dt, t_end)
    problem.h.value = dt
    res = result if result is not None else Result()
    H = problem.hamiltonian()
    dissipates = getattr(problem, "dissipates", False)
    row = {"t": 0.0, "H": H, "supplied": 0.0, **({"dissipated": 0.0} if dissipates else {}),
           "newton_its": 0, "balance_error": 0.0, **problem.observe()}
    res.rows.append(row)
    if writer:
        writer.record(row, problem)
    bar = None
    if progress and problem.comm.rank == 0:
        from tqdm import tqdm
        bar = tqdm(total=n_steps, unit="step", dynamic_ncols=True)
    supplied = dissipated = 0.0
    previous = None  # x_{n-1}, for the Newton start x_{n+1}^0 = 2 x_n - x_{n-1}
    t0 = time.perf_counter()
    try:
        for n in range(n_steps):
            t = n * dt
            problem.set_time(t + 0.5 * dt)
            try:
                problem.predict(previous)
                solve = problem.solve(n + 1, t + dt)
            except NewtonFailure:
                if previous is None:
                    raise
                problem.predict(None)  # retry from x_n
                solve = problem.solve(n + 1, t + dt)
            H_new = problem.hamiltonian()
            work = problem.supplied_work()
            supplied += work
            lost = problem.dissipated_energy() if dissipates else 0.0
            dissipated += lost
            row = {"t": (n + 1) * dt, "H": H_new, "supplied": supplied,
                   **({"dissipated": dissipated} if dissipates else {}), "newton_its": solve.iterations,
                   "balance_error": H_new - H + lost - work, **problem.observe()}
            if not np.isfinite(H_new):
                raise NewtonFailure(n + 1, t + dt, float("nan"), solve.iterations, "non-finite energy")
            H = H_new
            previous = problem.accept()
            res.rows.append(row)
            res.steps = n + 1
            if writer:
                writer.record(row, problem)
            if bar:
                bar.update()
    finally:
        res.wall_time = time.perf_counter() - t0
        if bar:
            bar.close()
    return res
