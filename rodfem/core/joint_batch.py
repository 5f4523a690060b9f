"""Many joints' step terms at once: the joints of rodfem/core/joints.py as stacked arrays.

Every joint k with n coordinates and m conditions is the quadratic form
g_k(q) = 1/2 q.Q_k q + c_k.q + e_k (rodfem/core/joints.py, `Joint.step`).  Joints of the same
(n, m) are stacked, Q[k, i, a, b], c[k, i, a], and one step's terms of all of them are a
handful of numpy contractions (no Python work per joint):

    q_m = (q_n + q_{n+1})/2,  v_m = (v_n + v_{n+1})/2,  G_k = Q_k q_m + c_k
    momentum rows:      r_v = G^T lambda               d/dq_{n+1}: 1/2 lambda.Q,  d/dlambda: G^T
    constraint rows:    r_lam = G v_m - dg_p/h         d/dq_{n+1}: 1/2 Q v_m,     d/dv_{n+1}: 1/2 G

Their global rows and columns are fixed when the system is built, so the Jacobian's entries of
all joints go into the matrix by one MatSetValues call per row in one petsc4py call
(``setValuesIJV``, the entries sorted by row once), the residual's by one ``setValues``.
The rows and columns of dofs fixed by supports are left out, as for a single joint.
"""
import numpy as np
from petsc4py import PETSc

from rodfem.core.joints import Joint


def batchable(joint) -> bool:
    """A plain joint (not a servo or another subclass with a step of its own)."""
    return type(joint) is Joint and joint.size > 0


class _Group:
    """Joints with the same number of coordinates n and conditions m, stacked."""

    def __init__(self, joints, fixed, at=None, counted=None):
        self.joints = joints
        self.Q = np.array([j.Q for j in joints])                        # [k, m, n, n]
        self.c = np.array([j.c for j in joints])                        # [k, m, n]
        self.e = np.array([j.e for j in joints])                        # [k, m]
        # positions in the gathered values (`at`: global indices -> positions; else the joints' own)
        self.q_at, self.v_at, self.lam_at = (
            np.array([at(getattr(j, k + "_index")) if at else getattr(j, k + "_at") for j in joints], dtype=np.int64)
            for k in ("q", "v", "lam"))
        # the joints whose supplied work is summed here (a joint computed on two ranks counts on one)
        self.counted = np.ones(len(joints), bool) if counted is None else np.asarray(counted, bool)
        self.q_index = np.array([j.q_index for j in joints], dtype=np.int64)   # global indices
        self.v_index = np.array([j.v_index for j in joints], dtype=np.int64)
        self.lam_index = np.array([j.lam_index for j in joints], dtype=np.int64)
        self.driven = [k for k, j in enumerate(joints) if j.drive is not None]
        free_v = ~np.isin(self.v_index, fixed)
        free_q = ~np.isin(self.q_index, fixed)
        m = self.e.shape[1]
        every = np.ones_like(self.lam_index, dtype=bool)
        # (rows, cols, kept) of each block, in the order of `blocks`
        self.layout = [(self.v_index, self.q_index, free_v, free_q),       # d r_v / d q
                       (self.v_index, self.lam_index, free_v, every),      # d r_v / d lambda
                       (self.lam_index, self.q_index, every, free_q),      # d r_lam / d q
                       (self.lam_index, self.v_index, every, free_v),      # d r_lam / d v
                       (self.lam_index, self.lam_index, every, every)]     # zeros (the LU's pivots)
        self.free_v, self.m = free_v, m

    def entries(self):
        """(rows, cols, kept mask) of every block, flattened."""
        out = []
        for rows, cols, keep_r, keep_c in self.layout:
            R = np.broadcast_to(rows[:, :, None], rows.shape + (cols.shape[1],))
            C = np.broadcast_to(cols[:, None, :], R.shape)
            keep = keep_r[:, :, None] & keep_c[:, None, :]
            out.append((R.ravel(), C.ravel(), keep.ravel()))
        return out

    def prescribed(self, t):
        """g_p(t) of every joint [k, m] (zero for the joints without a drive)."""
        gp = np.zeros(self.e.shape)
        for k in self.driven:
            gp[k] = self.joints[k].prescribed(t)
        return gp

    def step(self, v0, v1, h, t0, t1):
        """The terms of the step: (r_v [k, n], r_lam [k, m], blocks (list of [k, r, c]), work)."""
        q0, q1 = v0[self.q_at], v1[self.q_at]
        qm, vm = 0.5 * (q0 + q1), 0.5 * (v0[self.v_at] + v1[self.v_at])
        lam = v1[self.lam_at]
        G = np.einsum("kiab,kb->kia", self.Q, qm) + self.c
        dgp = self.prescribed(t1) - self.prescribed(t0) if self.driven else np.zeros(self.e.shape)
        r_v = np.einsum("kia,ki->ka", G, lam)
        r_lam = np.einsum("kia,ka->ki", G, vm) - dgp / h
        GT = G.transpose(0, 2, 1)
        blocks = [0.5 * np.einsum("ki,kiab->kab", lam, self.Q), GT, 0.5 * np.einsum("kiab,kb->kia", self.Q, vm),
                  0.5 * G, np.zeros(lam.shape + (self.m,))]
        work = -float(np.sum((lam * dgp)[self.counted])) if self.driven else 0.0
        return r_v, r_lam, blocks, work

    def position_residual(self, v, t):
        """g(q) - g_p(t) of every joint [k, m]."""
        q = v[self.q_at]
        return (0.5 * np.einsum("ka,kiab,kb->ki", q, self.Q, q) + np.einsum("kia,ka->ki", self.c, q) + self.e
                - self.prescribed(t))


