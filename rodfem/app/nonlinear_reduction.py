"""`rodfem reduce SCENE --nonlinear --order r [r ...] --test NAME=VALUE ...`: the nonlinear reduced model
(rodfem/analysis/galerkin.py) of a scene, trained on one run and checked on it and on another input.

The training run is the scene with its parameters (its own u(t)); its states at every step are the
snapshots.  The test run is the scene with the `test` parameters on top (e.g. another load amplitude:
the same mesh, another input).  For each order r (POD modes per block) the reduced model runs both
inputs from the same initial state; reported per run: the errors against the full model

    configuration   max_n |q_r(t_n) - q(t_n)| / max_n |q(t_n) - q(t_0)|   (all configuration dofs)
    <column>        max_n |c_r - c| / max_n |c - c(t_0)|  for the position columns (tip_*, mean_*)

the largest energy-balance residual relative to max |H|, and the wall times (full and reduced loop, the
reduced model's time split into assembly, projection and solve) and the speed-up full / reduced.

`hyper` = "ecsw" (the default): the reduced model is hyper-reduced (rodfem/analysis/ecsw.py): per order, the
sample of cells and their weights are trained on the training run's states (`ecsw_tol`: the relative residual
of the fit; `ecsw_snapshots` states), written to the JSON (`ecsw`: cells, weights, fit residual), and the
reduced model assembles on them only; the energy balance is that of the weighted Hamiltonian H_w.  "none": the
reduced model assembles at full order.  `compare`: with ECSW, also the model without hyper-reduction (the
JSON's `galerkin` entries).  With ECSW the errors also hold `energy_weighted_vs_full`: max |H_w - H| / max |H| at
the reduced states (H at full order, after the run).
"""
import json
import os
import time

import numpy as np
from mpi4py import MPI

from rodfem.analysis.ecsw import DEFAULT_SNAPSHOTS, DEFAULT_TOL, HyperReducedSystem, check_parameters, train
from rodfem.analysis.galerkin import ReducedSystem, layout, pod_basis
from rodfem.analysis.timeloop import run
from rodfem.app.analyses import resolve
from rodfem.errors import ParameterError


def full_run(problem, dt, t_end):
    """The full model's run: (history, states as columns, the first x_0)."""
    states = [problem.snapshot()[0]]
    res = run(problem, dt, t_end, after_step=lambda *a, **k: states.append(problem.state()))
    return res, np.array(states).T


def reduced_run(problem, basis, dt, t_end, x0, sample=None):
    """The reduced model's run from the full state x0 (the problem's clock restarted at 0), hyper-reduced with the
    ECSW `sample` if given: (history, full states x_ref + V xi (formed after the run), model)."""
    rom = (HyperReducedSystem(problem, basis, sample, start=x0) if sample is not None
           else ReducedSystem(problem, basis, start=x0))
    coords = [rom.xi0.copy()]
    res = run(rom, dt, t_end, after_step=lambda *a, **k: coords.append(rom.xi1.copy()))
    return res, basis.x_ref[:, None] + basis.V @ np.array(coords).T, rom


def errors(full, full_states, red, red_states, lay):
    """The errors of the module docstring and the reduced run's largest relative balance residual."""
    q = lay.q
    dq = np.linalg.norm(full_states[q] - full_states[q][:, :1], axis=0).max()
    out = {"configuration": float(np.linalg.norm(red_states[q] - full_states[q], axis=0).max() / max(dq, 1e-300))}
    for c in full.rows[0]:
        if c.startswith(("tip_", "mean_")):
            a, b = full.column(c), red.column(c)
            out[c] = float(np.abs(b - a).max() / max(np.abs(a - a[0]).max(), 1e-300))
    H = max(np.abs(red.column("H")).max(), 1e-300)
    out["balance_relative"] = float(red.max_balance_error / H)
    out["H_max"] = float(H)
    return out


