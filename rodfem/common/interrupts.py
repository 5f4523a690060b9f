"""SIGINT and SIGTERM during a run: finish the current step, then stop cleanly.

Inside ``with deferred():`` (the command line wraps every command in it) a
first SIGINT or SIGTERM only records the signal; the time loop calls
`check` between steps (the static solve between load steps, `rodfem modes`
before its eigenvalue solve), which raises `Interrupted` on every rank as soon as
any rank has seen a signal (under ``mpirun``, which turns a Ctrl-C into a
SIGTERM to every rank, the ranks may see it at different steps).  The run
then writes summary.json (status "interrupted") and its plots and exits with
128 + the signal number.  A second signal ends the process at once (the
default action).  Signals ignored when the process started (``nohup``, a
background job of a script) stay ignored.
"""
import signal
from contextlib import contextmanager

from mpi4py import MPI

from rodfem.errors import Interrupted

SIGNALS = (signal.SIGINT, signal.SIGTERM)
_state = {"active": False, "signum": 0}


def _record(signum, frame):
    if _state["signum"]:  # the second one: the default action, now
        signal.signal(signum, signal.SIG_DFL)
        signal.raise_signal(signum)
    _state["signum"] = signum


@contextmanager
def deferred():
    """Defer SIGINT/SIGTERM to the next `check` for the duration of the block (main thread only)."""
    previous = {s: signal.getsignal(s) for s in SIGNALS}
    for s, handler in previous.items():
        if handler is not signal.SIG_IGN:
            signal.signal(s, _record)
    _state.update(active=True, signum=0)
    try:
        yield
    finally:
        _state.update(active=False, signum=0)
        for s, handler in previous.items():
            signal.signal(s, handler)


def received():
    """The signal this rank has received inside `deferred` (0: none)."""
    return _state["signum"]


def check(comm, step, t, where=None):
    """Between steps: raise Interrupted on every rank if any rank has received a signal.

    Collective inside `deferred` (every rank calls it at the same step); free outside.
    `where` (optional) says where the run stopped if not "after step n (t = ...)" (rodfem.errors.Interrupted).
    """
    if not _state["active"]:
        return
    signum = comm.allreduce(_state["signum"], op=MPI.MAX)
    if signum:
        raise Interrupted(signum, step, t, where)
