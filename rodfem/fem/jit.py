"""The JIT cache (forms compiled to C and shared libraries on disk): safe to interrupt, errors in one line.

ffcx claims a module by creating NAME.c (``open(..., "x")``) and marks it done
with NAME.c.cached; a process that finds NAME.c without NAME.c.cached takes it
for a compilation in progress, waits 10 s and fails.  A compilation killed
midway thus left NAME.c behind and broke every later run of that form.

rodfem compiles under a lock: inside `locked(comm)` (a Problem being built,
forms being compiled), rank 0 of `comm` takes an exclusive ``fcntl.flock`` on
CACHE/rodfem-jit.lock as soon as a module it needs is not in the cache
(ffcx's lookup of a module is hooked, rodfem.fem.compat.hook_jit_lookup), and
holds it to the end of the block; the other ranks only load what rank 0
compiled.  A run whose modules are all compiled never takes the lock, so it
is not held up by another run compiling (or stopped, or stuck).  A NAME.c
without NAME.c.cached found while holding the lock was left by a compilation
that died, and is removed, so ffcx compiles it afresh (so is a NAME.c.cached
whose NAME.c is gone).  The lock also makes a second run wait for a first one
compiling the same forms instead of timing out.  A form compiled outside such a
block (a demo or a test calling dolfinx.fem.form itself) is compiled under the
lock too: ffcx's JIT entry points are wrapped in `locked(COMM_SELF)`
(rodfem.fem.compat.hook_jit_compilers).  (A program that does not import rodfem
compiling into the same cache at the same moment is not covered: give it its
own XDG_CACHE_HOME.)

Waiting for the lock says so on stderr, naming the holder (its pid, written
into the lock file, and whether it is stopped), stops on SIGINT/SIGTERM
inside `rodfem.common.interrupts.deferred` (`Interrupted`), and gives up after
RODFEM_JIT_LOCK_TIMEOUT seconds (default 600) with an InputError (exit 2).

Errors of the cache itself (a directory that cannot be created or written, a
damaged module) become one InputError naming the directory and the remedy.
"""
import errno
import fcntl
import functools
import inspect
import logging
import os
import sys
import time
from contextlib import contextmanager

from mpi4py import MPI

from rodfem.common import interrupts
from rodfem.errors import InputError, Interrupted, agreed
from rodfem.fem import compat

LOCK_NAME = "rodfem-jit.lock"
TIMEOUT_VARIABLE = "RODFEM_JIT_LOCK_TIMEOUT"
DEFAULT_TIMEOUT = 600.0   # seconds
POLL = 0.1                # seconds between two tries of the lock
_held = {"depth": 0, "root": False, "fd": None, "error": None}


def stale_sources(cache_dir):
    """NAME.c files without their NAME.c.cached (left by a compilation that did not finish), and
    NAME.c.cached markers without NAME.c (left when a NAME.c was removed: ffcx would fail to
    create the marker again after compiling)."""
    with os.scandir(cache_dir) as entries:
        names = {e.name for e in entries}
    sources = [n for n in names if n.endswith(".c") and n + ".cached" not in names]
    markers = [n for n in names if n.endswith(".c.cached") and n[: -len(".cached")] not in names]
    return [os.path.join(cache_dir, n) for n in sources + markers]


FULL = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)   # a full disk, a quota, a file size limit


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
    if isinstance(e, OSError) and e.errno in FULL:   # the compiler's files do not fit (cffi names no file)
        return InputError(f"the JIT cache {cache_dir} cannot be written ({e.strerror}): free some space there "
                          f"or set XDG_CACHE_HOME to a directory with room (the cache is $XDG_CACHE_HOME/fenics)")
    if not _about_cache(e, cache_dir):
        return None
    if isinstance(e, OSError) and not isinstance(e, TimeoutError):
        return _unusable(cache_dir, e)
    return _damaged(cache_dir, e)


def _acquire(cache_dir):
    """Open and lock CACHE/rodfem-jit.lock (waiting for a run compiling); remove stale sources."""
    path = os.path.join(cache_dir, LOCK_NAME)
    try:
        os.makedirs(cache_dir, exist_ok=True)
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as e:
        raise _unusable(cache_dir, e) from None
    try:
        _wait_for(fd, path)
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        for stale in stale_sources(cache_dir):
            os.unlink(stale)
    except OSError as e:
        os.close(fd)
        raise _unusable(cache_dir, e) from None
    except BaseException:
        os.close(fd)
        raise
    return fd


def lock_timeout():
    """Seconds to wait for the cache lock: $RODFEM_JIT_LOCK_TIMEOUT, default DEFAULT_TIMEOUT."""
    text = os.environ.get(TIMEOUT_VARIABLE, "").strip()
    if not text:
        return DEFAULT_TIMEOUT
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value >= 0:
        raise InputError(f"{TIMEOUT_VARIABLE} must be a number of seconds >= 0 (got {text!r})")
    return value


