"""Many joints' step terms at once: the joints of rodfem/core/joints.py as stacked arrays.

Every joint k with n coordinates and m conditions is the quadratic form
g_k(q) = 1/2 q.Q_k q + c_k.q + e_k (rodfem/core/joints.py, `Joint.step`).  Joints of the same
(n, m) are stacked, Q[k, i, a, b], c[k, i, a], and one step's terms of all of them are a
handful of numpy contractions (no Python work per joint):

    q_m = (q_n + q_{n+1})/2,  v_m = (v_n + v_{n+1})/2,  G_k = Q_k q_m + c_k
    momentum rows:      r_v = G^T lambda               d/dq_{n+1}: 1/2 lambda.Q,  d/dlambda: G^T
    constraint rows:    r_lam = G v_m - dg_p/h         d/dq_{n+1}: 1/2 Q v_m,     d/dv_{n+1}: 1/2 G

A joint whose conditions are linear in q (Q_k = 0: a pin between two beams' end nodes) has a constant
G_k = c_k and constant Jacobian blocks: they are computed once, and a step of such joints is the two
products above.  The blocks of the others are computed when a Jacobian is asked for, not at every
residual.

Their global rows and columns are fixed when the system is built, so the Jacobian's entries of
all joints go into the matrix by one MatSetValues call per row in one petsc4py call
(``setValuesIJV``, the entries sorted by row once), the residual's by one ``setValues``.
The rows and columns of dofs fixed by supports are left out, as for a single joint.
"""
import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc

from rodfem.core.joints import Joint


def batchable(joint) -> bool:
    """A plain joint (not a servo or another subclass with a step of its own)."""
    return type(joint) is Joint and joint.size > 0


