"""A rank's part of the interface Schur complement straight out of its LU: partial factorization.

For the rank's matrix with its interface G ordered last,

    K = [[A_II, A_IG],      = [[L_II, 0],   [[U_II, U_IG],
         [A_GI, 0   ]]         [L_GI, I]] .  [0,    T   ]]

Gaussian elimination of the interior rows only (no pivoting, in a fill-reducing order of I)
leaves in the G x G corner T = -A_GI A_II^{-1} A_IG, the rank's term of the Schur complement
S = A_GG + sum_r T_r.  No solve per interface column is needed (rodfem/la/schur.py's Z:
one full forward and backward sweep per column), and an application is one sweep each way:

    forward:   z_I = L_II^{-1} b_I,   z_G = -L_GI z_I   (= -A_GI A_II^{-1} b_I)
    (the caller sums z_G over the ranks, adds b_G and solves S x_G = b_G + sum_r z_G)
    backward:  x_I = U_II^{-1} (z_I - U_IG x_G).

This is what MUMPS does with a Schur complement (ICNTL(19)); PETSc 3.18's own LU has no such
option and MUMPS factors these chains 2-3x slower than PETSc's LU.  The kernels are a plain
up-looking sparse LU (symbolic fill once per nonzero pattern, numeric per Jacobian) in C.

The interior order (`interior_orders`): the dofs with a zero diagonal (multipliers) after the dofs
they couple to, the dofs next to the interface last (the fill of the G rows then stays small);
for the rest the one with the least fill of RCM (both ways round) and AMD, or, after a zero pivot,
nested dissection of the graph in RCM order, or AMD.
"""
import numpy as np

from rodfem.fem import cbuild

