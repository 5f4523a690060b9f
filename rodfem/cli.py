"""Command line: ``rodfem list | show SCENE | run SCENE [--set NAME=VALUE ...] --out DIR``.

Every way a run can end is one line on stderr and an exit code
(rodfem.errors): bad input or environment ``rodfem: error: ...`` naming the
parameter or path and what is allowed (2); a Newton failure with step, time
and residual (3), keeping what was written; SIGINT/SIGTERM finish the
current step, write the results and exit with 130/143
(rodfem.interrupts).  Under MPI only rank 0 prints, and the ranks agree on
an error before raising it; anything unforeseen aborts every rank
(MPI_Abort) rather than leave one waiting.
"""
import argparse
import os
import sys
import traceback

from mpi4py import MPI

from . import interrupts
from .errors import InputError, Interrupted
from .newton import NewtonFailure
from .scene import ParameterError, load, scenes

comm = MPI.COMM_WORLD


def say(*args, file=None):
    """Print on rank 0.  A standard output that cannot be written (``> /dev/full``) is an InputError."""
    if comm.rank != 0:
        return
    stream = file or sys.stdout
    try:
        print(*args, file=stream, flush=True)
    except OSError as e:
        silence(stream)
        if stream is sys.stdout:
            raise InputError(f"cannot write to standard output ({e.strerror})") from None


def silence(stream):
    """Point a stream that failed at /dev/null, so that its unwritten rest does not fail again at exit."""
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, stream.fileno())
    os.close(null)


def parse_sets(pairs):
    overrides = {}
    for pair in pairs or []:
        if "=" not in pair:
            raise ParameterError(f"--set expects NAME=VALUE (got {pair!r})")
        name, value = pair.split("=", 1)
        overrides[name.strip()] = value.strip()
    return overrides


def cmd_list(args):
    for name, ep in scenes().items():
        say(f"{name:24s} {ep.load().description}")


def cmd_show(args):
    scene = load(args.scene)
    say(f"{scene.name}: {scene.description}")
    if scene.notes:
        say(scene.notes)
    say(f"\n{'parameter':14s} {'default':>12s}  {'unit':8s} allowed / meaning")
    for p in scene.parameters:
        say(f"{p.name:14s} {str(p.default):>12s}  {p.unit:8s} {p.allowed()}: {p.doc}")


def cmd_run(args):
    from .driver import default_out, run_scene
    out = args.out = args.out or default_out(args.scene)
    result, summary = run_scene(args.scene, parse_sets(args.set), out=out, progress=not args.quiet)
    balance = "H_n+1 - H_n + h d_n - h y.u" if result.rows and "dissipated" in result.rows[0] else "H_n+1 - H_n - h y.u"
    say(f"{summary['scene']}: {summary['steps']} steps in {summary['wall_time_s']:.2f} s "
        f"({summary['time_per_step_ms']:.3f} ms/step, {summary['newton_its_mean']:.2f} Newton its/step), "
        f"max |{balance}| = {summary['max_balance_error']:.2e} "
        f"({summary['max_balance_error_relative']:.1e} of max |H|)")
    say(f"results in {out}/: history.csv, summary.json, centreline.pvd and surface.pvd (ParaView), "
        f"fields.json, animation.gif, shapes.png, energy.png")


def cmd_study(args):
    from .study import run_study
    run_study(args.scene, parse_sets(args.set), out=args.out, dts=args.dt, elements=args.elements)


def parser():
    ap = argparse.ArgumentParser(prog="rodfem", description="Port-Hamiltonian rods, beams and strings in FEniCSx.")
    sub = ap.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the scenes").set_defaults(func=cmd_list)
    sp = sub.add_parser("show", help="parameters of a scene")
    sp.add_argument("scene")
    sp.set_defaults(func=cmd_show)
    rp = sub.add_parser("run", help="run a scene")
    rp.add_argument("scene")
    rp.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    rp.add_argument("--out", metavar="DIR", help="output directory (default results/SCENE)")
    rp.add_argument("--quiet", action="store_true", help="no progress bar")
    rp.set_defaults(func=cmd_run)
    st = sub.add_parser("study", help="error against run time over a sweep of dt and n_elements")
    st.add_argument("scene")
    st.add_argument("--set", action="append", metavar="NAME=VALUE")
    st.add_argument("--out", metavar="DIR")
    st.add_argument("--dt", type=float, nargs="+", help="time steps of the sweep")
    st.add_argument("--elements", type=int, nargs="+", help="element counts of the sweep")
    st.set_defaults(func=cmd_study)
    return ap


def main(argv=None):
    import signal
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # `rodfem list | head`: end quietly, not via PETSc's handler
    args = parser().parse_args(argv)
    import logging
    logging.disable(logging.INFO)  # the JIT compiler logs every C build step at INFO
    try:
        with interrupts.deferred():
            args.func(args)
    except InputError as e:
        return fail(f"rodfem: error: {e}", e.exit_code)
    except NewtonFailure as e:
        return fail(f"rodfem: error: {e}{kept(args)}", 3)
    except Interrupted as e:
        return fail(f"rodfem: {e}{kept(args)}", e.exit_code)
    except Exception:
        if comm.size > 1:  # a bug: abort every rank rather than leave the others waiting
            traceback.print_exc()
            sys.stderr.flush()
            comm.Abort(1)
        raise
    return 0


def kept(args):
    out = getattr(args, "out", None)
    return f"; results so far kept in {out}/" if out and args.command == "run" else ""


def fail(message, code):
    """Report on one line (rank 0) and return the exit code."""
    say(" ".join(message.split()), file=sys.stderr)
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
