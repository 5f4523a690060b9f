"""The step's Jacobian is the derivative of its residual: J = dF/dx_{n+1} against central differences.

Newton's quadratic convergence needs J = dF/dx.  Each body's J is UFL's derivative of its residual
form (rodfem/core/body.py), but the system's matrix also holds the joints' and components' blocks
written by hand (rodfem/core/joints.py, rodfem/core/joint_batch.py: constant for linear conditions,
computed only when a Jacobian is asked for; rodfem/core/components.py), assembled by our own kernels
(rodfem/fem/fastassembly.py, rodfem/fem/batch.py).  Here the assembled matrix is compared, column by
column, with central differences of the assembled residual, at a state a few steps into a run
pushed off the solution by a random perturbation (the dofs fixed by supports left at their values:
off them the residual's lifting is linearized, and J's columns there are zero by construction).
The error of column j is measured against that column's largest entry (a joint's multiplier column
holds G^T, entries of order 1, beside the beams' stiffness rows of order 1e8).  Measured: 1.6e-11
(chain of rigid links) to 7.2e-7 (four-bar: the stiff beams' residual's round-off over the step h
of the differences) (bound 1e-5); a joint's G^T block scaled by 0.9 gives 0.11 in every scene with
joints, the 1/2 Q v_m block left out 4e-4.
"""
import numpy as np
import pytest
from mpi4py import MPI

from rodfem import run
from rodfem.app.scene import load

pytestmark = pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="serial: the dense matrix of one rank")


def fixed_dofs(assembler, n):
    fixed = np.zeros(n, bool)
    for blk in assembler.blocks:
        for bc in blk.bcs:
            fixed[blk.l2g[bc.dof_indices()[0]]] = True
    return fixed


def jacobian_and_differences(system, dt, steps=3, noise=1e-3, seed=0):
    """(J, D): the assembled Jacobian and the central differences of the residual, dense."""
    run(system, dt, steps * dt)
    newton = system.newton
    asm = newton.assembler
    x = asm.vector.copy()
    n = x.getSize()
    rng = np.random.default_rng(seed)
    X = x.getArray()
    X += np.where(fixed_dofs(asm, n), 0.0, noise * rng.standard_normal(n) * (1.0 + np.abs(X)))
    b = newton.b.duplicate()
    asm.residual(x, b)
    asm.jacobian(x, newton.A)
    J = newton.A.convert("dense").getDenseArray().copy()
    D = np.empty((n, n))
    y = x.duplicate()
    for j in range(n):
        h = 1e-5 * max(1.0, abs(X[j]))
        columns = []
        for sign in (1.0, -1.0):
            x.copy(y)
            y.getArray()[j] += sign * h
            asm.residual(y, b)
            columns.append(b.getArray().copy())
        D[:, j] = (columns[0] - columns[1]) / (2.0 * h)
    return J, D


@pytest.mark.parametrize("scene, overrides", [
    ("four-bar-2d", {}),                                   # flexible beams, pins (linear)
    ("chain-1000", {"n_links": 4}),                        # rigid links, revolute joints (quadratic)
    ("spring-damper-chain", {}),                            # rigid boxes, springs and dashpots (components)
    ("slider-crank-3d", {}),                               # revolute, spherical, universal, prismatic
    ("free-flying-3d", {"n_elements": 4}),                 # 3D rods and a ball joint
    ("tensegrity", {}),                                    # rigid struts, string cables, spherical joints
    ("crane-payload", {"n_elements": 4}),                  # a string carrying a rigid box
])
def test_jacobian_is_the_derivative_of_the_residual(scene, overrides):
    s = load(scene)
    p = s.values(overrides)
    J, D = jacobian_and_differences(s.build(p, MPI.COMM_WORLD), p["dt"])
    column = np.max(np.abs(J), axis=0)
    err = np.max(np.abs(J - D)[:, column > 0] / column[column > 0])
    assert err <= 1e-5, err
    assert np.all(np.abs(D[:, column == 0]) <= 1e-5 * np.max(column)), "a column the Jacobian leaves out"
