"""The partial LU's order and factor pattern kept per matrix pattern (rodfem/la/partial_lu.py).

A system built again in the same process skips the ordering and the symbolic factorization of its
Jacobian's pattern; the factor is made afresh.  The history must be the one of a process that
factors that pattern for the first time, to the bit, and a different pattern of the same size (a
3D rod pinned at one end against the free one: the supported rows and columns leave the pattern)
must not take the other's order."""
import numpy as np
from mpi4py import MPI

from rodfem import Load, Problem, Support, constant_in_time, run
from rodfem.app.scene import load
from rodfem.demos._rod3d import NEWTON, rod, straight
from rodfem.demos.flying_spaghetti_3d import END, LENGTH, START
from rodfem.la import partial_lu

SCENE = load("flying-spaghetti-3d")
P = SCENE.values({"n_elements": 4})


def free():
    return SCENE.build(P, MPI.COMM_WORLD)


def pinned():
    """The scene's rod and loads, pinned at s = 0."""
    d1, d3 = (END - START) / LENGTH, np.array([0.0, 0.0, 1.0])
    loads = [Load("v", constant_in_time([P["Fx"], P["Fy"], P["Fz"]], until=P["t_load"]), "right", "end force")]
    return Problem(rod(P), LENGTH, P["n_elements"], loads=loads, supports=[Support("left", "pinned")],
                   initial=straight(START, (d1, np.cross(d3, d1), d3)), integrator=P["integrator"],
                   comm=MPI.COMM_WORLD, newton_options=NEWTON)


def history(make, steps=3):
    problem = make()
    result = run(problem, P["dt"], steps * P["dt"])
    assert problem.newton.linear_solver.startswith("schur")   # (the partial LU served)
    return {c: np.asarray(result.column(c), float) for c in result.rows[0] if c != "wall_time"}


def same(a, b):
    assert a.keys() == b.keys()
    for c in a:
        assert np.array_equal(a[c], b[c]), c


def test_a_pattern_factored_again_gives_the_same_history():
    partial_lu._SYMBOLIC.clear()
    first = history(pinned)
    partial_lu._SYMBOLIC.clear()
    free_first = history(free)
    kept = len(partial_lu._SYMBOLIC)
    again = history(pinned)                 # another pattern of the same size: its own order
    assert len(partial_lu._SYMBOLIC) == kept + 1
    same(first, again)
    same(free_first, history(free))         # the kept order and pattern: nothing ordered again
    assert len(partial_lu._SYMBOLIC) == kept + 1
