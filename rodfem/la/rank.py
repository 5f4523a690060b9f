"""The number of independent rows of a sparse matrix (the joints' velocity constraints G).

With its rows scaled to unit length, G (m x n) has independent rows iff its Gram matrix

    A = G G^T        (m x m, unit diagonal; rows that share no column are orthogonal)

is positive definite, i.e. iff every pivot of its symmetric elimination (Cholesky's, LU's without
row exchanges: pivot_k = 1 / (A^{-1})_kk in the order used, each >= lambda_min(A)) is positive.
A dependent row gives a pivot at round-off, ~1e-16; a pivot above PIVOT = 1e-12 (singular values
of G above 1e-6) is taken as independent.  A is as sparse as the joints' graph: a chain of 1000
bodies is banded, and the sparse LU takes milliseconds where a dense SVD of G took minutes (cubic
in the number of joints coupled).  Only when a pivot is small are the rows counted by the
singular values of the dense G (the figure the error message gives).
"""
import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

PIVOT = 1e-12        # the smallest pivot of the unit-diagonal Gram matrix taken as independent
TINY = 1e-10         # rows (and singular values) smaller than this, relative, count as zero


def row_rank(G) -> int:
    """The number of linearly independent rows of G (a scipy.sparse or dense matrix)."""
    G = sp.csr_matrix(G, dtype=float)
    m = G.shape[0]
    if m == 0:
        return 0
    norms = np.sqrt(np.asarray(G.multiply(G).sum(axis=1)).ravel())
    if np.all(norms > TINY * max(norms.max(), 1.0)):
        A = (sp.diags(1.0 / norms) @ G)
        gram = (A @ A.T).tocsc()
        try:
            lu = splu(gram, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                      options={"SymmetricMode": True})
            pivots = np.abs(lu.U.diagonal())
            if pivots.min() > PIVOT and lu.perm_r.tolist() == lu.perm_c.tolist():   # symmetric: Cholesky's pivots
                return m
        except RuntimeError:   # an exactly singular Gram matrix
            pass
    sv = np.linalg.svd(G.toarray(), compute_uv=False)
    return int(np.sum(sv > TINY * max(sv.max(initial=0.0), 1.0)))
