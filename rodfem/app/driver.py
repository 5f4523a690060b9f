"""Run a scene end to end: parameters -> Problem -> time loop -> files on disk."""
import os
import time
from contextlib import nullcontext, suppress

import numpy as np
from mpi4py import MPI

from rodfem.analysis.stepping import StepControl, StepState
from rodfem.analysis.timeloop import Result, run, steps_for
from rodfem.app.scene import Parameter, Scene, load
from rodfem.common import interrupts
from rodfem.errors import InputError, Interrupted, NewtonFailure, ParameterError, out_of_memory
from rodfem.io.output import OutDir, RunWriter, plotting, summarize, write_json

STOPS = (NewtonFailure, Interrupted, InputError)


def run_scene(scene, overrides=None, out=None, progress=False, comm=MPI.COMM_WORLD, resume=None):
    """Run `scene` (a Scene or its name) with `overrides` (dict name -> value or text).

    Writes history.csv, summary.json, centreline/ and PNGs into `out` (if given), a
    directory the run owns (rodfem.io.output.OutDir).  Returns (result, summary).  A Newton
    failure, an interrupt (`Interrupted`) or an output error keeps everything written so
    far, records it in summary.json and re-raises.  ``checkpoint_every=N`` among the
    overrides writes out/checkpoint.npz every N steps; `resume` (a directory) continues
    the run there from its checkpoint (rodfem/io/checkpoint.py).
    """
    from rodfem.io import checkpoint
    overrides, saved = dict(overrides or {}), None
    if resume:
        saved = checkpoint.read(resume)
        checkpoint.check(saved[0], resume, None if scene is None else getattr(scene, "name", scene))
        scene = scene or saved[0]["scene"]
        overrides = {**checkpoint.resume_parameters(saved[0], resume, overrides), **overrides,
                     "checkpoint_every": overrides.get("checkpoint_every", saved[0]["checkpoint_every"])}
    every = checkpoint_every(overrides.pop("checkpoint_every", 0), out)
    continues = bool(saved) and saved[0]["step"] > 0     # step 0: a static equilibrium, a new run from it
    if continues and out and os.path.realpath(out) != os.path.realpath(resume):
        raise ParameterError(f"--resume continues the run in {resume}: give no --out (or the same directory)")
    if not isinstance(scene, Scene):
        scene = load(scene)
    p = scene.values(overrides)
    control = step_control(p)
    try:
        n_steps = None if control.adaptive else steps_for(p["dt"], p["t_end"])
    except ValueError as e:
        raise ParameterError(f"parameter 'dt': {e}") from None
    if control.adaptive and p["dt"] != "auto" and p["dt"] > p["t_end"]:
        raise ParameterError(f"parameter 'dt': the first step {p['dt']:g} is longer than t_end = {p['t_end']:g}")
    if continues and (saved[0]["t"] > p["t_end"] if control.adaptive else saved[0]["step"] > n_steps):
        raise ParameterError(f"parameter 't_end': {p['t_end']:g} is before the checkpoint's time {saved[0]['t']:g} "
                             f"(--resume continues to a later t_end)")
    if out:
        plotting()   # the pictures can be drawn: known before the directory is touched
    outdir = OutDir(out, comm) if out else None
    started = {"scene": scene.name, "status": "running", "parameters": p, "mpi_ranks": comm.size,
               "pid": os.getpid(), "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    # a resumed run: everything checked before the directory is touched (its record stays if refused)
    problem, start, kept = resumed(scene, p, comm, saved, resume, bool(continues and outdir)) if saved else (None,) * 3
    with outdir.claimed(started, clear=not continues) if outdir else nullcontext():
        problem = problem or build(scene, p, comm, outdir, started)
        if start and outdir:
            rows = checkpoint.truncate_history(outdir, kept)
            result = Result(rows=rows, steps=start.step,   # (its step control's counts: those at the checkpoint)
                            stepping=dict(StepState.from_dict(start.stepping).to_dict(), adaptive=control.adaptive,
                                          dt_min=control.minimum(p["dt"], p["t_end"])))
            writer = checkpoint.writer_for(outdir, problem, n_steps, p.get("frames", 101), start.step, start.t,
                                           p.get("section", 0.0), control.output_times or None)
        else:
            result = Result(steps=start.step if start else 0)
            writer = (RunWriter(outdir, problem, n_steps, p.get("frames", 101), p.get("section", 0.0),
                                control.output_times or None) if outdir else None)
        try:
            saver = checkpoint.Saver(outdir, scene.name, p, problem, every, n_steps) if every and outdir else None
            if not (start and (start.t >= p["t_end"] if control.adaptive else start.step == n_steps)):
                # (a checkpoint at t_end: nothing left to run)
                run(problem, p["dt"], p["t_end"], writer=writer, progress=progress, result=result, start=start,
                    after_step=saver, control=control)
        except (*STOPS, MemoryError) as error:
            stop = out_of_memory(error) if isinstance(error, MemoryError) else error
            status, failure = stopped(stop)
            if writer:
                with suppress(InputError, MemoryError):  # after an output error, keep what can still be written
                    writer.finish(summarize(scene.name, p, problem, result, status, failure), result)
            if stop is error:
                raise
            raise stop from None
        summary = summarize(scene.name, p, problem, result)
        if writer:
            writer.finish(summary, result)
    return result, summary


def step_control(p):
    """The time loop's StepControl of the parameters `p` (adaptive: the frames' times are its output times)."""
    adaptive = p.get("adaptive", "false") == "true" or p.get("dt") == "auto"   # dt=auto: adaptive steps
    frames = p.get("frames", 101)
    times = tuple(np.linspace(0.0, p["t_end"], frames).tolist()) if frames > 1 else (p["t_end"],)
    return StepControl(adaptive=adaptive, rtol=p.get("rtol", 1e-3), atol=p.get("atol", 1e-6),
                       dt_min=p.get("dt_min", 0.0), output_times=times if adaptive else (),
                       per_unit_step=p.get("error_per", "step") == "unit-step")


CHECKPOINT_EVERY = Parameter("checkpoint_every", 0, "", "steps between checkpoints (0: none)", low=0)


def resumed(scene, p, comm, saved, directory, history):
    """(problem, start, history lines kept) of a run resumed from the checkpoint `saved` = (meta, arrays)
    in `directory`: the problem built and put in the checkpoint's state (start None for a new run
    from a static equilibrium, step 0), and, if `history`, the lines of history.csv up to the
    checkpoint (rodfem.io.checkpoint.history_lines).  Writes nothing: a refusal leaves the directory
    as it was."""
    from rodfem.io import checkpoint
    kept = checkpoint.history_lines(directory, saved[0], comm) if history else None
    problem = build(scene, p, comm)
    start = checkpoint.restore(problem, *saved)
    return problem, (start if saved[0]["step"] > 0 else None), kept


def checkpoint_every(value, out):
    """The checkpoint interval N (0: none) from --set checkpoint_every=N (an integer parameter like
    n_elements: 10.0 is 10, 10.5 is refused)."""
    every = CHECKPOINT_EVERY.value(value)
    if every and not out:
        raise ParameterError("parameter 'checkpoint_every' needs an output directory (--out)")
    return every


def build(scene, p, comm, outdir=None, started=None):
    """scene.build(p, comm), built (forms compiled, joints bound and checked); when it fails,
    summary.json says why (status "error" or "interrupted").

    A compilation killed by a Ctrl-C (the C compiler gets the signal too) counts as the interrupt.
    """
    try:
        return scene.build(p, comm).build()
    except Exception as error:
        stop = stop_of(error)
        if stop is None:
            raise
        record(outdir, started, stop)
        if stop is error:
            raise
        raise stop from None


def stop_of(error, where=None):
    """The exception that ends a run for `error`: the interrupt when a signal came (whatever the
    death of a compiler it killed looked like), one line for a MemoryError, the error itself if it
    is one of STOPS; None for anything else (a bug: let it through)."""
    if isinstance(error, Interrupted):
        return error
    if interrupts.received():
        return Interrupted(interrupts.received(), where=where)
    if isinstance(error, MemoryError):
        return out_of_memory(error)
    return error if isinstance(error, STOPS) else None


def record(outdir, started, stop, status=None):
    """summary.json of the run in `outdir` (if any): `started` with how `stop` ended it
    (status(stop) -> (status, failure); default `stopped`); a write that fails is let go."""
    if outdir:
        state, failure = (status or stopped)(stop)
        with suppress(InputError):
            outdir.do("write summary.json", write_json, outdir.file("summary.json"),
                      dict(started, status=state, failure=failure))


def stopped(stop):
    """(status, failure record) of summary.json for an exception that ended a run."""
    if isinstance(stop, NewtonFailure):
        return "newton-failure", {"step": stop.step, "t": stop.t, "residual": stop.residual,
                                  "iterations": stop.iterations, "reason": stop.reason}
    if isinstance(stop, Interrupted):
        return "interrupted", {"signal": stop.signal, "step": stop.step, "t": stop.t,
                               **({"where": stop.where} if stop.where else {})}
    return "error", {"message": str(stop)}


def default_out(name):
    return os.path.join("results", name)
