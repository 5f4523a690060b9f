"""What a run may ask for: a bounded number of (time or load) steps, a mesh that fits in memory and
at least one element per MPI rank.  Refused with one line giving the estimate.

Memory per element, measured (peak RSS of a run, LU factorisation included):
9.4 KB for the planar beam (9 dofs per element), 300 KB for the 3D rod (72);
a d + b d^2 with a = 600 B, b = 50 B fits both (the d^2 term is the LU fill of a
banded matrix of bandwidth ~ d).
"""
import numbers
import resource
from contextlib import contextmanager

from mpi4py import MPI

from rodfem.errors import InputError, ParameterError

MAX_STEPS = 10**7
BYTES_PER_DOF = 600.0           # a
BYTES_PER_DOF_SQUARED = 50.0    # b


def bytes_per_element(dofs_per_element):
    d = dofs_per_element
    return BYTES_PER_DOF * d + BYTES_PER_DOF_SQUARED * d * d


def _read_number(path, key=None):
    """A number from a /proc or /sys file (the value after `key:`, in kB, if given); None if absent."""
    try:
        with open(path) as f:
            if key is None:
                return int(f.read())  # "max" (no limit) raises ValueError
            info = dict(line.split(":", 1) for line in f)
            return int(info[key].split()[0]) * 1024
    except (OSError, KeyError, ValueError):
        return None


def available_memory(ranks_on_node=1):
    """Bytes this process may still allocate: its share of the node's MemAvailable (and cgroup limit)
    and what its address-space limit (ulimit -v) leaves."""
    node = [m for m in (_read_number("/proc/meminfo", "MemAvailable"), _read_number("/sys/fs/cgroup/memory.max"))
            if m is not None]
    limits = [m / ranks_on_node for m in node]
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY:
        limits.append(soft - (_read_number("/proc/self/status", "VmSize") or 0))
    return max(min(limits), 0.0) if limits else float("inf")


def check_elements(n_elements, dofs_per_element, comm):
    """n_elements as an int, or an InputError: not a whole number >= 1, fewer than the MPI ranks,
    or a mesh that does not fit in the memory available (the estimate in the message).  Collective."""
    if isinstance(n_elements, bool) or not isinstance(n_elements, numbers.Real) or n_elements != int(n_elements) \
            or n_elements < 1:
        raise InputError(f"n_elements must be a whole number >= 1 (got {n_elements!r})")
    n = int(n_elements)
    if n < comm.size:
        raise InputError(f"n_elements = {n} is fewer than the {comm.size} MPI ranks: every rank needs an element "
                         f"(use n_elements >= {comm.size} or fewer ranks)")
    per_element = bytes_per_element(dofs_per_element)
    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    have = comm.allreduce(available_memory(node.size), op=MPI.SUM)  # the same verdict on every rank
    node.Free()
    if n * per_element > have:
        raise InputError(f"n_elements = {n} needs about {n * per_element / 1e9:.3g} GB ({dofs_per_element} dofs, "
                         f"{per_element / 1e3:.3g} KB per element) but {have / 1e9:.3g} GB are available: "
                         f"at most about {int(have / per_element)} elements fit")
    if _checking["on"]:
        raise Checked(n)
    return n


class Checked(Exception):
    """Raised by check_elements inside `checking()` once a mesh has passed: the build stops there."""


_checking = {"on": False}


@contextmanager
def checking():
    """Inside the block a scene's build stops at its first mesh, once check_elements has passed it
    (`Checked`): its parameters checked without the cost of building (rodfem study checks every run of
    a sweep this way before running any)."""
    _checking["on"] = True
    try:
        yield
    finally:
        _checking["on"] = False


def shown(x, other):
    """x with as few digits as show that it is not `other` (at least 3): 10000001 against 1e7,
    10.000001 against 10, not 1e+07 and 10."""
    for digits in range(3, 18):
        text = f"{x:.{digits}g}"
        if float(text) != other:
            return text
    return repr(x)


def check_steps(n_steps):
    """Refuse more than MAX_STEPS time steps (the history is kept in memory, ~1 KB per step)."""
    if n_steps > MAX_STEPS:
        raise ValueError(f"t_end/dt = {shown(n_steps, MAX_STEPS)} steps, more than the limit of {MAX_STEPS:.0e} "
                         f"(~{n_steps * 1e3 / 1e9:.3g} GB of history; choose a larger dt or a smaller t_end)")


def check_load_steps(steps):
    """Refuse a first load step below 1/MAX_STEPS (--load-steps N: at most MAX_STEPS load steps)."""
    if steps > MAX_STEPS:
        raise ParameterError(f"--load-steps {shown(steps, MAX_STEPS)}: more than the limit of {MAX_STEPS:.0e} "
                             f"load steps (the first load step is 1/N; choose N in [1, {MAX_STEPS:.0e}])")
