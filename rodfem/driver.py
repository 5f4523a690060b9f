"""Run a scene end to end: parameters -> Problem -> time loop -> files on disk."""
import os

from mpi4py import MPI

from .newton import NewtonFailure
from .output import RunWriter, summarize
from .scene import Scene, load
from .timeloop import Result, run, steps_for


def run_scene(scene, overrides=None, out=None, progress=False, comm=MPI.COMM_WORLD):
    """Run `scene` (a Scene or its name) with `overrides` (dict name -> value or text).

    Writes history.csv, summary.json, centreline/ and PNGs into `out` (if given).
    Returns (result, summary).  A Newton failure keeps everything written so far,
    records it in summary.json and re-raises.
    """
    if not isinstance(scene, Scene):
        scene = load(scene)
    p = scene.values(overrides)
    try:
        n_steps = steps_for(p["dt"], p["t_end"])
    except ValueError as e:
        from .scene import ParameterError
        raise ParameterError(f"parameter 'dt': {e}") from None
    problem = scene.build(p, comm)
    writer = RunWriter(out, problem, n_steps, p.get("frames", 100)) if out else None
    result = Result()
    try:
        run(problem, p["dt"], p["t_end"], writer=writer, progress=progress, result=result)
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


def default_out(name):
    return os.path.join("results", name)
