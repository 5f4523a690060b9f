"""rodfem: port-Hamiltonian rods, beams, strings and multibody systems in FEniCSx."""
from rodfem.common.stdio import ensure_standard_streams

ensure_standard_streams()  # before anything (UFL, PETSc, MPI) touches a closed stdout

import logging  # noqa: E402

from rodfem.errors import InputError, Interrupted  # noqa: F401,E402
from rodfem.core.integrators import RULES, Step  # noqa: F401,E402
from rodfem.core.joints import GROUND, ConstraintError, ground  # noqa: F401,E402
from rodfem.nls.newton import NewtonFailure  # noqa: F401
from rodfem.core.ports import Load, Support, constant_in_time, ramp  # noqa: F401
from rodfem.core.problem import Problem  # noqa: F401
from rodfem.core.spaces import Field, StateSpace  # noqa: F401
from rodfem.core.system import System  # noqa: F401
from rodfem.analysis.timeloop import Result, run  # noqa: F401

__version__ = "0.1.0"

# UFL warns on every interpolation of a UFL expression ("Couldn't map 'f' to a float").
logging.getLogger("UFL").setLevel(logging.ERROR)
