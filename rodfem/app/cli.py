"""Command line: ``rodfem list | show SCENE | run SCENE [--set NAME=VALUE ...] --out DIR`` (and
static, linearize, modes, reduce, study).

Every way a run can end is one line on stderr and an exit code
(rodfem.errors): bad input or environment ``rodfem: error: ...`` naming the
parameter or path and what is allowed (2); a Newton failure with step, time
and residual (3), keeping what was written; SIGINT/SIGTERM finish the
current step, write the results and exit with 130/143
(rodfem.common.interrupts).  Under MPI only rank 0 prints, and the ranks agree on
an error before raising it; anything unforeseen aborts every rank
(MPI_Abort) rather than leave one waiting.
"""
import argparse
import os
import sys
import traceback

from mpi4py import MPI

from rodfem.app.scene import load, scenes
from rodfem.common import interrupts
from rodfem.errors import InputError, Interrupted, NewtonFailure, ParameterError, out_of_memory

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


def parse_sets(pairs, option="--set"):
    overrides = {}
    for pair in pairs or []:
        if "=" not in pair:
            raise ParameterError(f"{option} expects NAME=VALUE (got {pair!r})")
        name, value = pair.split("=", 1)
        overrides[name.strip()] = value.strip()
    return overrides


def whole(text):
    """An integer option (--load-steps, --count, --elements) read as the integer parameters are
    (rodfem/app/scene.py): 10.0 is 10; 10.5, inf and nan are refused."""
    try:
        value = float(text)
    except ValueError:
        value = None
    if value is None or not value.is_integer():
        raise argparse.ArgumentTypeError(f"must be an integer (got {text!r})")
    return int(value)


def check_directories(args):
    """Refuse an empty --out or --resume ('' would otherwise read as none given: the default
    directory, results/SCENE, cleared)."""
    for option in ("out", "resume"):
        value = getattr(args, option, None)
        if value is not None and not value.strip():
            raise ParameterError(f"--{option} must name a directory (got {value!r})")


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
    from rodfem.app.driver import default_out, run_scene
    if args.scene is None and not args.resume:
        raise ParameterError("run needs a SCENE (or --resume DIR)")
    out = args.out = args.out or args.resume or default_out(args.scene)
    result, summary = run_scene(args.scene, parse_sets(args.set), out=out, progress=not args.quiet,
                                resume=args.resume)
    balance = "H_n+1 - H_n + h d_n - h y.u" if result.rows and "dissipated" in result.rows[0] else "H_n+1 - H_n - h y.u"
    say(f"{summary['scene']}: {summary['steps']} steps in {summary['wall_time_s']:.2f} s "
        f"({summary['time_per_step_ms']:.3f} ms/step, {summary['newton_its_mean']:.2f} Newton its/step), "
        f"max |{balance}| = {summary['max_balance_error']:.2e} "
        f"({summary['max_balance_error_relative']:.1e} of max |H|)")
    control = summary.get("step_control", {})
    if control.get("adaptive") or control.get("rejected"):
        say(f"step control: {control['rejected']} steps rejected or failed"
            + (f", {control['split_steps']} steps done in sub-steps ({control['substeps']} sub-steps in all)"
               if not control["adaptive"] else ""))
    say(f"results in {out}/: history.csv, summary.json, centreline.pvd and surface.pvd (ParaView), "
        f"fields.json, animation.gif, shapes.png, energy.png")


def cmd_study(args):
    from rodfem.app.study import run_study
    args.out = args.out or os.path.join("results", f"study-{args.scene}")
    run_study(args.scene, parse_sets(args.set), out=args.out, dts=args.dt, elements=args.elements)


def cmd_static(args):
    """rodfem static SCENE: the equilibrium of the discrete model under the loads at t (default t_end)."""
    from rodfem.app.analyses import run_static
    out = args.out or os.path.join("results", args.scene + "-static")
    from rodfem.analysis.stability import verdict
    _, result, summary = run_static(args.scene, parse_sets(args.set), out=out, t=args.time,
                                    steps=args.load_steps, adaptive=not args.fixed_steps, stability=args.stability)
    err = (f", error {summary['error_relative']:.3e} of the scale against the exact solution"
           if summary.get("error_relative") is not None else "")
    say(f"{summary['scene']}: static equilibrium at t = {summary['t']:g} in {summary['load_steps']} load steps "
        f"({summary['load_steps_halved']} halved), {summary['newton_its']} Newton iterations, "
        f"{summary['wall_time_s']:.2f} s{err}")
    if summary.get("warning"):
        say(f"warning: {summary['warning']}")
    say(verdict(summary["stability"]))
    if summary.get("checkpoint"):
        say(f"results in {out}/: summary.json, loadsteps.csv, centreline.pvd, shapes.png, checkpoint.npz "
            f"(a dynamic run from this equilibrium: rodfem run --resume {out} --out NEWDIR)")
    else:   # (bodies placed whole on ranks: no checkpoint)
        say(f"results in {out}/: summary.json, loadsteps.csv, centreline.pvd, shapes.png")


