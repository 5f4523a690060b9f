"""Inputs of the Python API (rodfem/core/ports.py, rodfem/core/spaces.py, rodfem/core/system.py):
each mistake a user can make is an InputError naming the load, field or body and what is allowed
(never a KeyError, a numpy broadcast error or a DOLFINx IndexError), at the moment it is made."""
import numpy as np
import pytest
from mpi4py import MPI

from rodfem import InputError, Load, Problem, System, run
from rodfem.core.joints import ground
from rodfem.errors import ConstraintError
from rodfem.forms import joints
from rodfem.forms.planar_beam import PlanarBeam, quadratic

BEAM = PlanarBeam(1.0, 1.0, quadratic(EA=100.0, GA=100.0, EI=1.0))


def beam(**kw):
    return Problem(BEAM, 1.0, 4, comm=MPI.COMM_WORLD, **kw)


def test_a_load_on_an_unknown_field_names_the_fields():
    with pytest.raises(InputError, match=r"load nosuchfield@right: Load.flow must be one of the fields r, phi, v"):
        beam(loads=[Load("nosuchfield", [0.0, 1.0])])


def test_a_load_of_the_wrong_shape_is_refused_when_bound():
    with pytest.raises(InputError, match=r"load v@right: value has shape \(3,\), field 'v' has \(2,\)"):
        beam(loads=[Load("v", lambda t: np.array([1.0, 2.0, 3.0]))])


@pytest.mark.parametrize("value, words", [
    (lambda t: np.zeros(2) if t < 0.12 else np.zeros(3), r"at t = 0.15 has shape \(3,\), at t = 0 it had \(2,\)"),
    (lambda t: np.array([0.0, np.nan if t > 0.12 else 1.0]), r"at t = 0.15 is not finite"),
    (lambda t: ["a", "b"] if t > 0.12 else [0.0, 0.0], r"at t = 0.15 is not an array of numbers"),
], ids=["shape-changes", "nan", "not-numbers"])
def test_a_load_that_goes_wrong_during_the_run_is_named(value, words):
    problem = beam(loads=[Load("v", value, name="push")])
    with pytest.raises(InputError, match="load push: its value " + words):
        run(problem, 0.1, 0.3)


def test_a_constant_initial_value_is_taken_and_a_wrong_one_named():
    """initial={"r": (x, y)} is the constant (x, y) on the whole body; a number for a 2-vector field
    is refused with the field's shape."""
    problem = beam(initial={"r": (0.5, -0.25), "phi": 0.0})
    s, r = problem.space.nodal(problem.x0, "r")
    assert np.all(r == [0.5, -0.25])
    with pytest.raises(InputError, match=r"initial value of field 'r': .* constant of shape \(2,\) is needed \(got 1.0\)"):
        beam(initial={"r": 1.0})


def test_bodies_and_joints_after_the_first_run_are_refused():
    system = System()
    a = system.add("a", BEAM, 1.0, 2)
    system.join(joints.pin, ground(), a.start)
    run(system, 0.01, 0.01)
    with pytest.raises(ConstraintError, match="body b: the system has been built"):
        system.add("b", BEAM, 1.0, 2)
    with pytest.raises(ConstraintError, match="the system has been built"):
        system.join(joints.pin, ground((1.0, 0.0)), a.end)
