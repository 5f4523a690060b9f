"""The soft-arm-grasp scene (demos/soft_arm_grasp.py): a tendon arm wraps itself around a fixed pole.
Checks: the balance with contact and friction to round-off under the discrete gradient, the friction
and dashpot work >= 0 every step, the penetration within the stated tolerance (and the impact's
overshoot bounded), the arm wrapped onto the pole, and, once the arm has settled, the forces on it in
balance -- base reaction (the weld's multipliers) + the pole's normal and friction force = 0 (the
tendon's forces are internal) -- without and with friction; mpirun -n 2 = serial."""

import numpy as np
import pytest
from mpi4py import MPI
from processes import assert_same_rows, rodfem_lines, script_on_ranks

from rodfem import run
from rodfem.demos.soft_arm_grasp import scene
from rodfem.errors import ParameterError

_RUNS = {}


def grasp(**over):
    """(p, result) of the scene with `over`, run once per set of parameters (the tests share the default run)."""
    p = scene.values(over)
    key = tuple(sorted(p.items()))
    if key not in _RUNS:
        _RUNS[key] = (p, run(scene.build(p, MPI.COMM_WORLD), p["dt"], p["t_end"]))
    return _RUNS[key]


def settled_forces(p, result, window=1.0):
    """The means over the last `window` seconds of the pole's force on the arm (normal + friction) and
    of the base's (the weld's multipliers): the contact columns are the state's, and ring at the step
    rate on the unresolved contact vibration; their mean is the step's force."""
    rows = [r for r in result.rows if r["t"] >= p["t_end"] - window]
    contact = np.mean([[r[f"arm.pole.Fn_{c}"] + r[f"arm.pole.Ft_{c}"] for c in "xyz"] for r in rows], axis=0)
    base = np.mean([[r[f"base.lambda{i}"] for i in (1, 2, 3)] for r in rows], axis=0)
    return contact, base


def test_grasp_keeps_the_balance_and_the_penetration():
    """With friction (mu = 0.3): H (kinetic, elastic, contact) - supplied + dissipated exact to 1e-12 of
    max |H| (measured 3e-13), every step's dissipation >= 0, the arm wrapped onto the pole (the tip
    under it, the normal force > 1 N); the penetration at the end below the stated 1e-3 m and at the
    impact below twice it (measured 1.7e-3 m: the arm slams onto the pole when its curvature reaches
    the pole's)."""
    p, result = grasp()
    H = result.column("H")
    assert result.max_balance_error <= 1e-12 * np.max(np.abs(H))
    assert np.diff(result.column("dissipated")).min() >= 0
    last = result.rows[-1]
    assert last["tip_z"] < -0.5 * p["R"]                       # round the pole, under it
    assert last["arm.pole.N"] > 1.0
    assert last["arm.pole.penetration"] <= p["penetration"]
    assert result.column("arm.pole.penetration").max() <= 2 * p["penetration"]


@pytest.mark.parametrize("mu, tol", [(0.0, 5e-3), (0.3, 3e-2)], ids=["frictionless", "friction"])
def test_settled_grasp_forces_balance(mu, tol):
    """At rest the pole's force balances the base's: |F_base + F_contact| <= tol |F_contact| over the
    last second (measured 1.3e-3 frictionless, 1.4e-2 with friction: the friction column is the
    regularized law at the state, and rings on its stiff slip), the grip |F_contact| ~ 4.7 N."""
    p, result = grasp(mu=mu)
    contact, base = settled_forces(p, result)
    assert np.linalg.norm(contact) > 1.0
    assert np.linalg.norm(base + contact) <= tol * np.linalg.norm(contact)


def test_bad_parameters_are_refused_in_one_line():
    with pytest.raises(ParameterError, match=r"parameter 'offset' must be in \(0, radius = 0.01\)"):
        scene.build(scene.values({"offset": 0.02}), MPI.COMM_WORLD)
    with pytest.raises(ParameterError, match="parameter 'mu' must be a number >= 0"):
        scene.values({"mu": -1})


SCRIPT = """
import json
from mpi4py import MPI
import rodfem
from rodfem.demos.soft_arm_grasp import scene
p = scene.values({"t_end": 0.8})
result = rodfem.run(scene.build(p, MPI.COMM_WORLD), p["dt"], p["t_end"])
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(result.rows[-1]))
"""


@pytest.mark.mpi
def test_grasp_in_parallel_equals_serial():
    """The grasp up to the first contact (t = 0.8 s: the arm lands on the pole at 0.75 s) under mpirun -n 2
    writes the serial history."""
    serial, parallel = script_on_ranks(SCRIPT, timeout=600)
    assert serial["arm.pole.N"] > 0
    assert_same_rows(serial, parallel)


def test_bad_parameter_cli(rodfem, tmp_path):
    """`rodfem run soft-arm-grasp` with the tendon outside the section: exit 2, one line naming the parameter."""
    out = rodfem("run", "soft-arm-grasp", "--set", "offset=0.02", "--out", str(tmp_path / "x"))
    assert out.returncode == 2
    lines = rodfem_lines(out.stderr)
    assert len(lines) == 1 and "parameter 'offset' must be in (0, radius = 0.01)" in lines[0]