def cmd_linearize(args):
    """rodfem linearize SCENE --out DIR: E, J, R, Q, B, C (.npz, .mat) about an equilibrium or the initial state."""
    from rodfem.app.analyses import run_linearize
    out = args.out or os.path.join("results", args.scene + "-linear")
    info = run_linearize(args.scene, parse_sets(args.set), out=out, about=args.about, t=args.time)
    c = info["checks"]
    say(f"{info['scene']}: linear model about the {args.about} state at t = {args.time:g}: "
        f"{info['n_states']} states, {info['n_inputs']} inputs; |A - (J - R) Q| = {c['ph_residual']:.1e} |A|, "
        f"|f0| = {info['drift_norm']:.1e}")
    say(f"results in {out}/: E.npz J.npz R.npz Q.npz B.npz C.npz A.npz Hess.npz (scipy.sparse.load_npz), "
        "linear.mat (MATLAB), states.csv (the ordering of the state), linear.json, summary.json")


def cmd_modes(args):
    """rodfem modes SCENE: natural frequencies and mode shapes of the linearized model."""
    from rodfem.app.analyses import run_modes
    out = args.out or os.path.join("results", args.scene + "-modes")
    omega, info = run_modes(args.scene, parse_sets(args.set), out=out, about=args.about, t=args.time,
                            count=args.count, solver=args.solver)
    rejected = info["eigensolver"].get("rejected", 0)
    fewer = (f" (of {args.count} asked; {rejected} rejected by the residual check)" if rejected else
             f" (of {args.count} asked: the model has no more)") if len(omega) < args.count else ""
    say(f"{info['scene']}: {len(omega)} modes{fewer} about the {args.about} state ({info['solver']} eigensolver, "
        f"{info['n_states']} states, residuals <= {max(info['residuals']):.1e})")
    if info["fallback"]:
        say(f"(the SLEPc result was not verified: {info['fallback']}; solved dense instead)")
    if info["eigensolver"].get("rejected_below_rad_s"):
        say(f"(an eigenvalue at {info['eigensolver']['rejected_below_rad_s']:.6g} rad/s, below the last mode, failed "
            "the residual check and is not listed)")
    say(f"{'mode':>4s} {'omega [rad/s]':>16s} {'f [Hz]':>14s} {'damping':>10s}")
    for k, w in enumerate(omega):
        say(f"{k + 1:4d} {w:16.8g} {w / (2 * 3.141592653589793):14.8g} {info['damping_ratio'][k]:10.3g}")
    say(f"results in {out}/: {', '.join(info['files'])}")


def cmd_reduce(args):
    """rodfem reduce SCENE --order r: structure-preserving reduced PH models (issue 29)."""
    from rodfem.app.reduction import run_reduce
    out = args.out or os.path.join("results", args.scene + "-reduced")
    if args.nonlinear:
        return cmd_reduce_nonlinear(args, out)
    if args.test:
        raise ParameterError("--test goes with --nonlinear (the test input of the nonlinear reduced model)")
    if args.hyper is not None or args.ecsw_tol is not None:
        raise ParameterError("--hyper and --ecsw-tol go with --nonlinear (hyper-reduction of the nonlinear reduced model)")
    info = run_reduce(args.scene, parse_sets(args.set), out=out, orders=args.order, about=args.about, t=args.time,
                      alpha=args.alpha)
    say(f"{info['scene']}: reduced PH models of the {info['n_states']}-state linear model about the {args.about} state "
        f"({info['n_inputs']} inputs; grid s = {info['alpha']:.3g} + i omega, omega in "
        f"[{info['grid']['omega_min']:.4g}, {info['grid']['omega_max']:.4g}] rad/s)")
    say(f"{'order':>5s} {'max |G-Gr|/max |G|':>19s} {'in band':>10s} {'at points':>10s} {'passive':>8s}  first frequencies "
        "[rad/s] (full)")
    for r, o in info["orders"].items():
        pairs = ", ".join(f"{a:.6g} ({b:.6g})" for a, b in zip(o["frequencies_rad_s"][:3], info["full_frequencies_rad_s"]))
        say(f"{r:>5s} {o['error']['max_relative']:19.2e} {o['error_in_band']['max_relative']:10.2e} "
            f"{o['interpolation_error']:10.1e} {str(o['checks']['passive']):>8s}  {pairs}")
    say(f"results in {out}/: r<order>/{{E,J,R,Q,B,C}}.npz, V.npy, reduced.mat; reduce.json, bode.png, summary.json")


