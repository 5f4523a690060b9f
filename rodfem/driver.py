"""Run a scene end to end: parameters -> Problem -> time loop -> files on disk."""
import os

from mpi4py import MPI

from .newton import NewtonFailure
from .output import RunWriter, summarize
from .scene import ParameterError, Scene, load
from .timeloop import Result, run, steps_for


def run_scene(scene, overrides=None, out=None, progress=False, comm=MPI.COMM_WORLD, resume=None):
    """Run `scene` (a Scene or its name) with `overrides` (dict name -> value or text).

    Writes history.csv, summary.json, centreline/ and PNGs into `out` (if given).
    Returns (result, summary).  A Newton failure keeps everything written so far,
    records it in summary.json and re-raises.  ``checkpoint_every=N`` among the overrides
    writes out/checkpoint.npz every N steps; `resume` (a directory) continues from its
    checkpoint (rodfem/checkpoint.py).
    """
    from . import checkpoint
    overrides, saved = dict(overrides or {}), None
    if resume:
        saved = checkpoint.read(resume)
        checkpoint.check(saved[0], resume, None if scene is None else getattr(scene, "name", scene))
        scene = scene or saved[0]["scene"]
        overrides = {**checkpoint.resume_parameters(saved[0], resume, overrides), **overrides,
                     "checkpoint_every": overrides.get("checkpoint_every", saved[0]["checkpoint_every"])}
    every = checkpoint_every(overrides.pop("checkpoint_every", 0), out)
    if not isinstance(scene, Scene):
        scene = load(scene)
    p = scene.values(overrides)
    try:
        n_steps = steps_for(p["dt"], p["t_end"])
    except ValueError as e:
        from .scene import ParameterError
        raise ParameterError(f"parameter 'dt': {e}") from None
    problem = scene.build(p, comm)
    start = checkpoint.restore(problem, *saved) if saved else None
    if start and start.step == 0:   # a static equilibrium (rodfem static): a new run starting from it
        start = None
    if start and out:
        result = Result(rows=checkpoint.truncate_history(out, start.step) if comm.rank == 0 else [], steps=start.step)
        writer = checkpoint.writer_for(out, problem, n_steps, p.get("frames", 100), start.step, start.t)
    else:
        result = Result(steps=start.step if start else 0)
        writer = RunWriter(out, problem, n_steps, p.get("frames", 100)) if out else None
    saver = checkpoint.Saver(out, scene.name, p, problem, every, n_steps) if every and out else None
    try:
        run(problem, p["dt"], p["t_end"], writer=writer, progress=progress, result=result, start=start,
            after_step=saver)
    except NewtonFailure as fail:
        summary = summarize(scene.name, p, problem, result, status="newton-failure",
                            failure={"step": fail.step, "t": fail.t, "residual": fail.residual,
                                     "iterations": fail.iterations, "reason": fail.reason})
        if writer:
            writer.finish(summary, result)
        raise
    summary = summarize(scene.name, p, problem, result)
    if writer:
        writer.finish(summary, result)
    return result, summary


def checkpoint_every(value, out):
    """The checkpoint interval N (0: none) from --set checkpoint_every=N."""
    try:
        every = int(value)
        if every != float(value) or every < 0:
            raise ValueError
    except (TypeError, ValueError):
        raise ParameterError(f"parameter 'checkpoint_every' must be an integer >= 0 (got {value!r})") from None
    if every and not out:
        raise ParameterError("parameter 'checkpoint_every' needs an output directory (--out)")
    return every


def default_out(name):
    return os.path.join("results", name)