C_SOURCE = r"""
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>

/* sum_p a[p] x[j[p]] over [p0, p1), four independent sums (the loop is latency-bound otherwise) */
static inline double sparse_dot(int64_t p0, int64_t p1, const double* a, const int32_t* j, const double* x)
{
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
  int64_t p = p0;
  for (; p + 4 <= p1; p += 4) {
    s0 += a[p] * x[j[p]];
    s1 += a[p + 1] * x[j[p + 1]];
    s2 += a[p + 2] * x[j[p + 2]];
    s3 += a[p + 3] * x[j[p + 3]];
  }
  for (; p < p1; ++p) s0 += a[p] * x[j[p]];
  return (s0 + s1) + (s2 + s3);
}

/* Symbolic factorization: the pattern of every row of [L U] in the new numbering.  K's row i
   (new numbering) is the original row perm[i]; its columns are iperm[kj].  Rows >= nI (the
   interface) are eliminated against the interior columns only.  Returns the number of entries
   (fi, fj filled when fj != NULL), or -1 when cap is too small. */
int64_t plu_symbolic(int n, int nI, const int32_t* perm, const int32_t* iperm,
                     const int32_t* ki, const int32_t* kj,
                     int64_t* fi, int32_t* fj, int64_t* fdiag, int64_t cap)
{
  int32_t* next = malloc(sizeof(int32_t) * (n + 1));
  int64_t nnz = 0;
  fi[0] = 0;
  for (int i = 0; i < n; ++i) {
    int head = n;
    next[head] = n;   /* sorted linked list of the row's columns, ended by n */
    int32_t r = perm[i];
    for (int32_t p = ki[r]; p < ki[r + 1]; ++p) {
      int c = iperm[kj[p]];
      int prev = head;
      while (next[prev] < c) prev = next[prev];
      if (next[prev] != c) { next[c] = next[prev]; next[prev] = c; }
    }
    if (i < nI) {   /* the diagonal is always in the pattern */
      int prev = head;
      while (next[prev] < i) prev = next[prev];
      if (next[prev] != i) { next[i] = next[prev]; next[prev] = i; }
    }
    int limit = i < nI ? i : nI;
    for (int k = next[head]; k < limit; k = next[k]) {
      /* merge the U part of row k (columns > k) */
      int prev = k;
      for (int64_t p = fdiag[k] + 1; p < fi[k + 1]; ++p) {
        int c = fj[p];
        while (next[prev] < c) prev = next[prev];
        if (next[prev] != c) { next[c] = next[prev]; next[prev] = c; }
        prev = c;
      }
    }
    for (int c = next[head]; c < n; c = next[c]) {
      if (nnz >= cap) { free(next); return -1; }
      fj[nnz] = c;
      if (c == i) fdiag[i] = nnz;
      ++nnz;
    }
    if (i >= nI) fdiag[i] = -1;
    fi[i + 1] = nnz;
  }
  free(next);
  return nnz;
}

/* The factor is kept split for the sweeps: the L rows in row order (lp, lj, la), the U rows of
   the interior (1 / u_ii first, then the columns > i) in reverse row order (up[i] = start of row
   i, uend[i] its end; ascending addresses for the backward sweep), the corner T dense. */

/* The pattern of K + K^T on the interior (rows and columns 0..nI-1 of K's CSR ki, kj), each row sorted: the
   graph the fill-reducing orders take.  gi (nI + 1) and gj (room for twice K's interior entries) receive it;
   t (nI + 1), tj (K's interior entries) and mark (nI) are work.  Returns its number of entries. */
int64_t plu_graph(int nI, const int32_t* ki, const int32_t* kj, int64_t* gi, int32_t* gj,
                  int64_t* t, int32_t* tj, int32_t* mark)
{
  /* K^T's interior rows by counting: its row c holds the rows r with an entry K_rc, ascending */
  for (int c = 0; c <= nI; ++c) t[c] = 0;
  for (int r = 0; r < nI; ++r)
    for (int32_t p = ki[r]; p < ki[r + 1]; ++p)
      if (kj[p] < nI) t[kj[p] + 1]++;
  for (int c = 0; c < nI; ++c) t[c + 1] += t[c];
  for (int r = 0; r < nI; ++r)
    for (int32_t p = ki[r]; p < ki[r + 1]; ++p)
      if (kj[p] < nI) tj[t[kj[p]]++] = r;
  for (int c = nI; c > 0; --c) t[c] = t[c - 1];   /* (the fill moved each start to the next row's) */
  t[0] = 0;
  /* row r: the columns of K's row and of K^T's, each once, sorted (insertion: rows hold tens, and K's
     pattern is nearly symmetric, so K^T adds few) */
  for (int c = 0; c < nI; ++c) mark[c] = -1;
  int64_t nnz = 0;
  gi[0] = 0;
  for (int r = 0; r < nI; ++r) {
    int64_t start = nnz;
    for (int32_t p = ki[r]; p < ki[r + 1]; ++p) {
      int c = kj[p];
      if (c < nI && mark[c] != r) { mark[c] = r; gj[nnz++] = c; }
    }
    for (int64_t p = t[r]; p < t[r + 1]; ++p) {
      int c = tj[p];
      if (mark[c] != r) { mark[c] = r; gj[nnz++] = c; }
    }
    for (int64_t a = start + 1; a < nnz; ++a) {
      int32_t v = gj[a];
      int64_t b = a - 1;
      while (b >= start && gj[b] > v) { gj[b + 1] = gj[b]; --b; }
      gj[b + 1] = v;
    }
    gi[r + 1] = nnz;
  }
  return nnz;
}

/* The graph's rows and columns r with id[r] >= 0, numbered id[r] (increasing with r: each row stays sorted):
   si (its rows + 1) and sj (room for gi[n] entries) receive it.  Returns its number of entries. */
int64_t plu_subgraph(int n, const int64_t* gi, const int32_t* gj, const int32_t* id, int64_t* si, int32_t* sj)
{
  int64_t nnz = 0;
  int k = 0;
  si[0] = 0;
  for (int r = 0; r < n; ++r) {
    if (id[r] < 0) continue;
    for (int64_t p = gi[r]; p < gi[r + 1]; ++p)
      if (id[gj[p]] >= 0) sj[nnz++] = id[gj[p]];
    si[++k] = nnz;
  }
  return nnz;
}

/* Numeric factorization.  K's values: entry p of K is src[p] into (D, O, G) (D: 0..nD-1, O: next
   nO, G: the rest), at the new column kcol[p].  Returns 0, or 1 + the row of a zero pivot. */
int plu_numeric(int n, int nI, const int32_t* perm, const int32_t* ki, const int32_t* kcol, const int64_t* src,
                int64_t nD, int64_t nO, const double* D, const double* O, const double* G,
                const int64_t* lp, const int32_t* lj, double* la,
                const int64_t* up, const int64_t* uend, const int32_t* uj, double* ua,
                double* T, double* w)
{
  int nG = n - nI;
  for (int i = 0; i < n; ++i) {
    for (int64_t q = lp[i]; q < lp[i + 1]; ++q) w[lj[q]] = 0.0;
    if (i < nI) {
      w[i] = 0.0;
      for (int64_t q = up[i] + 1; q < uend[i]; ++q) w[uj[q]] = 0.0;
    } else {
      for (int c = nI; c < n; ++c) w[c] = 0.0;
    }
    int32_t r = perm[i];
    for (int32_t p = ki[r]; p < ki[r + 1]; ++p) {
      int64_t s = src[p];
      w[kcol[p]] += s < nD ? D[s] : (s < nD + nO ? O[s - nD] : G[s - nD - nO]);
    }
    for (int64_t q = lp[i]; q < lp[i + 1]; ++q) {
      int k = lj[q];
      double l = w[k] * ua[up[k]];
      la[q] = l;
      if (l != 0.0)
        for (int64_t t = up[k] + 1; t < uend[k]; ++t) w[uj[t]] -= l * ua[t];
    }
    if (i < nI) {
      double d = w[i];
      if (d == 0.0 || !isfinite(d)) return 1 + i;
      ua[up[i]] = 1.0 / d;
      for (int64_t q = up[i] + 1; q < uend[i]; ++q) ua[q] = w[uj[q]];
    } else {
      for (int c = nI; c < n; ++c) T[(size_t)(i - nI) * nG + (c - nI)] = w[c];
    }
  }
  return 0;
}

/* Forward sweep: x (new numbering, length n) <- [z_I; z_G] from b (row i of the interior read
   at b[where[i]]; the G part of the right-hand side is taken as zero). */
void plu_forward(int n, int nI, const int32_t* where, const int64_t* lp, const int32_t* lj, const double* la,
                 const double* b, double* x)
{
  for (int i = 0; i < nI; ++i) x[i] = b[where[i]] - sparse_dot(lp[i], lp[i + 1], la, lj, x);
  for (int i = nI; i < n; ++i) x[i] = -sparse_dot(lp[i], lp[i + 1], la, lj, x);
}

/* Backward sweep: x[0..nI) <- U_II^{-1} (x_I - U_IG x_G), x[nI..n) holding x_G; out[where] <- x_I. */
void plu_backward(int nI, const int32_t* where, const int64_t* up, const int64_t* uend, const int32_t* uj,
                  const double* ua, double* x, double* out)
{
  for (int i = nI - 1; i >= 0; --i) {
    x[i] = (x[i] - sparse_dot(up[i] + 1, uend[i], ua, uj, x)) * ua[up[i]];
    out[where[i]] = x[i];
  }
}
"""

