"""The JIT cache (forms compiled to C and shared libraries on disk): safe to interrupt, errors in one line.

ffcx claims a module by creating NAME.c (``open(..., "x")``) and marks it done
with NAME.c.cached; a process that finds NAME.c without NAME.c.cached takes it
for a compilation in progress, waits 10 s and fails.  A compilation killed
midway thus left NAME.c behind and broke every later run of that form.

rodfem compiles under a lock: rank 0 of a Problem's communicator holds an
exclusive ``fcntl.flock`` on CACHE/rodfem-jit.lock while the Problem is built
(the other ranks only load what rank 0 compiled).  A NAME.c without
NAME.c.cached found while holding the lock was therefore left by a compilation
that died, and is removed, so ffcx compiles it afresh (so is a NAME.c.cached
whose NAME.c is gone).  The lock also makes a
second run wait for a first one compiling the same forms instead of timing out.
(A program other than rodfem compiling into the same cache at the same moment
is not covered: give it its own XDG_CACHE_HOME.)

Errors of the cache itself (a directory that cannot be created or written, a
damaged module) become one InputError naming the directory and the remedy.
"""
import fcntl
import functools
import inspect
import os
from contextlib import contextmanager

from rodfem.errors import InputError, agreed
from rodfem.fem import compat

LOCK_NAME = "rodfem-jit.lock"
_held = {"depth": 0}


def stale_sources(cache_dir):
    """NAME.c files without their NAME.c.cached (left by a compilation that did not finish), and
    NAME.c.cached markers without NAME.c (left when a NAME.c was removed: ffcx would fail to
    create the marker again after compiling)."""
    with os.scandir(cache_dir) as entries:
        names = {e.name for e in entries}
    sources = [n for n in names if n.endswith(".c") and n + ".cached" not in names]
    markers = [n for n in names if n.endswith(".c.cached") and n[: -len(".cached")] not in names]
    return [os.path.join(cache_dir, n) for n in sources + markers]


def _unusable(cache_dir, e):
    return InputError(f"the JIT cache {cache_dir} cannot be used ({e.strerror or e}: {e.filename or cache_dir}); "
                      f"set XDG_CACHE_HOME to a writable directory (the cache is $XDG_CACHE_HOME/fenics)")


def _damaged(cache_dir, e):
    return InputError(f"the JIT cache {cache_dir} is damaged ({' '.join(str(e).split())}); "
                      f"clear it with: rm -rf {cache_dir}  (or set XDG_CACHE_HOME to another directory)")


def _about_cache(e, cache_dir):
    """Whether an error of the JIT names a file of the cache (or a JIT module it could not load)."""
    where = " ".join(str(x) for x in (e, getattr(e, "filename", ""), getattr(e, "path", "")))
    return str(cache_dir) in where or "JIT module" in where


def _converted(e, cache_dir):
    """The InputError for an error of the cache (None for any other error)."""
    if not _about_cache(e, cache_dir):
        return None
    if isinstance(e, OSError) and not isinstance(e, TimeoutError):
        return _unusable(cache_dir, e)
    return _damaged(cache_dir, e)


def _acquire(cache_dir):
    """Open and lock CACHE/rodfem-jit.lock (waits for another run compiling); remove stale sources."""
    try:
        os.makedirs(cache_dir, exist_ok=True)
        fd = os.open(os.path.join(cache_dir, LOCK_NAME), os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as e:
        raise _unusable(cache_dir, e) from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        for path in stale_sources(cache_dir):
            os.unlink(path)
    except OSError as e:
        os.close(fd)
        raise _unusable(cache_dir, e) from None
    return fd


@contextmanager
def locked(comm):
    """Hold the cache lock (rank 0 of `comm`) for the block; cache errors in the block become InputErrors.

    Collective.  Re-entrant (a Problem built while another is being built in the same process).
    """
    cache_dir = compat.jit_cache_dir()
    fd = None
    with agreed(comm):
        if comm.rank == 0 and _held["depth"] == 0:
            fd = _acquire(cache_dir)
    _held["depth"] += 1
    try:
        yield
    except (ImportError, OSError, RuntimeError) as e:
        error = _converted(e, cache_dir)
        if comm.size > 1 and "just-in-time" in str(e):  # DOLFINx's report of rank 0's failure, on every rank
            with agreed(comm):
                if error is not None:
                    raise error from None
        if error is None:
            raise
        raise error from None
    finally:
        _held["depth"] -= 1
        if fd is not None:
            os.close(fd)  # releases the lock


def compiles(init):
    """Decorator for a constructor that compiles forms (Problem.__init__): runs it under `locked(comm)`,
    with `comm` its argument of that name."""
    signature = inspect.signature(init)

    @functools.wraps(init)
    def wrapper(*args, **kwargs):
        bound = signature.bind(*args, **kwargs)
        bound.apply_defaults()
        with locked(bound.arguments["comm"]):
            return init(*args, **kwargs)
    return wrapper


def compile_forms(forms):
    """Compile a dict of UFL forms (None stays None) under the cache lock.

    Every form is built before any is compiled: UFL's signatures (the JIT
    cache keys) depend on global counters that a compilation advances, so
    compiling F before J is even built would give J a different key in a cold
    and a warm process (a second run would recompile).
    """
    for f in forms.values():
        if f is not None:
            f.signature()  # computed (and kept by UFL) before any compilation
    comm = compat.form_comm(next(f for f in forms.values() if f is not None))
    with locked(comm):
        return {k: compat.form(f) if f is not None else None for k, f in forms.items()}
