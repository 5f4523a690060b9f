"""The analyses of a scene from the command line: `rodfem static`, `rodfem linearize` and
`rodfem modes` build the scene, run the algorithm of rodfem/analysis/ on it and own the output
directory, its files, pictures and summary (as rodfem/app/driver.py does for `rodfem run`).
"""
import numpy as np
from mpi4py import MPI

from rodfem.analysis.linearize import Linearization, mode_shapes, natural_modes, plot_modes
from rodfem.analysis.statics import StaticFailure, Statics
from rodfem.errors import ParameterError

# -- a scene's equilibrium, from the command line (rodfem static SCENE) -----------------------

def finite_time(t):
    """t as a float; --time nan or inf is refused (ParameterError, exit 2)."""
    t = float(t)
    if not np.isfinite(t):
        raise ParameterError(f"--time must be a finite number (got {t})")
    return t


def run_static(scene, overrides=None, out=None, t=None, steps=1, adaptive=True, comm=None):
    """The static equilibrium of `scene` under its inputs at time t (default: t_end, the full load).

    Writes into `out` (if given): summary.json (load steps, Newton iterations, the observables
    at equilibrium and, for scenes with an exact solution, the error against it), loadsteps.csv
    (mu, Newton iterations, residual per load step), centreline.pvd (the initial and the
    equilibrium shape), shapes.png, and checkpoint.npz: the equilibrium as the state at step 0,
    from which ``rodfem run --resume out`` starts a dynamic run (at rest, pre-stressed).
    Returns (problem, StaticResult, summary)."""
    import os
    import time
    from contextlib import nullcontext

    from mpi4py import MPI

    from rodfem._version import __version__
    from rodfem.app.scene import Scene, load
    from rodfem.io import checkpoint
    from rodfem.io.output import OutDir, RunWriter, plot_shapes, write_json

    comm = comm or MPI.COMM_WORLD
    if not isinstance(scene, Scene):
        scene = load(scene)
    p = scene.values(overrides)
    t = p["t_end"] if t is None else finite_time(t)
    if steps < 1:
        raise ParameterError(f"--load-steps must be an integer >= 1 (got {steps})")
    outdir = OutDir(out, comm) if out else None
    started = {"scene": scene.name, "mode": "static", "status": "running", "parameters": p, "t": t,
               "mpi_ranks": comm.size, "pid": os.getpid()}
    with outdir.claimed(started) if outdir else nullcontext():
        problem = scene.build(p, comm)
        writer = RunWriter(outdir, problem, 1, 2, p.get("section", 0.0)) if outdir else None
        if writer:
            writer.frame(0.0)
        t0 = time.perf_counter()
        statics = Statics(problem)
        try:
            result = statics.solve(t, steps, adaptive)
        except StaticFailure as fail:
            if outdir:
                outdir.do("write summary.json", write_json, outdir.file("summary.json"),
                          dict(started, status="static-failure", failure=str(fail)))
            raise
        wall = time.perf_counter() - t0
        obs = problem.observe()
        summary = {"scene": scene.name, "mode": "static", "status": "completed", "rodfem_version": __version__,
                   "parameters": p, "t": t, "load_steps": len(result.steps), "load_steps_halved": result.failed,
                   "initial_load_steps": steps, "adaptive": adaptive, "newton_its": result.newton_its,
                   "wall_time_s": wall, "dofs": problem.dofs, "n_elements": problem.n_elements,
                   "mpi_ranks": comm.size, "equilibrium": obs}
        ref = scene.reference(p) if scene.reference and t == p["t_end"] else None
        if ref:
            scale = ref.get("scale", 1.0)
            errs = {k: abs(obs[k] - v) for k, v in ref.items() if k != "scale" and k in obs}
            summary["reference"] = ref
            summary["error"] = max(errs.values()) if errs else None
            summary["error_relative"] = summary["error"] / scale if errs else None
        if outdir:   # the equilibrium as a checkpoint at step 0: `rodfem run --resume out` starts from it
            checkpoint.save(outdir, problem, checkpoint.Layout(problem), 0, None, problem.hamiltonian(), 0.0,
                            {"scene": scene.name, "parameters": p, "checkpoint_every": 0, "static_time": t})
            writer.frame(1.0)

            def write_loadsteps(path):
                with open(path, "w") as f:
                    f.write("mu,newton_its,residual\n")
                    for s in result.steps:
                        f.write(f"{s.mu!r},{s.iterations},{s.residual!r}\n")
            outdir.do("write loadsteps.csv", write_loadsteps, outdir.file("loadsteps.csv"))
            outdir.do("write summary.json", write_json, outdir.file("summary.json"), summary)
            outdir.do("write shapes.png", plot_shapes, outdir.file("shapes.png"), writer.snapshots,
                      writer.dim, writer.width)
    return problem, result, summary


# -- a scene's linear model and modes (rodfem linearize / rodfem modes) -------------------------

ABOUT = ("static", "initial")