C_DECL = """
int64_t plu_subgraph(int n, const int64_t* gi, const int32_t* gj, const int32_t* id, int64_t* si, int32_t* sj);
int64_t plu_graph(int nI, const int32_t* ki, const int32_t* kj, int64_t* gi, int32_t* gj,
                  int64_t* t, int32_t* tj, int32_t* mark);
int64_t plu_symbolic(int n, int nI, const int32_t* perm, const int32_t* iperm, const int32_t* ki, const int32_t* kj,
                     int64_t* fi, int32_t* fj, int64_t* fdiag, int64_t cap);
int plu_numeric(int n, int nI, const int32_t* perm, const int32_t* ki, const int32_t* kcol, const int64_t* src,
                int64_t nD, int64_t nO, const double* D, const double* O, const double* G,
                const int64_t* lp, const int32_t* lj, double* la,
                const int64_t* up, const int64_t* uend, const int32_t* uj, double* ua,
                double* T, double* w);
void plu_forward(int n, int nI, const int32_t* where, const int64_t* lp, const int32_t* lj, const double* la,
                 const double* b, double* x);
void plu_backward(int nI, const int32_t* where, const int64_t* up, const int64_t* uend, const int32_t* uj,
                  const double* ua, double* x, double* out);
"""


def interior_graph(ki, kj, nI):
    """The pattern of K + K^T on the interior (K's CSR ki, kj; rows and columns 0..nI-1) as a scipy CSR matrix
    of ones, each row sorted (C: scipy's sum with the transpose and its sort took 0.4-0.9 s on a rank's half of
    10^5 planar elements)."""
    import scipy.sparse as sp
    mod = cbuild.load("rodfem_partial_lu", C_SOURCE, C_DECL)
    ki, kj = np.ascontiguousarray(ki, np.int32), np.ascontiguousarray(kj, np.int32)
    inner = int(np.count_nonzero(kj[:ki[nI]] < nI))
    gi, gj = np.zeros(nI + 1, np.int64), np.zeros(2 * inner, np.int32)
    t, tj, mark = np.zeros(nI + 1, np.int64), np.zeros(max(inner, 1), np.int32), np.zeros(max(nI, 1), np.int32)
    p = lambda a, kind: mod.ffi.from_buffer(f"{kind}[]", a)   # noqa: E731
    nnz = mod.lib.plu_graph(nI, p(ki, "int32_t"), p(kj, "int32_t"), p(gi, "int64_t"), p(gj, "int32_t"),
                            p(t, "int64_t"), p(tj, "int32_t"), p(mark, "int32_t"))
    graph = sp.csr_matrix((np.ones(nnz), gj[:nnz], gi), shape=(nI, nI))
    graph.has_sorted_indices = True
    return graph


