"""How a run ends, and the agreement of an error across MPI ranks.

Exit codes of the command line (README, "Exit codes"):

* 0   completed;
* 2   bad input or environment (`InputError`: a parameter (`ParameterError`), a joint
      (`ConstraintError`), ``--out``, the JIT cache, a PETSc option, not enough memory);
* 3   numerical failure (`NewtonFailure`);
* 130 / 143  interrupted by SIGINT / SIGTERM (`Interrupted`: 128 + signal number).

Under MPI every rank must raise the same error at the same point, or the
ranks that did not fail wait for ever in their next collective operation:
`agreed` is the one place where a rank's local failure becomes everyone's.
"""
import os
import re
import signal
from contextlib import contextmanager


class InputError(ValueError):
    """Bad input or environment (exit code 2); the message is one line naming what is wrong and what is allowed."""

    exit_code = 2


class ParameterError(InputError):
    """Bad user input; the message is one line naming the parameter and what is allowed (exit code 2)."""


class ConstraintError(ParameterError):
    """A joint or body that cannot be built: bad input, one line naming it (exit code 2)."""


class NewtonFailure(RuntimeError):
    """Newton did not converge in a time step (exit code 3)."""

    exit_code = 3

    def __init__(self, step, t, residual, iterations, reason):
        self.step, self.t, self.residual, self.iterations, self.reason = step, t, residual, iterations, reason
        super().__init__(f"Newton failed at step {step} (t = {t:.6g}): residual {residual:.3e} "
                         f"after {iterations} iterations ({reason})")


class Interrupted(Exception):
    """The run was stopped by a signal between two time steps (exit code 128 + signal number).

    `where` replaces "after step n (t = ...)" in the message: "after load step 3 (load factor 0.3)",
    "before the eigenvalue solve", "while waiting for the JIT cache lock"."""

    def __init__(self, signum, step=0, t=0.0, where=None):
        self.signum, self.step, self.t, self.where = int(signum), step, t, where
        self.signal = signal.Signals(self.signum).name
        self.exit_code = 128 + self.signum
        super().__init__(f"interrupted by {self.signal} {where or f'after step {step} (t = {t:.6g})'}")


@contextmanager
def agreed(comm):
    """Run the block on every rank of `comm`; if it raises an InputError on any rank, raise one on every rank.

    The failing rank raises its own error, the others an InputError with the message of the first
    failing rank.  Collective: every rank must enter the block, and the block itself must contain no
    collective operation (a rank that failed early would leave the others waiting in it).
    """
    error = None
    try:
        yield
    except InputError as e:
        error = e
    wait_idle(comm)   # (rank 0 writes files meanwhile: the others wait without taking a core from it)
    messages = comm.allgather(None if error is None else str(error))
    if error is not None:
        raise error
    first = next((m for m in messages if m is not None), None)
    if first is not None:
        raise InputError(first)


def wait_idle(comm, interval=2e-4):
    """Wait until every rank of `comm` has come here, sleeping between looks (a non-blocking barrier
    tested every `interval` seconds; collective).  MPI's blocking calls wait by polling, which keeps a
    core busy: on a machine with as many cores as ranks (or fewer), a rank waiting while another
    writes a run's files takes the core that the writing rank or the machine's other work needs."""
    if comm.size == 1:
        return
    import time
    request = comm.Ibarrier()
    while not request.Test():
        time.sleep(interval)


def out_of_memory(error):
    """InputError for a MemoryError: the size asked for does not fit in this machine's memory."""
    return InputError(f"out of memory ({error or 'MemoryError'}): use fewer elements, or more ranks on more "
                      "machines")


def petsc_error(error, what):
    """InputError for an error PETSc raised (a refused option, a solver package it lacks, no memory):
    what failed, PETSc's last message line (the reason) and PETSC_OPTIONS."""
    lines = [ln.strip() for ln in str(error).splitlines() if ln.strip()]
    reason = re.sub(r"^\[\d+\]\s*", "", lines[-1]) if lines else str(error)
    options = f" (PETSC_OPTIONS={os.environ['PETSC_OPTIONS']!r})" if os.environ.get("PETSC_OPTIONS") else ""
    return InputError(f"{what}{options}: {reason}; rodfem's solver options have the prefix -rodfem_, "
                      f"e.g. -rodfem_snes_max_it 50")