def prepare(scene, overrides=None, about="static", t=0.0, comm=None, load_steps=1):
    """Build `scene` and put it in the state to linearize about: its static equilibrium under the
    inputs at time t ('static', the default) or its initial state with the inputs at t
    ('initial'; not an equilibrium in general: then f0 != 0).  Returns (scene, p, Linearization)."""
    from rodfem.analysis.statics import Statics
    from rodfem.app.scene import Scene, load
    comm = comm or MPI.COMM_WORLD
    if about not in ABOUT:
        raise ParameterError(f"--about must be one of {', '.join(ABOUT)} (got {about!r})")
    t = finite_time(t)
    if comm.size > 1:
        raise ParameterError("linearize and modes run on one process (no mpirun)")
    if not isinstance(scene, Scene):
        scene = load(scene)
    p = scene.values(overrides)
    problem = scene.build(p, comm)
    system = problem.named_bodies
    ref = None
    if about == "static":
        statics = Statics(problem)
        statics.solve(t, load_steps)
        ref = statics.refs if system else statics.refs[""]
    else:
        for load in problem.loads:
            load.update(t)
    return scene, p, Linearization(problem, reference=ref)


def run_linearize(scene, overrides=None, out=None, about="static", t=0.0):
    """`rodfem linearize`: the matrices into `out`; returns the linear.json content."""
    import time
    t0 = time.perf_counter()
    t = finite_time(t)        # (prepare checks it too; this is the t linear.json records)
    scene, p, lin = prepare(scene, overrides, about, t)
    from rodfem._version import __version__
    extra = {"scene": scene.name, "rodfem_version": __version__, "parameters": p, "about": about, "t": t,
             "wall_time_s": time.perf_counter() - t0, "form": "E dx' = (J - R) Q dx + B du, dy = B^T Q dx "
             "(= C dx); A = (J - R) Q; Hess: Hessian of H; E_modes, A_modes: the total-form pencil of modes"}
    return lin.write(out, extra) if out else extra


def run_modes(scene, overrides=None, out=None, about="static", t=0.0, count=6, solver="auto"):
    """`rodfem modes`: natural frequencies and mode shapes; returns (omega, info).

    Only verified modes (rodfem/la/pencil.py) are printed and written; a model without any
    oscillating mode is refused (ParameterError) and nothing is written.  info["files"] names the
    files written: modes.csv and modes.json, and, when a flexible body moves, modes.png and
    mode_shapes.npz."""
    import time
    if count < 1:
        raise ParameterError(f"--count must be an integer >= 1 (got {count})")
    t0 = time.perf_counter()
    scene, p, lin = prepare(scene, overrides, about, t)
    omega, vectors, used = natural_modes(lin, count, solver)
    found = lin.modes_info
    if not len(omega):
        raise ParameterError(f"{scene.name} has no oscillating mode about the {about} state ({_none_why(found)}); "
                             "nothing written")
    info = {"scene": scene.name, "about": about, "t": t, "solver": used, "n_states": lin.Em.shape[0],
            "omega_rad_s": [float(w) for w in omega], "f_Hz": [float(w / (2 * np.pi)) for w in omega],
            "damping_ratio": [float(z) for z in lin.damping], "count": count,
            "residuals": found["residuals"], "fallback": found["fallback"],
            "eigensolver": {k: v for k, v in found.items() if k not in ("residuals", "fallback", "solver")},
            "parameters": p, "wall_time_s": time.perf_counter() - t0, "files": []}
    if out:
        info["files"] = write_modes(out, lin, omega, vectors, info)
    return omega, info


def _none_why(found):
    """Why no mode was found, from natural_modes' lin.modes_info."""
    if "finite_eigenvalues" not in found:
        return "no verified oscillation"
    parts = [f"{found['real_eigenvalues']} real"]
    parts += [f"{found['growing_oscillations']} growing oscillations"] if found["growing_oscillations"] else []
    parts += [f"{found['rejected']} failing the residual check"] if found["rejected"] else []
    return f"its linear model has {found['finite_eigenvalues']} finite eigenvalues: {', '.join(parts)}"


def write_modes(out, lin, omega, vectors, info):
    """modes.csv, modes.json and, if a flexible body moves, modes.png and mode_shapes.npz; their names."""
    import json
    import os
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "modes.csv"), "w") as fh:
        fh.write("mode,omega_rad_s,f_Hz,period_s,damping_ratio,residual\n")
        for k, w in enumerate(omega):
            fh.write(f"{k + 1},{w!r},{w / (2 * np.pi)!r},{2 * np.pi / w!r},{lin.damping[k]!r},{info['residuals'][k]!r}\n")
    files = ["modes.csv", "modes.json"]
    bodies, shapes = mode_shapes(lin, vectors)
    if bodies:
        plot_modes(os.path.join(out, "modes.png"), bodies, shapes[: min(len(shapes), 4)], omega)
        arrays = {"omega": omega, "damping_ratio": lin.damping}
        for b, (name, s, ref) in enumerate(bodies):
            key = name or "body"
            arrays[f"{key}.s"], arrays[f"{key}.reference"] = s, ref
            arrays[f"{key}.shapes"] = np.array([mode[b] for mode in shapes])
        np.savez(os.path.join(out, "mode_shapes.npz"), **arrays)
        files += ["modes.png", "mode_shapes.npz"]
    with open(os.path.join(out, "modes.json"), "w") as fh:
        json.dump(dict(info, files=files), fh, indent=2, default=float)
    return files
