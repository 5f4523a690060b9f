"""rodfem: port-Hamiltonian rods, beams, strings and multibody systems in FEniCSx."""
from .stdio import ensure_standard_streams

ensure_standard_streams()  # before anything (UFL, PETSc, MPI) touches a closed stdout

import logging  # noqa: E402

from .errors import InputError, Interrupted  # noqa: F401,E402
from .integrators import RULES, Step  # noqa: F401,E402
from .interconnection import GROUND, ConstraintError, ground  # noqa: F401,E402
from .newton import NewtonFailure  # noqa: F401
from .ports import Load, Support, constant_in_time, ramp  # noqa: F401
from .problem import Problem  # noqa: F401
from .spaces import Field, StateSpace  # noqa: F401
from .system import System  # noqa: F401
from .timeloop import Result, run  # noqa: F401

__version__ = "0.1.0"

# UFL warns on every interpolation of a UFL expression ("Couldn't map 'f' to a float").
logging.getLogger("UFL").setLevel(logging.ERROR)