def cmd_reduce_nonlinear(args, out):
    """rodfem reduce SCENE --nonlinear: the POD-Galerkin reduced model of the nonlinear scene (issue 29)."""
    from rodfem.analysis.ecsw import DEFAULT_TOL
    from rodfem.app.nonlinear_reduction import run_nonlinear_reduce
    if args.hyper == "none" and args.ecsw_tol is not None:
        raise ParameterError("--ecsw-tol goes with --hyper ecsw (the default), not with --hyper none")
    info = run_nonlinear_reduce(args.scene, parse_sets(args.set), test=parse_sets(args.test, "--test"), orders=args.order,
                                out=out, hyper=args.hyper or "ecsw",
                                ecsw_tol=DEFAULT_TOL if args.ecsw_tol is None else args.ecsw_tol)
    runs = info["runs"]
    say(f"{info['scene']}: nonlinear reduced models ({runs['train']['dofs']} dofs; full model "
        + ", ".join(f"{k} {v['full_ms_per_step']:.3g} ms/step" for k, v in runs.items()) + ")")
    say(f"{'r':>3s} {'unknowns':>8s} {'input':>6s} {'config. error':>13s} {'balance/H':>10s} {'ms/step':>8s} {'speed-up':>8s}"
        + (f" {'cells':>9s}" if info["hyper"] == "ecsw" else ""))
    for r, o in info["orders"].items():
        cells = f" {o['ecsw']['sampled']:4d}/{o['ecsw']['elements']:<4d}" if "ecsw" in o else ""
        for name in runs:
            e = o[name]
            say(f"{r:>3s} {o['reduced_unknowns']:8d} {name:>6s} {e['errors']['configuration']:13.2e} "
                f"{e['errors']['balance_relative']:10.1e} {e['ms_per_step']:8.3g} {e['speed_up']:8.2f}{cells}")
    say(f"results in {out}/nonlinear_reduce.json")


def parser():
    ap = argparse.ArgumentParser(prog="rodfem", description="Port-Hamiltonian rods, beams and strings in FEniCSx.")
    sub = ap.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the scenes").set_defaults(func=cmd_list)
    sp = sub.add_parser("show", help="parameters of a scene")
    sp.add_argument("scene")
    sp.set_defaults(func=cmd_show)
    rp = sub.add_parser("run", help="run a scene")
    rp.add_argument("scene", nargs="?")
    rp.add_argument("--resume", metavar="DIR", help="continue the run in DIR from its checkpoint "
                    "(written with --set checkpoint_every=N)")
    rp.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    rp.add_argument("--out", metavar="DIR", help="output directory (default results/SCENE)")
    rp.add_argument("--quiet", action="store_true", help="no progress bar")
    rp.set_defaults(func=cmd_run)
    st = sub.add_parser("study", help="error against run time over a sweep of dt and n_elements")
    st.add_argument("scene")
    st.add_argument("--set", action="append", metavar="NAME=VALUE")
    st.add_argument("--out", metavar="DIR")
    st.add_argument("--dt", type=float, nargs="+", help="time steps of the sweep")
    st.add_argument("--elements", type=whole, nargs="+", help="element counts of the sweep")
    st.set_defaults(func=cmd_study)
    add_static_parsers(sub)
    return ap


