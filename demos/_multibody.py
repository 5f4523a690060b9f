# Shared pieces of the multibody scenes: the nodal fields of a body gathered
# on every rank, the frame of a rigid body and the orthonormality of directors
# (for history columns added with System.record).
import numpy as np
from mpi4py import MPI

from rodfem.forms.cosserat_rod import DIRECTORS


def nodal(body, field, state="x1"):
    """All nodal values of `field` of a body, sorted by s, on every rank: (s, values[n, size])."""
    s, vals = body.space.nodal(getattr(body, state), field)
    parts = body.comm.allgather((s, vals))
    s = np.concatenate([p[0] for p in parts])
    vals = np.concatenate([p[1] for p in parts])
    order = np.argsort(s, kind="stable")
    s, vals = s[order], vals[order]
    keep = np.concatenate([[True], np.diff(s) > 0]) if len(s) else []
    return s[keep], vals[keep]


def rigid_frame(body, state="x1"):
    """(x, R = [d1 d2 d3]) of a director-based rigid body (every rank)."""
    x = nodal(body, "x", state)[1][0]
    R = np.column_stack([nodal(body, d, state)[1][0] for d in DIRECTORS])
    return x, R


def orthonormality(*bodies, state="x1", comm=None, system=None):
    """max |R^T R - I| over the nodes of director-based bodies (rigid or rods), every rank of `comm`
    (default: the first body's): each rank its own nodes, then one reduction.  ``system=``: every
    body of a System with directors, read from its state in one indexing (System.field_values)."""
    if system is not None:
        R = np.stack([system.field_values(d, state) for d in DIRECTORS], axis=2)
        comm = system.comm
    else:
        R = np.concatenate([np.stack([b.space.nodal(getattr(b, state), d)[1] for d in DIRECTORS], axis=2)
                            for b in bodies])
    worst = float(np.max(np.abs(np.einsum("nki,nkj->nij", R, R) - np.eye(3)))) if len(R) else 0.0
    return (comm or bodies[0].comm).allreduce(worst, op=MPI.MAX)


def rod_inertia(m, l, r):
    """Principal moments (J_1, J_2, J_3) of a uniform solid cylinder of mass m, length l, radius r along d1:
    J_1 = m r^2 / 2, J_2 = J_3 = m (l^2 / 12 + r^2 / 4)."""
    J = m * (l * l / 12.0 + r * r / 4.0)
    return np.array([0.5 * m * r * r, J, J])