class JointBatch:
    """The plain joints of a system (`batchable`), their step terms computed together (rank 0) and
    added to the residual and the matrix in one call each (see the module docstring).

    Each joint must have its indices set (rodfem/core/system.py's PointIndex: q_index, v_index,
    lam_index and the positions q_at, v_at, lam_at in the gathered values); `fixed`: the global
    indices of the dofs fixed by supports.  Bodies placed whole on ranks (rodfem/core/joint_ranks.py):
    `at` maps global indices to positions in this rank's gathered values, `own` = (lo, hi) keeps the
    rows lo <= row < hi only (this rank's) and `counted[k]` tells whether joint k's work is summed here."""

    def __init__(self, joints, fixed, at=None, own=None, counted=None):
        fixed = np.array(sorted(fixed), dtype=np.int64)
        by_shape, where = {}, {}
        for k, j in enumerate(joints):
            by_shape.setdefault((len(j.q_index), j.size), []).append(j)
            where.setdefault((len(j.q_index), j.size), []).append(k)
        counted = np.ones(len(joints), bool) if counted is None else np.asarray(counted, bool)
        self.groups = [_Group(js, fixed, at, counted[where[key]]) for key, js in by_shape.items()]
        lo, hi = own if own is not None else (np.iinfo(np.int64).min, np.iinfo(np.int64).max)
        rows, cols, self._keep = [], [], []
        for g in self.groups:
            for r, c, keep in g.entries():
                keep = keep & (r >= lo) & (r < hi)
                rows.append(r[keep])
                cols.append(c[keep])
                self._keep.append(keep)
        rows = np.concatenate(rows) if rows else np.zeros(0, np.int64)
        cols = np.concatenate(cols) if cols else np.zeros(0, np.int64)
        self.rows, self.cols = rows, cols
        # the matrix entries sorted by row, once: one setValuesIJV per Jacobian
        self._order = np.lexsort((cols, rows))
        r_sorted = rows[self._order]
        self._rowmap, starts = np.unique(r_sorted, return_index=True)
        self._indptr = np.append(starts, len(r_sorted)).astype(PETSc.IntType)
        self._cols = cols[self._order].astype(PETSc.IntType)
        self._rowmap = self._rowmap.astype(PETSc.IntType)
        # the residual's rows: the free momentum rows and every constraint row
        self._res_keep = [(g.free_v.ravel() & (g.v_index.ravel() >= lo) & (g.v_index.ravel() < hi),
                           (g.lam_index.ravel() >= lo) & (g.lam_index.ravel() < hi)) for g in self.groups]
        self._res_rows = np.concatenate(
            [np.concatenate([g.v_index.ravel()[kv], g.lam_index.ravel()[kl]]) for g, (kv, kl) in
             zip(self.groups, self._res_keep)]).astype(PETSc.IntType) if self.groups else np.zeros(0, PETSc.IntType)
        self._terms = None

    def entries(self):
        """(rows, cols) of every matrix entry the joints can fill."""
        return [(self.rows, self.cols)] if len(self.rows) else []

    def update(self, v0, v1, h, t0, t1):
        """The terms of all joints at the gathered values v1 of the iterate (rank 0)."""
        self._terms = [g.step(v0, v1, h, t0, t1) for g in self.groups]
        return sum(t[3] for t in self._terms)

    def residual(self, b):
        if not self._terms or not len(self._res_rows):
            return
        b.setValues(self._res_rows, self.residual_values(), addv=PETSc.InsertMode.ADD)

    def residual_values(self):
        """The residual's values at the rows `_res_rows` (of the last `update`)."""
        return np.concatenate([np.concatenate([r_v.ravel()[kv], r_lam.ravel()[kl]])
                               for (r_v, r_lam, _, _), (kv, kl) in zip(self._terms, self._res_keep)])

    def jacobian(self, A):
        if not self._terms or not len(self.rows):
            return
        flat, k = [], 0
        for r_v, r_lam, blocks, _ in self._terms:
            for block in blocks:
                flat.append(block.ravel()[self._keep[k]])
                k += 1
        values = np.concatenate(flat)[self._order]
        A.setValuesIJV(self._indptr, self._cols, np.ascontiguousarray(values, dtype=PETSc.ScalarType),
                       addv=PETSc.InsertMode.ADD_VALUES, rowmap=self._rowmap)

    def worst_gap(self, v, t):
        """max |g(q) - g_p(t)| over the joints."""
        return max((float(np.max(np.abs(g.position_residual(v, t)))) for g in self.groups), default=0.0)

    def multipliers(self, v):
        """(joint, lambda values) of every joint, in the groups' order."""
        for g in self.groups:
            lam = v[g.lam_at]
            for j, values in zip(g.joints, lam):
                yield j, values