def add_static_parsers(sub):
    """Subcommands of statics, linearization and modes (issue 12)."""
    sp = sub.add_parser("static", help="static equilibrium of a scene (Newton with load continuation)")
    sp.add_argument("scene")
    sp.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    sp.add_argument("--out", metavar="DIR", help="output directory (default results/SCENE-static)")
    sp.add_argument("--time", type=float, metavar="T", help="the loads at time T (default t_end: the full load)")
    sp.add_argument("--load-steps", type=whole, default=1, metavar="N", help="first load step 1/N (default 1)")
    sp.add_argument("--fixed-steps", action="store_true", help="no growing of the load step (halving on failure stays)")
    sp.add_argument("--stability", default="auto", choices=("auto", "on", "off"),
                    help="whether the equilibrium is stable, from the eigenvalues of the linearized model "
                         "(auto: up to 600 dofs, about 1 s; on: up to 2000; default auto)")
    sp.set_defaults(func=cmd_static)
    for name, func, what in (("linearize", cmd_linearize, "linear PH model E, J, R, Q, B, C of a scene (.npz, .mat)"),
                             ("modes", cmd_modes, "natural frequencies and mode shapes of a scene")):
        lp = sub.add_parser(name, help=what)
        lp.add_argument("scene")
        lp.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
        default = f"results/SCENE-{'linear' if name == 'linearize' else 'modes'}"
        lp.add_argument("--out", metavar="DIR", help=f"output directory (default {default})")
        lp.add_argument("--about", default="static", choices=("static", "initial"),
                        help="linearize about the static equilibrium under the loads at --time (default) or the initial state")
        lp.add_argument("--time", type=float, default=0.0, metavar="T", help="the inputs at time T (default 0)")
        if name == "modes":
            lp.add_argument("--count", type=whole, default=6, metavar="K", help="number of modes (default 6)")
            lp.add_argument("--solver", default="auto", choices=("auto", "slepc", "dense"),
                            help="SLEPc (Krylov-Schur, verified; dense fallback up to 2000 states) or scipy's dense QZ "
                                 "(auto: dense up to 1500 states)")
        lp.set_defaults(func=func)
    add_reduce_parser(sub)


def add_reduce_parser(sub):
    """rodfem reduce (issue 29)."""
    rp = sub.add_parser("reduce", help="structure-preserving reduced PH models of a scene's linear model")
    rp.add_argument("scene")
    rp.add_argument("--order", type=whole, nargs="+", default=[8], metavar="R",
                    help="reduced orders (even; default 8); several: one model each, one Bode plot")
    rp.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    rp.add_argument("--out", metavar="DIR", help="output directory (default results/SCENE-reduced)")
    rp.add_argument("--about", default="static", choices=("static", "initial"),
                    help="linearize about the static equilibrium under the loads at --time (default) or the initial state")
    rp.add_argument("--time", type=float, default=0.0, metavar="T", help="the inputs at time T (default 0)")
    rp.add_argument("--alpha", type=float, default=0.05, metavar="A",
                    help="real part of the interpolation points, a fraction of the first natural frequency (default 0.05)")
    rp.add_argument("--nonlinear", action="store_true",
                    help="the nonlinear POD-Galerkin reduced model instead (--order: POD modes per block), trained on "
                         "the scene's run (docs/guide/nonlinear-reduction.md)")
    rp.add_argument("--test", action="append", metavar="NAME=VALUE",
                    help="with --nonlinear: a parameter of the test run (another input; repeatable)")
    rp.add_argument("--hyper", choices=("ecsw", "none"),
                    help="with --nonlinear: hyper-reduction, ECSW sampled and weighted cells (default) or none (full-order "
                         "assembly) (docs/guide/hyper-reduction.md)")
    rp.add_argument("--ecsw-tol", type=float, metavar="TOL",
                    help="with --hyper ecsw: relative residual of the weights' fit to the training contributions, in (0, 1) "
                         "(default 1e-3)")
    rp.set_defaults(func=cmd_reduce)


def main(argv=None):
    import signal
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # `rodfem list | head`: end quietly, not via PETSc's handler
    args = parser().parse_args(argv)
    try:
        with interrupts.deferred():
            check_directories(args)
            args.func(args)
    except InputError as e:
        return fail(f"rodfem: error: {e}{kept(args, e)}", e.exit_code)
    except NewtonFailure as e:
        return fail(f"rodfem: error: {e}{kept(args, e)}", 3)
    except Interrupted as e:
        return fail(f"rodfem: {e}{kept(args, e)}", e.exit_code)
    except MemoryError as e:
        return fail(f"rodfem: error: {out_of_memory(e)}", 2)
    except Exception:
        if comm.size > 1:  # a bug: abort every rank rather than leave the others waiting
            traceback.print_exc()
            sys.stderr.flush()
            comm.Abort(1)
        raise
    return 0


def kept(args, error):
    """'; results so far kept in DIR/' for a run or static solve that stopped (not for bad input), and
    for an error that says where its results are kept (`error.kept`: a study)."""
    out = getattr(error, "kept", None)
    if out is None and not isinstance(error, InputError) and args.command in ("run", "static"):
        out = getattr(args, "out", None)
    return f"; results so far kept in {out}/" if out else ""


def fail(message, code):
    """Report on one line (rank 0) and return the exit code."""
    say(" ".join(message.split()), file=sys.stderr)
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