def _wait_for(fd, path):
    """Take the lock on `fd`; while another process holds it, say so once, stop on a signal, give up
    after lock_timeout() seconds."""
    timeout, t0, told = lock_timeout(), time.monotonic(), False
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return
        except BlockingIOError:
            pass
        holder, hint = _holder(fd)
        if not told:
            _tell(f"rodfem: waiting for the JIT cache lock {path}, held by {holder} (compiling forms); giving up "
                  f"after {timeout:g} s ({TIMEOUT_VARIABLE}=SECONDS to change){hint}")
            told = True
        if interrupts.received():
            raise Interrupted(interrupts.received(), where="while waiting for the JIT cache lock")
        if time.monotonic() - t0 >= timeout:
            raise InputError(f"the JIT cache lock {path} is still held by {holder} after {timeout:g} s"
                             f"{hint or ': end that process or let it finish'}, or set {TIMEOUT_VARIABLE}=SECONDS "
                             f"to wait longer")
        time.sleep(POLL)


def _holder(fd):
    """('pid N' of the process holding the lock, from the lock file; a hint if it is stopped)."""
    try:
        pid = int(os.pread(fd, 32, 0).decode().strip())
    except (OSError, ValueError):
        return "another process", ""
    try:
        with open(f"/proc/{pid}/stat") as f:
            state = f.read().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        state = ""
    stopped = state in ("T", "t")
    return f"pid {pid}", (f"; it is stopped (Ctrl-Z?): resume it with kill -CONT {pid}, or end it" if stopped else "")


def _tell(line):
    try:
        print(line, file=sys.stderr, flush=True)
    except OSError:
        pass


def _ready(module_name, cache_dir):
    """Whether ffcx will load `module_name` from the cache rather than compile it (or wait for it)."""
    source = os.path.join(cache_dir, module_name + ".c")
    return os.path.exists(source) and os.path.exists(source + ".cached")


def _before_lookup(module_name, cache_dir):
    """ffcx is about to look up `module_name` in `cache_dir`: inside `locked`, rank 0 takes the lock
    first if the module is not compiled yet."""
    if _held["depth"] and not _ready(module_name, cache_dir):
        hold(cache_dir)


def hold(cache_dir=None):
    """Take the cache lock now (inside `locked`, on the rank that compiles; held to the end of the
    block): before compiling into the cache.  An error is kept for `locked` to agree on."""
    if not (_held["depth"] and _held["root"]) or _held["fd"] is not None:
        return
    try:
        _held["fd"] = _acquire(cache_dir or compat.jit_cache_dir())
    except (InputError, Interrupted) as e:
        _held["error"] = e
        raise


HOOKED = compat.hook_jit_lookup(_before_lookup)


@contextmanager
def locked(comm):
    """The block may compile into the JIT cache: rank 0 of `comm` takes the cache lock when a module
    is not compiled yet (at once if ffcx's lookup could not be hooked) and keeps it to the end;
    cache errors in the block become InputErrors.

    Collective.  Re-entrant (a Problem built while another is being built in the same process).
    """
    cache_dir = compat.jit_cache_dir()
    outer = _held["depth"] == 0
    if outer:
        _held.update(root=comm.rank == 0, fd=None, error=None)
    _held["depth"] += 1
    quiet = logging.root.manager.disable
    logging.disable(max(quiet, logging.INFO))  # the C build (setuptools) logs every compiler call at INFO
    try:
        if outer and not HOOKED:
            with agreed(comm):
                hold(cache_dir)
        yield
    except (ImportError, OSError, RuntimeError) as e:
        error = _converted(e, cache_dir)
        if comm.size > 1 and "just-in-time" in str(e):  # DOLFINx's report of rank 0's failure, on every rank
            _agree(comm, error)
        if error is None:
            raise
        raise error from None
    finally:
        logging.disable(quiet)
        _held["depth"] -= 1
        if outer and _held["fd"] is not None:
            os.close(_held["fd"])  # releases the lock
            _held["fd"] = None


def _under_lock(entry):
    """ffcx's JIT entry point `entry`, run inside `locked(COMM_SELF)`: a compilation outside a
    rodfem block (which would race another process holding the lock) takes the lock too."""
    @functools.wraps(entry)
    def compile_locked(*args, **kwargs):
        with locked(MPI.COMM_SELF):
            return entry(*args, **kwargs)
    return compile_locked


COMPILERS = compat.hook_jit_compilers(_under_lock)


def _agree(comm, error):
    """Raise on every rank what stopped rank 0's compilation (collective): the interrupt or InputError
    met taking the lock (`hold`), else the cache error `error` of any rank."""
    own = _held["error"]
    met = comm.allgather(None if own is None else (getattr(own, "signum", 0), str(own)))
    first = next((m for m in met if m is not None), None)
    if first is None:
        with agreed(comm):
            if error is not None:
                raise error from None
        return
    signum, message = first
    if signum:
        raise Interrupted(signum, where="while waiting for the JIT cache lock") from None
    raise (own or InputError(message)) from None


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
        compiled = {k: compat.form(f) if f is not None else None for k, f in forms.items()}
    for k, f in forms.items():   # the constants in the kernels' order (rodfem/fem/batch.py reads them)
        if f is not None:
            compiled[k].rodfem_constants = list(f.constants())
    return compiled
