"""Scenes built in the test process (not through the command line): a scene's system after a few steps."""
from mpi4py import MPI

from rodfem import run
from rodfem.app.scene import load


def built(scene, n, steps=2):
    """The system of `scene` with n elements (its other parameters the defaults), after `steps` steps."""
    s = load(scene)
    p = s.values({"n_elements": n})
    problem = s.build(p, MPI.COMM_WORLD)
    run(problem, p["dt"], steps * p["dt"])
    return problem