class _Group:
    """Joints with the same number of coordinates n and conditions m, stacked, with the entries that
    can be nonzero only: Q is sparse (a revolute joint between rigid bodies, n = 24, m = 5: 30 of Q's
    2880 coefficients), so its products are sparse matrix-vector products and each block of the step's
    Jacobian keeps the entries where Q (and c) can make it nonzero:

        d r_v/dq = 1/2 lambda.Q:   (a, b) with Q_kiab != 0 for some i
        d r_v/dlambda = G^T, d r_lam/dv = 1/2 G:   (i, a) with Q_kiab != 0 for some b, or c_kia != 0
        d r_lam/dq = 1/2 Q v_m:    (i, a) with Q_kiab != 0 for some b
        d r_lam/dlambda = 0:       every (i, j) (explicit zeros: the LU's pivots)
    """

    def __init__(self, joints, fixed, at=None, counted=None):
        self.joints = joints
        Q = np.array([j.Q for j in joints])                             # [k, m, n, n]
        self.c = np.array([j.c for j in joints])                        # [k, m, n]
        self.e = np.array([j.e for j in joints])                        # [k, m]
        k, m, n = self.c.shape
        kk, ii, aa, bb = np.nonzero(Q)
        values = Q[kk, ii, aa, bb]
        # G = Q q + c as one sparse product: row (k, i, a), column (k, b)
        self.QG = sp.csr_matrix((values, ((kk * m + ii) * n + aa, kk * n + bb)), shape=(k * m * n, k * n))
        structure_vq = np.zeros((k, n, n), bool)
        structure_vq[kk, aa, bb] = True
        structure_q = np.zeros((k, m, n), bool)
        structure_q[kk, ii, aa] = True
        structure_G = structure_q | (self.c != 0)
        # 1/2 lambda.Q at the entries of structure_vq: row (its place among them), column (k, i)
        place = np.full(k * n * n, -1, dtype=np.int64)
        place[np.flatnonzero(structure_vq)] = np.arange(int(structure_vq.sum()))
        self.QL = sp.csr_matrix((0.5 * values, (place[(kk * n + aa) * n + bb], kk * m + ii)),
                                shape=(int(structure_vq.sum()), k * m))
        # (each block's entries: flat positions in the block [k, rows, cols])
        self.structure = [np.flatnonzero(structure_vq), np.flatnonzero(structure_G.transpose(0, 2, 1)),
                          np.flatnonzero(structure_q), np.flatnonzero(structure_G), np.arange(k * m * m)]
        self.zeros = np.zeros(k * m * m)
        # positions in the gathered values (`at`: global indices -> positions; else the joints' own)
        self.q_at, self.v_at, self.lam_at = (
            np.array([at(getattr(j, x + "_index")) if at else getattr(j, x + "_at") for j in joints], dtype=np.int64)
            for x in ("q", "v", "lam"))
        # the joints whose supplied work is summed here (a joint computed on two ranks counts on one)
        self.counted = np.ones(len(joints), bool) if counted is None else np.asarray(counted, bool)
        self.q_index = np.array([j.q_index for j in joints], dtype=np.int64)   # global indices
        self.v_index = np.array([j.v_index for j in joints], dtype=np.int64)
        self.lam_index = np.array([j.lam_index for j in joints], dtype=np.int64)
        self.driven = [x for x, j in enumerate(joints) if j.drive is not None]
        free_v = ~np.isin(self.v_index, fixed)
        free_q = ~np.isin(self.q_index, fixed)
        every = np.ones_like(self.lam_index, dtype=bool)
        # (rows, cols, kept) of each block, in the order of `blocks`
        self.layout = [(self.v_index, self.q_index, free_v, free_q),       # d r_v / d q
                       (self.v_index, self.lam_index, free_v, every),      # d r_v / d lambda
                       (self.lam_index, self.q_index, every, free_q),      # d r_lam / d q
                       (self.lam_index, self.v_index, every, free_v),      # d r_lam / d v
                       (self.lam_index, self.lam_index, every, every)]     # zeros (the LU's pivots)
        self.free_v, self.m = free_v, m
        # linear conditions (Q = 0): G = c and the blocks are constant
        self.linear, self._constant = self.QG.nnz == 0, None
        if self.linear:
            self._constant = self.blocks(self.c, np.zeros((k, m)), np.zeros((k, n)))

    def entries(self):
        """(rows, cols, kept mask) of every block's entries that can be nonzero, flattened (in the
        order of the values `step` gives)."""
        out = []
        for (rows, cols, keep_r, keep_c), where in zip(self.layout, self.structure):
            R = np.broadcast_to(rows[:, :, None], rows.shape + (cols.shape[1],))
            C = np.broadcast_to(cols[:, None, :], R.shape)
            keep = keep_r[:, :, None] & keep_c[:, None, :]
            out.append((R.ravel()[where], C.ravel()[where], keep.ravel()[where]))
        return out

    def prescribed(self, t):
        """g_p(t) of every joint [k, m] (zero for the joints without a drive)."""
        gp = np.zeros(self.e.shape)
        for x in self.driven:
            gp[x] = self.joints[x].prescribed(t)
        return gp

    def G(self, q):
        """G(q) = Q q + c of every joint [k, m, n] (q: [k, n])."""
        return (self.QG @ q.ravel()).reshape(self.c.shape) + self.c

    def step(self, v0, v1, h, t0, t1):
        """The terms of the step: (r_v [k, n], r_lam [k, m], (G, lambda, v_m): what `blocks` takes, work)."""
        vm = 0.5 * (v0[self.v_at] + v1[self.v_at])
        lam = v1[self.lam_at]
        if self.linear:
            G = self.c
        else:
            q0, q1 = v0[self.q_at], v1[self.q_at]
            G = self.G(0.5 * (q0 + q1))
        dgp = self.prescribed(t1) - self.prescribed(t0) if self.driven else 0.0
        r_v = np.matmul(lam[:, None, :], G)[:, 0, :]
        r_lam = np.matmul(G, vm[:, :, None])[:, :, 0] - dgp / h
        work = -float(np.sum((lam * dgp)[self.counted])) if self.driven else 0.0
        return r_v, r_lam, (G, lam, vm), work

    def blocks(self, G, lam, vm):
        """Each Jacobian block's values at its entries (flat, in the order of `entries`): 1/2 lambda.Q,
        G^T, 1/2 Q v_m, 1/2 G and the zeros (constant for linear conditions)."""
        if self._constant is not None:
            return self._constant
        return [self.QL @ lam.ravel(), G.transpose(0, 2, 1).ravel()[self.structure[1]],
                0.5 * (self.QG @ vm.ravel())[self.structure[2]], 0.5 * G.ravel()[self.structure[3]], self.zeros]

    def position_residual(self, v, t):
        """g(q) - g_p(t) = 1/2 (G(q) + c) q + e - g_p(t) of every joint [k, m]."""
        q = v[self.q_at]
        G = self.c if self.linear else self.G(q)
        return 0.5 * np.matmul(G + self.c, q[:, :, None])[:, :, 0] + self.e - self.prescribed(t)


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
        self._gather = np.flatnonzero(np.concatenate(self._keep))[self._order] if self._keep else np.zeros(0, np.int64)
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
        self._values = None   # the Jacobian's values, when constant (linear conditions only)

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
        values = self._values
        if values is None:
            values = np.concatenate([block.ravel() for g, terms in zip(self.groups, self._terms)
                                     for block in g.blocks(*terms[2])])[self._gather]
            values = np.ascontiguousarray(values, dtype=PETSc.ScalarType)
            if all(g.linear for g in self.groups):
                self._values = values   # (constant)
        A.setValuesIJV(self._indptr, self._cols, values, addv=PETSc.InsertMode.ADD_VALUES, rowmap=self._rowmap)

    def worst_gap(self, v, t):
        """max |g(q) - g_p(t)| over the joints."""
        return max((float(np.max(np.abs(g.position_residual(v, t)))) for g in self.groups), default=0.0)

    def multipliers(self, v):
        """(joint, lambda values) of every joint, in the groups' order."""
        for g in self.groups:
            lam = v[g.lam_at]
            for j, values in zip(g.joints, lam):
                yield j, values