def subgraph(graph, keep):
    """The rows and columns `keep` (ascending) of a graph (scipy CSR, rows sorted), renumbered 0, 1, ...
    (C; scipy's `graph[keep][:, keep]` took 0.15-0.7 s on a rank's half of 10^5 planar elements)."""
    import scipy.sparse as sp
    mod = cbuild.load("rodfem_partial_lu", C_SOURCE, C_DECL)
    n = graph.shape[0]
    ids = np.full(n, -1, np.int32)
    ids[keep] = np.arange(len(keep), dtype=np.int32)
    gi, gj = np.ascontiguousarray(graph.indptr, np.int64), np.ascontiguousarray(graph.indices, np.int32)
    si, sj = np.zeros(len(keep) + 1, np.int64), np.zeros(max(int(gi[-1]), 1), np.int32)
    p = lambda a, kind: mod.ffi.from_buffer(f"{kind}[]", a)   # noqa: E731
    nnz = mod.lib.plu_subgraph(n, p(gi, "int64_t"), p(gj, "int32_t"), p(ids, "int32_t"), p(si, "int64_t"),
                               p(sj, "int32_t"))
    out = sp.csr_matrix((np.ones(nnz), sj[:nnz], si), shape=(len(keep), len(keep)))
    out.has_sorted_indices = True
    return out


