"""The analyses of a scene from the command line: `rodfem static`, `rodfem linearize` and
`rodfem modes` build the scene, run the algorithm of rodfem/analysis/ on it and own the output
directory, its files, pictures and summary (as rodfem/app/driver.py does for `rodfem run`).

Each writes summary.json at the start (status "running") and replaces it at the end: "completed",
or how it stopped: "static-failure", "interrupted" (SIGINT/SIGTERM: between two load steps, or
before the eigenvalue solve), "error".  Input is checked before the directory is touched.
"""
import os
import time
from contextlib import contextmanager, nullcontext

import numpy as np
from mpi4py import MPI

from rodfem.analysis.linearize import Linearization, mode_shapes, natural_modes, plot_modes
from rodfem.analysis.stability import check_mode, stability_of
from rodfem.analysis.statics import StaticFailure, Statics
from rodfem.app.driver import build, record, stop_of, stopped
from rodfem.common import interrupts
from rodfem.common.limits import check_load_steps
from rodfem.errors import ParameterError
from rodfem.io.output import OutDir, write_json


def resolve(scene, overrides):
    """(Scene, its parameter values) of a scene or its name and the --set overrides."""
    from rodfem.app.scene import Scene, load
    if not isinstance(scene, Scene):
        scene = load(scene)
    return scene, scene.values(overrides)


@contextmanager
def owned(out, started, comm, subdir=None):
    """The block's OutDir (None without `out`; with `subdir` made in it): locked, its summary.json
    `started` (status "running").

    An exception of a stopped analysis is recorded in summary.json and re-raised; any exception
    after a signal (a compiler killed by a Ctrl-C) is the interrupt.
    """
    outdir = OutDir(out, comm, subdir) if out else None
    with outdir.claimed(started) if outdir else nullcontext():
        try:
            yield outdir
        except Exception as error:
            stop = stop_of(error, where="while building the scene")
            if stop is None:
                raise
            record(outdir, started, stop, analysis_status)
            if stop is error:
                raise
            raise stop from None


def analysis_status(stop):
    """(status, failure) of summary.json: a static failure by name, else as for a run."""
    return ("static-failure", str(stop)) if isinstance(stop, StaticFailure) else stopped(stop)


def heading(scene, p, mode, comm, **extra):
    """summary.json at the start of an analysis."""
    return {"scene": scene.name, "mode": mode, "status": "running", "parameters": p, **extra,
            "mpi_ranks": comm.size, "pid": os.getpid(), "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")}


# -- a scene's equilibrium, from the command line (rodfem static SCENE) -----------------------

INACCURATE = 0.05   # a static result further than this from its scene's exact solution is flagged


def finite_time(t):
    """t as a float; --time nan or inf is refused (ParameterError, exit 2)."""
    t = float(t)
    if not np.isfinite(t):
        raise ParameterError(f"--time must be a finite number (got {t})")
    return t


