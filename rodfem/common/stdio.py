"""Standard streams that were closed when rodfem started (``rodfem run ... >&-``)."""
import os
import sys


def ensure_standard_streams():
    """Open /dev/null on a closed stdin, stdout or stderr.

    Otherwise the next file opened would get descriptor 1 or 2 and receive what
    is meant for the terminal (PETSc and MPI write to them directly), and UFL
    fails at import on ``sys.stdout = None``.
    """
    for fd, name, mode in ((0, "stdin", "r"), (1, "stdout", "w"), (2, "stderr", "w")):
        try:
            os.fstat(fd)
        except OSError:
            null = os.open(os.devnull, os.O_RDWR)  # the lowest free descriptor: fd, unless a lower one is closed
            if null != fd:
                os.dup2(null, fd)
                os.close(null)
        if getattr(sys, name) is None:
            setattr(sys, name, open(fd, mode, closefd=False))
