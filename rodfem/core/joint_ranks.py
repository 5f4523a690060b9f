"""The plain joints of bodies placed whole on ranks, computed on the ranks of their rows.

With every body whole on one rank (rodfem/core/placement.py, RankLayout in rodfem/fem/assembly.py) a
joint's rows are the momentum rows of its points, on its bodies' ranks, and its constraint rows, on the
rank of its first body.  Each rank computes the step terms (rodfem/core/joint_batch.py) of the joints
with a row of its own, from the values of their coordinates, velocities and multipliers gathered on
that rank (one PETSc scatter: the other rank's few values of a joint between two ranks come by
point-to-point messages), and adds only its own rows: the residual straight into its part of the
vector, the Jacobian into its rows of the matrix.  A joint between bodies of two ranks is computed on
both (the same numbers from the same gathered values, each rank adding its rows), its supplied work
counted on the rank of its constraint rows.  No entry then goes to another rank (the matrix's
assembly exchanges no values, the residual needs no assembly), and the joints' work is shared out.
"""
import numpy as np
from petsc4py import PETSc

from rodfem.core.joint_batch import JointBatch


class RankJoints:
    """The plain joints `joints` (their q_index, v_index, lam_index and rows set: rodfem/core/system.py's
    PointIndex) computed on this rank; `fixed`: the dofs fixed by supports; X: a vector of the layout
    (collective)."""

    def __init__(self, joints, fixed, layout, X):
        self.lo, self.hi = layout.start, layout.start + layout.size_local
        mine = [j for j in joints if self._here(np.concatenate([j.v_index[j.rows], j.lam_index])).any()]
        wanted = [idx for j in mine for idx in (j.q_index, j.v_index, j.lam_index)]
        self.wanted = (np.unique(np.concatenate(wanted)) if wanted else np.zeros(0, np.int64)).astype(PETSc.IntType)
        self.gathered = PETSc.Vec().createSeq(len(self.wanted), comm=PETSc.COMM_SELF)
        is_from = PETSc.IS().createGeneral(self.wanted, comm=PETSc.COMM_SELF)
        self.scatter = PETSc.Scatter().create(X, is_from, self.gathered, None)   # (collective)
        is_from.destroy()

        def at(index):
            return np.searchsorted(self.wanted, np.asarray(index, np.int64))
        counted = [bool(self._here(j.lam_index[:1]).all()) for j in mine]
        self.batch = JointBatch(mine, fixed, at=at, own=(self.lo, self.hi), counted=counted) if mine else None
        self.rows = self.batch._res_rows - self.lo if self.batch is not None else None
        # a point of two joints: its rows repeat, their terms summed by bincount over the distinct rows
        # (np.add.at: 0.12 ms a residual at 256 links, a third of the joints' step work)
        self.distinct, self.inverse = (np.unique(self.rows, return_inverse=True) if self.rows is not None
                                       else (None, None))
        self.repeated = self.rows is not None and len(self.distinct) < len(self.rows)
        self.x0 = None

    def _here(self, index):
        return (index >= self.lo) & (index < self.hi)

    def values(self, X):
        """The values of X this rank's joints read (collective)."""
        self.scatter.scatter(X, self.gathered, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return self.gathered.getArray(readonly=True).copy()

    def step(self, X0):
        """x_n of the step (collective)."""
        self.x0 = self.values(X0)

    def update(self, X, h, t0, t1):
        """The terms at the iterate X (collective); returns the supplied work of the joints counted here."""
        v1 = self.values(X)
        return self.batch.update(self.x0, v1, h, t0, t1) if self.batch is not None else 0.0

    def worst_gap(self, X, t):
        """max |g(q) - g_p(t)| over this rank's joints at the state X (collective)."""
        v = self.values(X)
        return self.batch.worst_gap(v, t) if self.batch is not None else 0.0

    def residual(self, b):
        """Add the terms to this rank's rows of b (the array of this rank's part)."""
        if self.batch is not None and len(self.rows):
            if self.repeated:
                b[self.distinct] += np.bincount(self.inverse, self.batch.residual_values(), len(self.distinct))
            else:
                b[self.rows] += self.batch.residual_values()

    def jacobian(self, A):
        if self.batch is not None:
            self.batch.jacobian(A)