def interior_orders(ki, kj, nI, nG, tries, postpone=None):
    """For each (method, reverse) of `tries`, in turn (a generator: an order not asked for is not made): a
    fill-reducing order of the interior (K's rows 0..nI-1) by PETSc (method: rcm, nd, amd; reverse: turned
    round), the interior dofs that couple to the interface G next, G (rows nI..) last.  The graph is built
    and each method's order found once (the three tries of a rank's half of 10^5 planar elements took
    1.0 s when each built its own).

    `postpone` (bool, interior rows): dofs with a zero diagonal (multipliers of constraints) are
    left out of the fill-reducing order and placed after their partners (below): their pivot is
    then the Schur complement -B A^{-1} B^T of the dofs they constrain, not zero (the LU does not
    pivot).  (Ordered with the rest, the multipliers cost the 3D rod's RCM band 40 % more fill.)"""
    import scipy.sparse as sp
    from petsc4py import PETSc
    from scipy.sparse.csgraph import connected_components
    n = nI + nG
    graph = interior_graph(ki, kj, nI)

    def petsc_order(g, kind):
        csr = (g.indptr.astype(PETSc.IntType), g.indices.astype(PETSc.IntType), np.ones(g.nnz))
        M = PETSc.Mat().createAIJWithArrays(g.shape, csr, comm=PETSc.COMM_SELF)   # (csr's arrays, not a copy)
        rows, _ = M.getOrdering(kind)
        order = np.asarray(rows.getIndices(), dtype=np.int64)
        M.destroy()
        return order

    # the fill-reducing order of the dofs with a pivot of their own that do not couple to the
    # interface; those that do come last (an interface row's fill is then the U rows of these
    # only), the postponed ones are placed after their partners below.  (Keeping the dofs next to
    # the interface last costs AMD fill: 4.1 on a rank's half of the 3D rod at 1024 elements,
    # against 2.8 for the same block without them last; RCM, 3.7, is then chosen.)
    near = np.zeros(nI, bool)
    if nG:   # (rows with an entry in an interface column, columns of an interface row's entries)
        near[np.searchsorted(ki, np.flatnonzero(kj[:ki[nI]] >= nI), side="right") - 1] = True
        cols = kj[ki[nI]:]
        near[cols[cols < nI]] = True
    held = np.zeros(nI, bool) if postpone is None else np.asarray(postpone, bool).copy()
    own = np.flatnonzero(~held & ~near)
    g = subgraph(graph, own)
    if held.any():
        # bodies joined only by multipliers (the strings of a net) are apart in the graph without them, and
        # the orders miss the fill their multipliers make: there the dofs a postponed dof constrains are
        # coupled through it (B^T B).  (A rank's half of a 20 x 20 cable net: AMD's factor 3.7e6 entries,
        # 4.3e5 with them.  Where the multipliers join no parts, the order stays as it was: with the edges,
        # three rods in frictional contact took 228 Newton iterations on Debian 13, against 157.)
        B = graph[np.flatnonzero(held)][:, own]
        coupled = (g + B.T @ B).tocsr()
        if connected_components(coupled, directed=False)[0] < connected_components(g, directed=False)[0]:
            g = coupled
    g.sort_indices()
    found = {}

    def order_of(method):
        if method not in found:
            if method == "nd":   # nested dissection of the graph in RCM order (its tie-breaks follow the chain)
                first = petsc_order(g, "rcm")
                h = g[first][:, first].tocsr()
                h.sort_indices()
                found[method] = own[first[petsc_order(h, "nd")]]
            else:
                found[method] = own[petsc_order(g, method)]
        return found[method]

    pairs = None
    for method, reverse in tries:
        order = order_of(method)
        if reverse:
            order = order[::-1]
        order = np.concatenate([np.flatnonzero(held & ~near), order, np.flatnonzero(near)])
        if postpone is not None and np.any(postpone):
            # in rounds: a postponed dof goes right after the last of its partners placed so far, the
            # dofs k with K_zk and K_kz both nonzero (only those give its pivot a term -K_zk K_kz / u_kk)
            # (round k adds 2^-k: a massless director rate after the stresses it couples to, then a
            # multiplier that constrains only that rate after it)
            if pairs is None:
                K = sp.csr_matrix((np.ones(len(kj)), kj, ki), shape=(n, n))[:nI, :nI]
                pairs = K.multiply(K.T).tocsr()
                rows = np.repeat(np.arange(nI), np.diff(pairs.indptr))
            position = np.empty(nI, np.float64)
            position[order] = np.arange(nI)
            placed = ~np.asarray(postpone, bool)
            for k in range(1, 30):
                waiting = ~placed[rows] & placed[pairs.indices]
                if not waiting.any():
                    break
                last = np.full(nI, -np.inf)
                np.maximum.at(last, rows[waiting], position[pairs.indices[waiting]])
                now = np.isfinite(last) & ~placed
                position[now] = last[now] + 0.5 ** k
                placed |= now
            order = np.argsort(position, kind="stable")
        yield np.concatenate([order, np.arange(nI, n)]).astype(np.int32)