def run_static(scene, overrides=None, out=None, t=None, steps=1, adaptive=True, comm=None, stability="auto"):
    """The static equilibrium of `scene` under its inputs at time t (default: t_end, the full load).

    Writes into `out` (if given): summary.json (load steps, Newton iterations, the observables
    at equilibrium and, for scenes with an exact solution, the error against it), loadsteps.csv
    (mu, Newton iterations, residual per load step, a row as each is accepted), centreline.pvd
    (the initial and the equilibrium shape), shapes.png, and checkpoint.npz: the equilibrium as
    the state at step 0, from which ``rodfem run --resume out`` starts a dynamic run (at rest,
    pre-stressed).  A signal stops it between two load steps (summary.json: "interrupted").
    summary["stability"]: whether the equilibrium is stable, from the eigenvalues of the linearized
    model (rodfem/analysis/stability.py; `stability` auto, on or off).
    Returns (problem, StaticResult, summary)."""
    from rodfem._version import __version__
    from rodfem.io import checkpoint
    from rodfem.io.output import RunWriter, plot_shapes

    comm = comm or MPI.COMM_WORLD
    scene, p = resolve(scene, overrides)
    t = p["t_end"] if t is None else finite_time(t)
    if steps < 1:
        raise ParameterError(f"--load-steps must be an integer >= 1 (got {steps})")
    check_load_steps(steps)
    check_mode(stability)
    started = heading(scene, p, "static", comm, t=t)
    with owned(out, started, comm, subdir="centreline") as outdir:
        problem = build(scene, p, comm)
        writer = RunWriter(outdir, problem, 1, 2, p.get("section", 0.0)) if outdir else None
        if writer:
            writer.frame(0.0)
        t0 = time.perf_counter()
        statics = Statics(problem)
        rows = LoadStepsFile(outdir)
        result = statics.solve(t, steps, adaptive, on_step=rows.append)
        wall = time.perf_counter() - t0
        obs = problem.observe()
        summary = {"scene": scene.name, "mode": "static", "status": "completed", "rodfem_version": __version__,
                   "parameters": p, "t": t, "load_steps": len(result.steps), "load_steps_halved": result.failed,
                   "initial_load_steps": steps, "adaptive": adaptive, "newton_its": result.newton_its,
                   "wall_time_s": wall, "dofs": problem.dofs, "n_elements": problem.n_elements,
                   "mpi_ranks": comm.size, "equilibrium": obs}
        ref = scene.reference(p) if scene.reference and scene.reference_is_static and t == p["t_end"] else None
        if ref:
            scale = ref.get("scale", 1.0)
            errs = {k: abs(obs[k] - v) for k, v in ref.items() if k != "scale" and k in obs}
            summary["reference"] = ref
            summary["error"] = max(errs.values()) if errs else None
            summary["error_relative"] = summary["error"] / scale if errs else None
            if errs and summary["error_relative"] > INACCURATE:
                summary["warning"] = (f"the equilibrium is {summary['error_relative']:.3g} of the scale away from the "
                                      f"scene's exact solution (more than {INACCURATE:g}): the mesh "
                                      f"(n_elements = {problem.n_elements}) does not resolve it; refine it")
        # the equilibrium as a checkpoint at step 0: `rodfem run --resume out` starts from it (not for bodies
        # placed whole on ranks: their checkpoints are not written yet, rodfem/io/checkpoint.py)
        summary["checkpoint"] = bool(outdir) and not getattr(problem, "distributed", False)
        if summary["checkpoint"]:
            checkpoint.save(outdir, problem, checkpoint.Layout(problem), 0, None, problem.hamiltonian(), 0.0,
                            {"scene": scene.name, "parameters": p, "checkpoint_every": 0, "static_time": t})
        if outdir:
            writer.frame(1.0)
            rows.close()
        t1 = time.perf_counter()
        summary["stability"] = dict(stability_of(problem, statics, t, stability), wall_time_s=time.perf_counter() - t1)
        if outdir:
            outdir.do("write summary.json", write_json, outdir.file("summary.json"), summary)
            outdir.do("write shapes.png", plot_shapes, outdir.file("shapes.png"), writer.snapshots,
                      writer.dim, writer.width, 16, "load factor (0: initial, 1: equilibrium)")
    return problem, result, summary


class LoadStepsFile:
    """loadsteps.csv of a static solve (mu, newton_its, residual): a row written as each load step
    is accepted, so a solve that stops keeps its rows; nothing without an OutDir.  Collective."""

    def __init__(self, outdir):
        self.outdir, self._file = outdir, None

    def append(self, step):
        if self.outdir:
            self.outdir.do("write loadsteps.csv", self._write, f"{step.mu!r},{step.iterations},{step.residual!r}\n")

    def close(self):
        if self.outdir:
            self.outdir.do("write loadsteps.csv", self._write, None)

    def _write(self, line):
        if self._file is None:
            self._file = open(self.outdir.file("loadsteps.csv"), "w")
            self._file.write("mu,newton_its,residual\n")
        if line is None:
            self._file.close()
            return
        self._file.write(line)
        self._file.flush()


# -- a scene's linear model and modes (rodfem linearize / rodfem modes) -------------------------

ABOUT = ("static", "initial")


def prepare(scene, overrides=None, about="static", t=0.0, comm=None, load_steps=1):
    """Build `scene` and put it in the state to linearize about: its static equilibrium under the
    inputs at time t ('static', the default) or its initial state with the inputs at t
    ('initial'; not an equilibrium in general: then f0 != 0).  Returns (scene, p, Linearization)."""
    comm = comm or MPI.COMM_WORLD
    t = finite_time(t)
    check_linearizable(about, comm)
    scene, p = resolve(scene, overrides)
    return scene, p, linearization(scene, p, about, t, comm, load_steps)