def energy_error(problem, red, states):
    """max_n |H_w(xi_n) - H(x_ref + V xi_n)| / max |H|: how far the weighted Hamiltonian of the hyper-reduced run is
    from the full model's H at the same states (evaluated after the run, at full order)."""
    H = []
    for k in range(states.shape[1]):
        problem.restore((states[:, k], []))
        H.append(problem.hamiltonian())
    Hw = red.column("H")
    return float(np.abs(Hw - np.array(H)).max() / max(np.abs(H).max(), 1e-300))


def run_nonlinear_reduce(scene, overrides=None, test=None, orders=(4, 8, 16), out=None, comm=MPI.COMM_WORLD,
                         hyper="ecsw", ecsw_tol=DEFAULT_TOL, ecsw_snapshots=DEFAULT_SNAPSHOTS, compare=False):
    """Train, reduce and check (see the module docstring); returns the content of nonlinear_reduce.json."""
    from rodfem.app.driver import build
    orders = sorted({int(r) for r in orders})
    if not orders or orders[0] < 1:
        raise ParameterError(f"--order must be integers >= 1 (POD modes per block; got {orders})")
    if hyper not in ("ecsw", "none"):
        raise ParameterError(f"--hyper must be ecsw or none (got {hyper!r})")
    if hyper == "ecsw":
        check_parameters(ecsw_tol, ecsw_snapshots)
    if comm.size > 1:
        raise ParameterError("the nonlinear reduced model runs serially (run it without mpirun)")
    scene, p = resolve(scene, overrides)
    cases = {"train": p}
    if test:
        _, cases["test"] = resolve(scene, {**(overrides or {}), **test})
    info = {"scene": scene.name, "hyper": hyper, "parameters": p,
            "test_parameters": {k: cases["test"][k] for k in test} if test else {}, "orders": {}, "runs": {}}
    data = {}
    for name, q in cases.items():
        problem = build(scene, q, comm)
        lay = layout(problem)
        res, X = full_run(problem, q["dt"], q["t_end"])
        data[name] = (problem, res, X, q)
        info["runs"][name] = {"steps": res.steps, "full_wall_time_s": res.wall_time,
                              "full_ms_per_step": 1e3 * res.wall_time / res.steps, "dofs": int(X.shape[0]),
                              "full_balance_relative": float(res.max_balance_error / max(np.abs(res.column("H")).max(), 1e-300))}
    X_train = data["train"][2]
    for r in orders:
        basis = pod_basis(X_train, r, lay, problem=data["train"][0])
        entry = {"modes_per_block": basis.ranks, "reduced_unknowns": basis.order}
        sample = None
        if hyper == "ecsw":
            sample = train(data["train"][0], basis, X_train, ecsw_tol, ecsw_snapshots)
            entry["ecsw"] = sample.to_dict()
        models = [("", sample)] + ([("galerkin", None)] if compare and sample is not None else [])
        for name, (problem, res, X, q) in data.items():
            for key, smp in models:
                t0 = time.perf_counter()
                red, S, rom = reduced_run(problem, basis, q["dt"], q["t_end"], X[:, 0], smp)
                wall = time.perf_counter() - t0
                found = {"errors": errors(res, X, red, S, lay), "wall_time_s": red.wall_time,
                         "ms_per_step": 1e3 * red.wall_time / red.steps, "speed_up": res.wall_time / red.wall_time,
                         "newton_iterations_per_step": rom.iterations / red.steps,
                         "jacobians_per_step": getattr(rom, "jacobians", rom.iterations) / red.steps,
                         "time_split_s": dict(rom.timings), "set_up_s": wall - red.wall_time}
                if smp is not None:
                    found["errors"]["energy_weighted_vs_full"] = energy_error(problem, red, S)
                (entry.setdefault(key, {}) if key else entry)[name] = found
        info["orders"][str(r)] = entry
    if out:
        os.makedirs(out, exist_ok=True)
        with open(os.path.join(out, "nonlinear_reduce.json"), "w") as fh:
            json.dump(info, fh, indent=2, default=float)
    return info
