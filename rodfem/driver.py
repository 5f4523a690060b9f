"""Run a scene end to end: parameters -> Problem -> time loop -> files on disk."""
import os
import time
from contextlib import nullcontext, suppress

from mpi4py import MPI

from . import interrupts
from .errors import InputError, Interrupted
from .newton import NewtonFailure
from .output import OutDir, RunWriter, summarize, write_json
from .scene import ParameterError, Scene, load
from .timeloop import Result, run, steps_for

STOPS = (NewtonFailure, Interrupted, InputError)


def run_scene(scene, overrides=None, out=None, progress=False, comm=MPI.COMM_WORLD):
    """Run `scene` (a Scene or its name) with `overrides` (dict name -> value or text).

    Writes history.csv, summary.json, centreline/ and PNGs into `out` (if given), a
    directory the run owns (rodfem.output.OutDir).  Returns (result, summary).  A Newton
    failure, an interrupt (`Interrupted`) or an output error keeps everything written so
    far, records it in summary.json and re-raises.
    """
    if not isinstance(scene, Scene):
        scene = load(scene)
    p = scene.values(overrides)
    try:
        n_steps = steps_for(p["dt"], p["t_end"])
    except ValueError as e:
        raise ParameterError(f"parameter 'dt': {e}") from None
    outdir = OutDir(out, comm) if out else None
    started = {"scene": scene.name, "status": "running", "parameters": p, "mpi_ranks": comm.size,
               "pid": os.getpid(), "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    with outdir.claimed(started) if outdir else nullcontext():
        problem = build(scene, p, comm, outdir, started)
        writer = (RunWriter(outdir, problem, n_steps, p.get("frames", 100), p.get("section", 0.0))
                  if outdir else None)
        result = Result()
        try:
            run(problem, p["dt"], p["t_end"], writer=writer, progress=progress, result=result)
        except STOPS as stop:
            status, failure = stopped(stop)
            if writer:
                with suppress(InputError):  # after an output error, keep what can still be written
                    writer.finish(summarize(scene.name, p, problem, result, status, failure), result)
            raise
        summary = summarize(scene.name, p, problem, result)
        if writer:
            writer.finish(summary, result)
    return result, summary


def build(scene, p, comm, outdir=None, started=None):
    """scene.build(p, comm); when it fails, summary.json says why (status "error" or "interrupted").

    A compilation killed by a Ctrl-C (the C compiler gets the signal too) counts as the interrupt.
    """
    try:
        return scene.build(p, comm)
    except Exception as error:
        if interrupts.received():  # whatever the compiler's death looked like
            stop = Interrupted(interrupts.received())
        elif isinstance(error, STOPS):
            stop = error
        else:
            raise
        if outdir:
            status, failure = stopped(stop)
            with suppress(InputError):
                outdir.do("write summary.json", write_json, outdir.file("summary.json"),
                          dict(started, status=status, failure=failure))
        if stop is error:
            raise
        raise stop from None


def stopped(stop):
    """(status, failure record) of summary.json for an exception that ended a run."""
    if isinstance(stop, NewtonFailure):
        return "newton-failure", {"step": stop.step, "t": stop.t, "residual": stop.residual,
                                  "iterations": stop.iterations, "reason": stop.reason}
    if isinstance(stop, Interrupted):
        return "interrupted", {"signal": stop.signal, "step": stop.step, "t": stop.t}
    return "error", {"message": str(stop)}


def default_out(name):
    return os.path.join("results", name)
