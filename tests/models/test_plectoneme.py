"""The plectoneme scene (demos/plectoneme.py) and its turned end (rodfem/core/joints.py, `MovingGround`):
a rod turned below the buckling twist stays straight with Tw = the imposed turns and the end's directors
on the turning frame to round-off, the torque's work exact; turned past buckling it coils, touches itself
and Lk = Tw + Wr stays the imposed turns while the twist turns into writhe, with the energy balance exact
under the discrete gradient and the penetration small; without the self-contact the rod passes through
itself and Lk jumps by 2; bad input; mpirun -n 2 = serial."""
import numpy as np
import pytest
from mpi4py import MPI
from processes import script_on_ranks

from rodfem import Support, System, ground, run
from rodfem.demos.plectoneme import scene, section
from rodfem.errors import ConstraintError, ParameterError
from rodfem.forms import cosserat_rod
from rodfem.forms.joints import prismatic


def column(result, name):
    return np.array([row[name] for row in result.rows])


SMALL = {"n_elements": 10, "turns": 1.5, "turn_time": 2.0, "dt": 0.04}


def test_below_buckling_the_rod_twists_straight():
    """0.5 turns (half the buckling twist): Wr = 0, Tw = Lk = t/turn_time; the end on the axis with its d2 at
    the frame's angle; torque GJ theta / L quasi-statically: H = supplied - dissipated = 1/2 GJ theta^2 / L
    (the strain energy; the kinetic energy is small); balance to round-off; the wall at the clamp (the plane
    x = -r) does nothing to a rod in front of it."""
    p = scene.values({**SMALL, "turns": 0.5, "t_end": 1.2, "turn_time": 2.0, "imperfection": 0.0})
    result = run(scene.build(p, MPI.COMM_WORLD), p["dt"], p["t_end"])
    t = column(result, "t")
    imposed = np.minimum(t / p["turn_time"], p["turns"])
    assert np.abs(column(result, "Lk") - imposed).max() < 1e-9
    assert np.abs(column(result, "Tw") - imposed).max() < 1e-9
    assert np.abs(column(result, "Wr")).max() < 1e-9
    assert np.abs(column(result, "end_y")).max() < 1e-12 and np.abs(column(result, "end_z")).max() < 1e-12
    assert np.abs(column(result, "balance_error")).max() < 1e-12
    _, _, _, C_M = section(p)
    theta = 2 * np.pi * p["turns"]
    work = 0.5 * theta**2 / (C_M[0] * p["L"])
    last = result.rows[-1]
    assert last["H"] == pytest.approx(work, rel=1e-3)
    assert last["supplied"] - last["dissipated"] == pytest.approx(last["H"], abs=1e-11)
    # the wall the rod is clamped in touches the tube at the clamp and takes no force: no energy, no penetration
    assert np.abs(column(result, "rod.wall.energy")).max() == 0.0 and np.abs(column(result, "rod.wall.N")).max() == 0.0
    assert column(result, "rod.wall.penetration").max() == 0.0


def test_link_holds_through_buckling_with_self_contact():
    """1.5 turns (10 elements, dt = 0.04): the rod buckles past about one turn (Wr grows past 0.5), touches
    itself, and Lk = Tw + Wr = the imposed turns at every step to 1e-6; the balance H_n - H_0 - supplied +
    dissipated to round-off; the penetration below r/5."""
    p = scene.values({**SMALL, "t_end": 3.2})
    result = run(scene.build(p, MPI.COMM_WORLD), p["dt"], p["t_end"])
    assert np.abs(column(result, "Lk_error")).max() < 1e-6
    assert column(result, "Wr")[-1] > 0.5
    pen = column(result, "self.penetration")
    assert pen.max() > 0
    assert pen.max() < 0.2 * p["r"]
    H, supplied, lost = column(result, "H"), column(result, "supplied"), column(result, "dissipated")
    assert np.abs(H - H[0] - supplied + lost).max() < 1e-11 * supplied[-1]
    assert np.abs(column(result, "balance_error")).max() < 1e-12 * supplied[-1]
    off = scene.values({**SMALL, "t_end": 3.2, "contact": "off"})
    free = run(scene.build(off, MPI.COMM_WORLD), off["dt"], off["t_end"])
    jump = np.abs(column(free, "Lk_error"))
    first = int(np.argmax(jump > 0.5))                  # the first step with a crossing
    assert jump[first] == pytest.approx(2.0, abs=1e-6) and jump[:first].max() < 1e-6


def test_bad_input_is_refused_in_one_line():
    with pytest.raises(ParameterError, match="imperfection"):
        scene.build(scene.values({"imperfection": 0.5}), MPI.COMM_WORLD)
    with pytest.raises(ParameterError, match="n_elements' must be >= 25"):
        scene.build(scene.values({"turns": 10, "n_elements": 12}), MPI.COMM_WORLD)
    with pytest.raises(ParameterError, match="turns"):
        scene.values({"turns": -1})
    s = System()
    model = cosserat_rod.CosseratRod(1.0, (0.02, 0.01, 0.01), [1e-3] * 3, [1.0] * 3)
    rod = s.add("rod", model, 1.0, 2, supports=[Support("left", "clamped")])
    with pytest.raises(ConstraintError, match="moves the ground point"):
        s.join(prismatic(0), rod.start, rod.end, motion=lambda t: (np.zeros(3), np.eye(3)))
    s.join(prismatic(0), ground((1.0, 0, 0)), rod.end, name="off", motion=lambda t: (np.zeros(3), np.eye(3)))
    with pytest.raises(ConstraintError, match="motion\\(0\\) must be the ground point's frame"):
        run(s, 0.1, 0.1)


SCRIPT = """
import json
from mpi4py import MPI
import rodfem
from rodfem.demos.plectoneme import scene
p = scene.values({"n_elements": 10, "turns": 1.5, "turn_time": 2.0, "t_end": 3.2, "dt": 0.04})
result = rodfem.run(scene.build(p, MPI.COMM_WORLD), p["dt"], p["t_end"])
if MPI.COMM_WORLD.rank == 0:
    row = dict(result.rows[-1], max_penetration=max(r["self.penetration"] for r in result.rows))
    print(json.dumps(row))
"""


@pytest.mark.mpi
def test_plectoneme_in_parallel_equals_serial():
    """The buckling rod of the test above (10 elements over 2 ranks: the turning joint, the contact's and the
    link's nodes gathered) under mpirun -n 2 writes the serial history, through the self-contact."""
    serial, parallel = script_on_ranks(SCRIPT, timeout=900)
    assert serial["max_penetration"] > 0 and serial["Wr"] > 0.5
    assert serial.keys() == parallel.keys()
    for key, value in serial.items():
        if key != "wall_time":
            assert parallel[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
