"""rodfem: port-Hamiltonian rods, beams, strings and multibody systems in FEniCSx.

The public API: `System` (bodies and joints; `Problem` builds one with a single body), `run`
(the time loop), `Simulator` (the step interface: a scene or a System stepped from Python),
`Load`/`Support` (ports), and the errors a run can end with.  The physics is in `rodfem.forms`
(e.g. ``from rodfem.forms.planar_beam import PlanarBeam``), the scenes in `rodfem.demos`.
"""
from rodfem.common.stdio import ensure_standard_streams

ensure_standard_streams()  # before anything (UFL, PETSc, MPI) touches a closed stdout

import logging

from rodfem._version import __version__
from rodfem.analysis.timeloop import Result, run
from rodfem.app.simulator import Simulator
from rodfem.core.integrators import RULES, Step
from rodfem.core.joints import GROUND, ground
from rodfem.core.ports import Load, Support, constant_in_time, ramp
from rodfem.core.problem import Problem
from rodfem.core.spaces import Field, StateSpace
from rodfem.core.system import System
from rodfem.errors import ConstraintError, InputError, Interrupted, NewtonFailure, ParameterError

__all__ = ["__version__", "GROUND", "RULES", "ConstraintError", "Field", "InputError", "Interrupted", "Load", "NewtonFailure",
           "ParameterError", "Problem", "Result", "Simulator", "StateSpace", "Step", "Support", "System", "constant_in_time",
           "ground", "ramp", "run"]

# UFL warns on every interpolation of a UFL expression ("Couldn't map 'f' to a float").
logging.getLogger("UFL").setLevel(logging.ERROR)