def check_linearizable(about, comm):
    if about not in ABOUT:
        raise ParameterError(f"--about must be one of {', '.join(ABOUT)} (got {about!r})")
    if comm.size > 1:
        raise ParameterError("linearize and modes run on one process (no mpirun)")


def linearization(scene, p, about, t, comm, load_steps=1):
    """The Linearization of the scene with values p about its static or initial state (see `prepare`);
    a signal stops it between two load steps or once the matrices are assembled."""
    problem = build(scene, p, comm)
    system = problem.named_bodies
    ref = None
    if about == "static":
        statics = Statics(problem)
        statics.solve(t, load_steps)
        ref = statics.refs if system else statics.refs[""]
    else:
        for load in problem.loads:
            load.update(t)
    lin = Linearization(problem, reference=ref, t=t)
    interrupts.check(comm, 0, t, "after the linearization")
    return lin


def run_linearize(scene, overrides=None, out=None, about="static", t=0.0):
    """`rodfem linearize`: the matrices into `out` (and summary.json); returns the linear.json content."""
    from rodfem._version import __version__
    comm = MPI.COMM_WORLD
    t = finite_time(t)
    check_linearizable(about, comm)
    scene, p = resolve(scene, overrides)
    t0 = time.perf_counter()
    started = heading(scene, p, "linearize", comm, about=about, t=t)
    with owned(out, started, comm) as outdir:
        lin = linearization(scene, p, about, t, comm)
        extra = {"scene": scene.name, "rodfem_version": __version__, "parameters": p, "about": about, "t": t,
                 "wall_time_s": time.perf_counter() - t0, "form": "E dx' = (J - R) Q dx + B du, dy = B^T Q dx "
                 "(= C dx); A = (J - R) Q; Hess: Hessian of H; E_modes, A_modes: the total-form pencil of modes"}
        if not outdir:
            return extra
        info = {}
        outdir.do("write the matrices", lambda: info.update(lin.write(out, extra)))
        outdir.do("write summary.json", write_json, outdir.file("summary.json"),
                  dict(started, status="completed", n_states=info["n_states"], n_inputs=info["n_inputs"],
                       wall_time_s=time.perf_counter() - t0))
    return info


def run_modes(scene, overrides=None, out=None, about="static", t=0.0, count=6, solver="auto"):
    """`rodfem modes`: natural frequencies and mode shapes (and summary.json) into `out`; returns
    (omega, info).  Only verified modes (rodfem/la/pencil.py) are printed and written; a model
    without any oscillating mode is refused (ParameterError, no modes written).  info["files"] names
    the files written: modes.csv, modes.json, summary.json and, when a flexible body moves,
    modes.png and mode_shapes.npz.  A signal stops it before the eigenvalue solve."""
    comm = MPI.COMM_WORLD
    t = finite_time(t)
    if count < 1:
        raise ParameterError(f"--count must be an integer >= 1 (got {count})")
    check_linearizable(about, comm)
    scene, p = resolve(scene, overrides)
    t0 = time.perf_counter()
    started = heading(scene, p, "modes", comm, about=about, t=t, count=count)
    with owned(out, started, comm) as outdir:
        lin = linearization(scene, p, about, t, comm)
        interrupts.check(comm, 0, t, "before the eigenvalue solve")
        omega, vectors, used = natural_modes(lin, count, solver)
        found = lin.modes_info
        if not len(omega):
            raise ParameterError(f"{scene.name} has no oscillating mode about the {about} state "
                                 f"({_none_why(found)}); no modes written")
        info = {"scene": scene.name, "about": about, "t": t, "solver": used, "n_states": lin.Em.shape[0],
                "omega_rad_s": [float(w) for w in omega], "f_Hz": [float(w / (2 * np.pi)) for w in omega],
                "damping_ratio": [float(z) for z in lin.damping], "count": count,
                "residuals": found["residuals"], "fallback": found["fallback"],
                "eigensolver": {k: v for k, v in found.items() if k not in ("residuals", "fallback", "solver")},
                "parameters": p, "wall_time_s": time.perf_counter() - t0, "files": []}
        if outdir:
            files = []
            outdir.do("write the modes", lambda: files.extend(write_modes(out, lin, omega, vectors, info)))
            info["files"] = files + ["summary.json"]
            outdir.do("write summary.json", write_json, outdir.file("summary.json"),
                      dict(started, status="completed", solver=used, n_states=info["n_states"],
                           omega_rad_s=info["omega_rad_s"], wall_time_s=time.perf_counter() - t0))
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