# The orders and factor patterns of the last KEEP matrix patterns factored in this process, by
# pattern: a system built again (a parameter study, a scene run again) or a second Newton on the
# same matrix pattern skips the ordering and symbolic factorization (a 16-element 3D rod: ~10 ms,
# most of a 10-step run's set-up).  The numeric factor is always made afresh.
# An order whose factor has at most NO_BETTER times the entries of K (and its diagonal) ends the tries.
NO_BETTER = 1.02
SYMBOLIC = ("perm", "iperm", "bidx", "lj", "lp", "uj", "up", "uend", "kcol", "nnz")
KEEP = 8
_SYMBOLIC = {}


def _pattern_key(ki, kj, src, nI, nG, method, where, postpone):
    """A digest of everything the order and the factor's pattern depend on."""
    import hashlib
    h = hashlib.sha256()   # (SHA-256: 1.8 GB/s here with the CPU's SHA instructions, BLAKE2b 0.8)
    for a in (ki, kj, src, where, postpone):
        if a is not None:
            a = np.ascontiguousarray(a)
            h.update(str((a.dtype, a.shape)).encode())
            h.update(a)   # (the array's own memory: no copy)
        else:
            h.update(b"-")
    return (int(nI), int(nG), str(method), h.hexdigest())


class PartialLU:
    """LU of K (CSR ki, kj: interior rows 0..nI-1, interface rows nI..nI+nG-1) with the interface
    eliminated last; `src` maps K's entries to the value arrays (D, O, G) given at `factor` (None:
    entry p of K is entry p of D)."""

    def __init__(self, ki, kj, nI, nG, src, nD, nO, method="rcm", where=None, postpone=None):
        self.mod = cbuild.load("rodfem_partial_lu", C_SOURCE, C_DECL)
        self.n, self.nI, self.nG = nI + nG, nI, nG
        self.ki, self.kj = np.ascontiguousarray(ki, np.int32), np.ascontiguousarray(kj, np.int32)
        # (src None: K's entries are D's, in order; where None: K's rows at 0..nI-1.  Digested as such)
        self.src = np.arange(len(self.kj), dtype=np.int64) if src is None else np.ascontiguousarray(src, np.int64)
        self.nD, self.nO = int(nD), int(nO)
        self.method = method
        key = _pattern_key(self.ki, self.kj, src, nI, nG, method, where, postpone)
        if key in _SYMBOLIC:   # (the same pattern met before in this process: its order and factor pattern)
            self.__dict__.update(_SYMBOLIC[key])
            self._workspace()
            return
        # The fill of a band order depends on its direction (K's pattern is not symmetric) and on
        # where the interface is: on the 3D rod's Jacobian (1024 elements) RCM gives 3.7 or 8.1
        # entries of the factor per entry of K on each of two ranks, AMD 4.1; on one rank RCM
        # 6.8 either way, AMD 2.8.  So "rcm" tries these three orders and keeps the least fill.
        best = None
        # Without an interface (one rank: the serial LU chain) AMD alone: the band orders' tries cost
        # two more symbolic factorizations (a 16-element 3D rod: 46 instead of 15 ms, a third of a
        # 10-step run) for more fill.
        tries = (("rcm", False), ("amd", False), ("rcm", True)) if method == "rcm" else ((method, False),)
        if method == "rcm" and nG == 0:
            tries = (("amd", False),)
        # No order's factor has fewer entries than K (and its diagonal): an order within NO_BETTER of that
        # ends the tries (a rank's half of 10^5 planar elements: RCM's factor is K's pattern and 36 entries;
        # AMD's order and count, 0.4 s, and RCM turned round, 0.1-0.2 s, are then not made).
        least = len(self.kj) + int(np.count_nonzero(self._diagonal_missing()[:nI]))
        for self.perm in interior_orders(self.ki, self.kj, nI, nG, tries, postpone):
            self.iperm = np.empty_like(self.perm)
            self.iperm[self.perm] = np.arange(self.n, dtype=np.int32)
            nnz = self._symbolic_count(limit=best[0] if best else None)   # (given up above the best)
            if nnz is not None and (best is None or nnz < best[0]):
                best = (nnz, self.perm, self.iperm, self._pattern)
            if best[0] <= NO_BETTER * least:
                break
        _, self.perm, self.iperm, self._pattern = best
        # where = positions of K's interior rows in the caller's vectors (default: 0..nI-1)
        where = np.arange(nI) if where is None else np.asarray(where)
        self.bidx = np.ascontiguousarray(where[self.perm[:nI]], dtype=np.int32)
        self._symbolic()
        if len(_SYMBOLIC) >= KEEP:
            _SYMBOLIC.pop(next(iter(_SYMBOLIC)))
        _SYMBOLIC[key] = {k: getattr(self, k) for k in SYMBOLIC}

    def _diagonal_missing(self):
        """Per row of K: whether its diagonal entry is absent from K's pattern (an interior row's factor has it)."""
        rows = np.repeat(np.arange(self.n, dtype=np.int32), np.diff(self.ki))
        present = np.zeros(self.n, bool)
        present[rows[self.kj == rows]] = True
        return ~present

    def _symbolic_count(self, limit=None):
        """The factor's pattern in the order perm (C): its number of entries (kept in self._pattern),
        or None if it has more than `limit`."""
        lib = self.mod.lib
        n, nI = self.n, self.nI
        fi = np.zeros(n + 1, np.int64)
        fdiag = np.zeros(n, np.int64)
        cap = 4 * len(self.kj) + n if limit is None else limit
        while True:
            fj = np.zeros(cap, np.int32)
            nnz = lib.plu_symbolic(n, nI, self._p(self.perm, "int32_t"), self._p(self.iperm, "int32_t"),
                                   self._p(self.ki, "int32_t"), self._p(self.kj, "int32_t"),
                                   self._p(fi, "int64_t"), self._p(fj, "int32_t"), self._p(fdiag, "int64_t"), cap)
            if nnz >= 0:
                break
            if limit is not None:
                return None
            cap *= 2
        self._pattern = (self.perm, fi, fj[:nnz])
        return int(nnz)

    def _symbolic(self):
        """The pattern of the factor, split into L rows and reversed U rows (numpy)."""
        n, nI = self.n, self.nI
        if self._pattern[0] is not self.perm:
            self._symbolic_count()
        _, fi, fj = self._pattern
        nnz = len(fj)
        del self._pattern
        rows = np.repeat(np.arange(n), np.diff(fi))
        lower = fj < np.minimum(rows, nI)
        self.lj = np.ascontiguousarray(fj[lower])
        self.lp = np.concatenate([[0], np.cumsum(np.bincount(rows[lower], minlength=n))]).astype(np.int64)
        upper = ~lower & (rows < nI)                    # the interior rows' U parts, diagonal first
        ur, uc = rows[upper], fj[upper]                 # (by row, each row by column: as fj is)
        counts = np.bincount(ur, minlength=nI)[:nI]
        self.uend = np.zeros(nI, np.int64)
        self.uend[::-1] = np.cumsum(counts[::-1])
        self.up = self.uend - counts
        # rows nI-1 ... 0, each by column: row r's k-th entry to up[r] + k (no sort)
        within = np.arange(len(ur), dtype=np.int64) - (np.cumsum(counts) - counts)[ur]
        self.uj = np.empty_like(uc)
        self.uj[self.up[ur] + within] = uc
        self.kcol = np.ascontiguousarray(self.iperm[self.kj], dtype=np.int32)
        self.nnz = int(nnz)
        self._workspace()

    def _workspace(self):
        """The factor's values, the work vectors and the kernels' views of every array."""
        n = self.n
        self.la, self.ua = np.zeros(len(self.lj)), np.zeros(len(self.uj))
        self.w = np.zeros(n)
        self.x = np.zeros(n)
        self.T = np.zeros((self.nG, self.nG))
        # cffi views of the arrays the kernels take, made once (the arrays are not reallocated)
        self.c = {name: self._p(getattr(self, name), kind) for name, kind in (
            ("perm", "int32_t"), ("bidx", "int32_t"), ("ki", "int32_t"), ("kcol", "int32_t"), ("src", "int64_t"),
            ("lp", "int64_t"), ("lj", "int32_t"), ("la", "double"), ("up", "int64_t"), ("uend", "int64_t"),
            ("uj", "int32_t"), ("ua", "double"), ("T", "double"), ("w", "double"), ("x", "double"))}

    def _p(self, a, kind):
        return self.mod.ffi.from_buffer(f"{kind}[]", a)

    @property
    def fill(self):
        """Entries of the factor per entry of K."""
        return self.nnz / max(len(self.kj), 1)

    def factor(self, D, O, G):
        """Factor with the values D, O (addresses or arrays, O may be None) and G (array or None);
        returns the corner T = -A_GI A_II^{-1} A_IG, or None after a zero pivot."""
        ffi, lib = self.mod.ffi, self.mod.lib

        def pointer(a):   # an address (int), an array or None
            if a is None:
                return ffi.NULL
            return ffi.cast("double*", a) if isinstance(a, int) else self._p(np.ascontiguousarray(a), "double")
        dp, op = pointer(D), pointer(O)
        gp = self._p(np.ascontiguousarray(G, dtype=np.float64).reshape(-1), "double") if G is not None and np.size(G) \
            else ffi.NULL
        c = self.c
        status = lib.plu_numeric(self.n, self.nI, c["perm"], c["ki"], c["kcol"], c["src"], self.nD, self.nO,
                                 dp, op, gp, c["lp"], c["lj"], c["la"], c["up"], c["uend"], c["uj"], c["ua"],
                                 c["T"], c["w"])
        return None if status else self.T

    def forward(self, b):
        """z_G = -A_GI A_II^{-1} b_I (b_I read from b at `where`); keeps z_I."""
        c = self.c
        b = np.ascontiguousarray(b, dtype=np.float64)
        self.mod.lib.plu_forward(self.n, self.nI, c["bidx"], c["lp"], c["lj"], c["la"], self._p(b, "double"), c["x"])
        return self.x[self.nI:].copy()

    def backward(self, xG, out):
        """out[where] <- A_II^{-1} (b_I - A_IG x_G), after forward(b)."""
        c = self.c
        self.x[self.nI:] = xG
        self.mod.lib.plu_backward(self.nI, c["bidx"], c["up"], c["uend"], c["uj"], c["ua"], c["x"],
                                  self._p(out, "double"))
