"""Jacobian assembly without PETSc's per-entry search: element matrices added straight into the CSR arrays.

DOLFINx 0.5 adds each element matrix with MatSetValuesLocal, which searches every entry's
column in its row: on these chains that search, not the element kernel, was 90 % of the
Jacobian's cost (planar beam: 2.1 us per element, the kernel 0.1; 3D rod: 160 us per element
in serial, 3-4 us for the planar beam per element in parallel).  Here one small C loop
(compiled once, like the forms, into the JIT cache) calls the form's own compiled kernel
(FFCx's tabulate_tensor) for each cell and adds the element matrix into the value arrays of
the PETSc matrix DOLFINx made: it sorts the element's columns once per cell and walks each
CSR row alongside them.  The result is the matrix DOLFINx assembles, entry by entry (the
same kernel, the same sums; Dirichlet rows and columns dropped and 1 on the diagonal).

In parallel the owned rows go into the diagonal and off-diagonal blocks of the MPIAIJ
matrix; the few entries of rows owned by another rank (the shared node) go through
MatSetValues, which sends them at assembly.

Only the entries that can be nonzero.  DOLFINx's pattern couples every dof of a cell with every
other (the element block of the mixed space), but most of those entries are zero whatever the
state: in the 3D rod a position row couples only to its velocity, a constraint row only to the
director rates of its node.  The pattern kept is the union of the entries that are nonzero at
the initial state and at two random states (every coefficient and constant of the form drawn at
random, at two scales, so that both sides of a conditional are seen), plus the diagonal.  On the
3D rod that is 14 % of DOLFINx's pattern (1024 elements: 1.33 of 9.73 million entries), and the
LU factorization and its solves become 3-4 times cheaper; on the planar beam it is 45 %, where
the denser pattern's identical rows (PETSc's inodes) solve faster, so the pattern is kept only
when it has at most SPARSE_ENOUGH of DOLFINx's entries.  Should an entry outside the pattern
ever be nonzero, it is inserted (the pattern grows; the LU sets itself up again).

`FastJacobian.usable(J)` says whether a form qualifies (cell and exterior-facet integrals,
no dof transformations, 32-bit PETSc indices); otherwise the caller keeps DOLFINx's assembly.
"""
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from rodfem.fem import cbuild, compat, petsc_raw

SPARSE_ENOUGH = 1 / 3   # keep the pattern of possible nonzeros when it has at most this share of DOLFINx's
DRAWS = (1.0, 1e-3)     # scales of the random states that find the possible nonzeros

C_SOURCE = r"""
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define MAXPAT 8
/* an entry for MatSetValues (local row and column); -1: the buffer is full */
#define PUSH(r, c, v) do { if (ng >= gcap) { status = -1; break; } \
                            grow[ng] = (r); gcol[ng] = (c); gval[ng] = (v); ++ng; } while (0)

typedef void (*kernel_t)(double*, const double*, const double*, const double*, const int*, const uint8_t*);

/* Sort the element's columns: idx[k] = local column j, by key (insertion sort: nd is small). */
static void sort_by_key(int n, int32_t* key, int32_t* idx)
{
  for (int a = 1; a < n; ++a) {
    int32_t k = key[a], v = idx[a];
    int b = a - 1;
    while (b >= 0 && key[b] > k) { key[b + 1] = key[b]; idx[b + 1] = idx[b]; --b; }
    key[b + 1] = k; idx[b + 1] = v;
  }
}

/* Add the element matrices of `n` entities (cells, or (cell, local facet) pairs) into the CSR
   blocks.  The nonzero entries the blocks have no place for (rows owned by another rank, or a
   column missing from the row's pattern) go to (grow, gcol, gval), in local indices, for
   MatSetValues.  Returns their number, or -1 if there were more than gcap. */
int rodfem_assemble(int n, const int32_t* cells, const int32_t* facets,
                    uintptr_t kernel_address,
                    int nd, const int32_t* dofs,
                    int nx, const int32_t* xdofs, const double* x,
                    const double* coeffs, int cstride, const double* consts,
                    const int8_t* bc, int nown,
                    const int32_t* di, const int32_t* dj, double* da,
                    const int32_t* oi, const int32_t* oj, double* oa, const int32_t* ghost_col,
                    int32_t* grow, int32_t* gcol, double* gval, int gcap, int roff,
                    const int32_t* cbody, int kstride)
{
  kernel_t kernel = (kernel_t)kernel_address;
  double* Ae = malloc(sizeof(double) * nd * nd);
  double coords[3 * 64];
  int32_t* key_d = malloc(sizeof(int32_t) * nd * 4);
  int32_t* idx_d = key_d + nd;
  int32_t* key_o = key_d + 2 * nd;
  int32_t* idx_o = key_d + 3 * nd;
  int ng = 0, status = 0;
  uint8_t perm = 0;
  int pat_len[MAXPAT];
  const int32_t* pat_cols[MAXPAT];
  int32_t* pat_rank = malloc(sizeof(int32_t) * nd * (MAXPAT + 1));
  for (int e = 0; e < n && status == 0; ++e) {
    int32_t c = cells[e];
    const int32_t* cd = dofs + (size_t)c * nd;
    for (int k = 0; k < nx; ++k)
      for (int d = 0; d < 3; ++d)
        coords[3 * k + d] = x[3 * (size_t)xdofs[(size_t)c * nx + k] + d];
    memset(Ae, 0, sizeof(double) * nd * nd);
    kernel(Ae, coeffs + (size_t)e * cstride, cbody ? consts + (size_t)cbody[e] * kstride : consts, coords,
           facets ? facets + e : NULL, &perm);
    /* columns of this cell: owned ones by local index, ghost ones by their off-diagonal column */
    int nD = 0, nO = 0;
    for (int j = 0; j < nd; ++j) {
      int32_t col = cd[j];
      if (bc[col]) continue;
      if (col < nown) { key_d[nD] = col + roff; idx_d[nD++] = j; }
      else { key_o[nO] = ghost_col[col - nown]; idx_o[nO++] = j; }
    }
    sort_by_key(nD, key_d, idx_d);
    sort_by_key(nO, key_o, idx_o);
    int npat = 0;
    for (int i = 0; i < nd; ++i) {
      int32_t row = cd[i];
      if (bc[row]) continue;
      const double* Ai = Ae + (size_t)i * nd;
      if (row < nown) {
        /* the positions of this cell's columns in the row: rows of the same node share their
           column list, so a list seen before in this cell gives them without a search */
        int start = di[row + roff], len = di[row + roff + 1] - start;
        const int32_t* cols = dj + start;
        int32_t* rank = NULL;
        for (int q = 0; q < npat; ++q)
          if (pat_len[q] == len && (pat_cols[q] == cols || memcmp(pat_cols[q], cols, sizeof(int32_t) * len) == 0)) {
            rank = pat_rank + (size_t)q * nd;
            break;
          }
        if (!rank) {
          rank = pat_rank + (size_t)(npat < MAXPAT ? npat : MAXPAT) * nd;
          int p = 0;   /* merge the sorted keys with the sorted row: -1 where the row lacks a column */
          for (int k = 0; k < nD; ++k) {
            while (p < len && cols[p] < key_d[k]) ++p;
            rank[k] = (p < len && cols[p] == key_d[k]) ? p : -1;
          }
          if (npat < MAXPAT) { pat_len[npat] = len; pat_cols[npat] = cols; ++npat; }
        }
        double* arow = da + start;
        for (int k = 0; k < nD; ++k) {
          double v = Ai[idx_d[k]];
          if (rank[k] >= 0) arow[rank[k]] += v;
          else if (v != 0.0) { PUSH(row, cd[idx_d[k]], v); }
        }
        if (nO) {
          int p = oi[row + roff], end = oi[row + roff + 1];
          for (int k = 0; k < nO; ++k) {
            double v = Ai[idx_o[k]];
            while (p < end && oj[p] < key_o[k]) ++p;
            if (p < end && oj[p] == key_o[k]) oa[p] += v;
            else if (v != 0.0) { PUSH(row, cd[idx_o[k]], v); }
          }
        }
      } else {
        for (int j = 0; j < nd; ++j) {
          if (bc[cd[j]] || Ai[j] == 0.0) continue;
          PUSH(row, cd[j], Ai[j]);
        }
      }
      if (status) break;
    }
  }
  free(Ae);
  free(key_d);
  free(pat_rank);
  return status ? -1 : ng;
}

/* mask[i * nd + j] = 1 where the element matrix of one of the `n` entities has a nonzero entry */
void rodfem_element_pattern(int n, const int32_t* cells, const int32_t* facets, uintptr_t kernel_address,
                            int nd, int nx, const int32_t* xdofs, const double* x,
                            const double* coeffs, int cstride, const double* consts, uint8_t* mask)
{
  kernel_t kernel = (kernel_t)kernel_address;
  double* Ae = malloc(sizeof(double) * nd * nd);
  double coords[3 * 64];
  uint8_t perm = 0;
  for (int e = 0; e < n; ++e) {
    int32_t c = cells[e];
    for (int k = 0; k < nx; ++k)
      for (int d = 0; d < 3; ++d)
        coords[3 * k + d] = x[3 * (size_t)xdofs[(size_t)c * nx + k] + d];
    memset(Ae, 0, sizeof(double) * nd * nd);
    kernel(Ae, coeffs + (size_t)e * cstride, consts, coords, facets ? facets + e : NULL, &perm);
    for (int k = 0; k < nd * nd; ++k)
      if (Ae[k] != 0.0) mask[k] = 1;   /* (a NaN counts) */
  }
  free(Ae);
}

void rodfem_set(double* a, int n, const int64_t* positions, double value)
{
  for (int k = 0; k < n; ++k) a[positions[k]] = value;
}

/* b[dofs of the entity] += element vector, for `n` entities of many bodies (rodfem/fem/batch.py):
   entity e's coefficients at coeffs + e * cstride, its constants at consts + cbody[e] * kstride */
void rodfem_batch_vector(int n, const int32_t* cells, const int32_t* facets, uintptr_t kernel_address,
                         int nd, const int32_t* dofs, int nx, const int32_t* xdofs, const double* x,
                         const double* coeffs, int cstride, const double* consts, const int32_t* cbody,
                         int kstride, double* b)
{
  kernel_t kernel = (kernel_t)kernel_address;
  double be[512];
  double coords[3 * 64];
  uint8_t perm = 0;
  for (int e = 0; e < n; ++e) {
    int32_t c = cells[e];
    for (int k = 0; k < nx; ++k)
      for (int d = 0; d < 3; ++d)
        coords[3 * k + d] = x[3 * (size_t)xdofs[(size_t)c * nx + k] + d];
    memset(be, 0, sizeof(double) * nd);
    kernel(be, coeffs + (size_t)e * cstride, consts + (size_t)cbody[e] * kstride, coords, facets ? facets + e : NULL, &perm);
    const int32_t* cd = dofs + (size_t)c * nd;
    for (int i = 0; i < nd; ++i) b[cd[i]] += be[i];
  }
}

/* out[cbody[e]] += the functional's value on entity e (one number per body) */
void rodfem_batch_scalar(int n, const int32_t* cells, const int32_t* facets, uintptr_t kernel_address,
                         int nx, const int32_t* xdofs, const double* x,
                         const double* coeffs, int cstride, const double* consts, const int32_t* cbody,
                         int kstride, double* out)
{
  kernel_t kernel = (kernel_t)kernel_address;
  double coords[3 * 64];
  uint8_t perm = 0;
  for (int e = 0; e < n; ++e) {
    int32_t c = cells[e];
    for (int k = 0; k < nx; ++k)
      for (int d = 0; d < 3; ++d)
        coords[3 * k + d] = x[3 * (size_t)xdofs[(size_t)c * nx + k] + d];
    kernel(out + cbody[e], coeffs + (size_t)e * cstride, consts + (size_t)cbody[e] * kstride, coords,
           facets ? facets + e : NULL, &perm);   /* the kernel adds to its body's sum, as in DOLFINx */
  }
}

/* Jobs of a batch (rodfem/fem/batch.py), each in one call.  job_inputs: the constants' and the
   other coefficients' values copied in (segments k: to[off[k]:off[k] + len[k]] <- the array at
   ptr[k]), X into S[0:size]; job_gather: integral i's coefficients, coeffs[k] = S[index[k]]. */
static void job_inputs(int nc, const uintptr_t* cptr, const int64_t* coff, const int64_t* clen, double* consts,
                       int no, const uintptr_t* optr, const int64_t* ooff, const int64_t* olen, double* S,
                       int64_t size, const double* X)
{
  for (int k = 0; k < nc; ++k) memcpy(consts + coff[k], (const double*)cptr[k], sizeof(double) * clen[k]);
  for (int k = 0; k < no; ++k) memcpy(S + ooff[k], (const double*)optr[k], sizeof(double) * olen[k]);
  memcpy(S, X, sizeof(double) * size);
}

static double* job_gather(int i, const int64_t* n, const uintptr_t* coeffs, const int64_t* cstride,
                          const uintptr_t* index, const double* S)
{
  double* c = (double*)coeffs[i];
  const int64_t* idx = (const int64_t*)index[i];
  const int64_t m = n[i] * cstride[i];
  for (int64_t k = 0; k < m; ++k) c[k] = S[idx[k]];
  return c;
}

/* A functional: integral by integral its kernel run into sums (one per body), total += sums, as
   rodfem_batch_scalar and numpy did it one call each. */
void rodfem_scalar_job(int nc, const uintptr_t* cptr, const int64_t* coff, const int64_t* clen, double* consts,
                       int no, const uintptr_t* optr, const int64_t* ooff, const int64_t* olen, double* S,
                       int64_t size, const double* X,
                       int ni, const int64_t* n, const uintptr_t* cells, const uintptr_t* facets,
                       const uintptr_t* address, const uintptr_t* coeffs, const int64_t* cstride,
                       const uintptr_t* index, const uintptr_t* body, const uintptr_t* sums,
                       int nx, const int32_t* xdofs, const double* x, int kstride, int nb, double* total)
{
  job_inputs(nc, cptr, coff, clen, consts, no, optr, ooff, olen, S, size, X);
  for (int b = 0; b < nb; ++b) total[b] = 0.0;
  for (int i = 0; i < ni; ++i) {
    const double* c = job_gather(i, n, coeffs, cstride, index, S);
    double* s = (double*)sums[i];
    for (int b = 0; b < nb; ++b) s[b] = 0.0;
    rodfem_batch_scalar((int)n[i], (const int32_t*)cells[i], (const int32_t*)facets[i], address[i], nx, xdofs, x,
                        c, (int)cstride[i], consts, (const int32_t*)body[i], kstride, s);
    for (int b = 0; b < nb; ++b) total[b] += s[b];
  }
}

/* A Jacobian: every integral's element matrices added by rodfem_assemble (integral by integral, the
   entries without a place after one another in grow, gcol, gval); their number, or -1 if gcap was too small. */
int rodfem_matrix_job(int nc, const uintptr_t* cptr, const int64_t* coff, const int64_t* clen, double* consts,
                      int no, const uintptr_t* optr, const int64_t* ooff, const int64_t* olen, double* S,
                      int64_t size, const double* X,
                      int ni, const int64_t* n, const uintptr_t* cells, const uintptr_t* facets,
                      const uintptr_t* address, const uintptr_t* coeffs, const int64_t* cstride,
                      const uintptr_t* index, const uintptr_t* body,
                      int nd, const int32_t* dofs, int nx, const int32_t* xdofs, const double* x, int kstride,
                      const int8_t* bc, int nown, const int32_t* di, const int32_t* dj, double* da,
                      const int32_t* ghost_col, int32_t* grow, int32_t* gcol, double* gval, int gcap)
{
  job_inputs(nc, cptr, coff, clen, consts, no, optr, ooff, olen, S, size, X);
  int total = 0;
  for (int i = 0; i < ni; ++i) {
    const double* c = job_gather(i, n, coeffs, cstride, index, S);
    int ng = rodfem_assemble((int)n[i], (const int32_t*)cells[i], (const int32_t*)facets[i], address[i], nd, dofs,
                             nx, xdofs, x, c, (int)cstride[i], consts, bc, nown, di, dj, da, NULL, NULL, NULL,
                             ghost_col, grow + total, gcol + total, gval + total, gcap - total, 0,
                             (const int32_t*)body[i], kstride);
    if (ng < 0)
      return -1;
    total += ng;
  }
  return total;
}

/* A residual: out[rows] += every integral's element vectors (rodfem_batch_vector, integral by integral). */
void rodfem_vector_job(int nc, const uintptr_t* cptr, const int64_t* coff, const int64_t* clen, double* consts,
                       int no, const uintptr_t* optr, const int64_t* ooff, const int64_t* olen, double* S,
                       int64_t size, const double* X,
                       int ni, const int64_t* n, const uintptr_t* cells, const uintptr_t* facets,
                       const uintptr_t* address, const uintptr_t* coeffs, const int64_t* cstride,
                       const uintptr_t* index, const uintptr_t* body,
                       int nd, const int32_t* dofs, int nx, const int32_t* xdofs, const double* x, int kstride,
                       double* out)
{
  job_inputs(nc, cptr, coff, clen, consts, no, optr, ooff, olen, S, size, X);
  for (int i = 0; i < ni; ++i) {
    const double* c = job_gather(i, n, coeffs, cstride, index, S);
    rodfem_batch_vector((int)n[i], (const int32_t*)cells[i], (const int32_t*)facets[i], address[i], nd, dofs, nx,
                        xdofs, x, c, (int)cstride[i], consts, (const int32_t*)body[i], kstride, out);
  }
}
"""

C_DECL = """
int rodfem_assemble(int n, const int32_t* cells, const int32_t* facets, uintptr_t kernel_address,
                    int nd, const int32_t* dofs, int nx, const int32_t* xdofs, const double* x,
                    const double* coeffs, int cstride, const double* consts,
                    const int8_t* bc, int nown,
                    const int32_t* di, const int32_t* dj, double* da,
                    const int32_t* oi, const int32_t* oj, double* oa, const int32_t* ghost_col,
                    int32_t* grow, int32_t* gcol, double* gval, int gcap, int roff,
                    const int32_t* cbody, int kstride);
void rodfem_element_pattern(int n, const int32_t* cells, const int32_t* facets, uintptr_t kernel_address,
                            int nd, int nx, const int32_t* xdofs, const double* x,
                            const double* coeffs, int cstride, const double* consts, uint8_t* mask);
void rodfem_set(double* a, int n, const int64_t* positions, double value);
void rodfem_batch_vector(int n, const int32_t* cells, const int32_t* facets, uintptr_t kernel_address,
                         int nd, const int32_t* dofs, int nx, const int32_t* xdofs, const double* x,
                         const double* coeffs, int cstride, const double* consts, const int32_t* cbody,
                         int kstride, double* b);
void rodfem_batch_scalar(int n, const int32_t* cells, const int32_t* facets, uintptr_t kernel_address,
                         int nx, const int32_t* xdofs, const double* x,
                         const double* coeffs, int cstride, const double* consts, const int32_t* cbody,
                         int kstride, double* out);
void rodfem_scalar_job(int nc, const uintptr_t* cptr, const int64_t* coff, const int64_t* clen, double* consts,
                       int no, const uintptr_t* optr, const int64_t* ooff, const int64_t* olen, double* S,
                       int64_t size, const double* X,
                       int ni, const int64_t* n, const uintptr_t* cells, const uintptr_t* facets,
                       const uintptr_t* address, const uintptr_t* coeffs, const int64_t* cstride,
                       const uintptr_t* index, const uintptr_t* body, const uintptr_t* sums,
                       int nx, const int32_t* xdofs, const double* x, int kstride, int nb, double* total);
int rodfem_matrix_job(int nc, const uintptr_t* cptr, const int64_t* coff, const int64_t* clen, double* consts,
                      int no, const uintptr_t* optr, const int64_t* ooff, const int64_t* olen, double* S,
                      int64_t size, const double* X,
                      int ni, const int64_t* n, const uintptr_t* cells, const uintptr_t* facets,
                      const uintptr_t* address, const uintptr_t* coeffs, const int64_t* cstride,
                      const uintptr_t* index, const uintptr_t* body,
                      int nd, const int32_t* dofs, int nx, const int32_t* xdofs, const double* x, int kstride,
                      const int8_t* bc, int nown, const int32_t* di, const int32_t* dj, double* da,
                      const int32_t* ghost_col, int32_t* grow, int32_t* gcol, double* gval, int gcap);
void rodfem_vector_job(int nc, const uintptr_t* cptr, const int64_t* coff, const int64_t* clen, double* consts,
                       int no, const uintptr_t* optr, const int64_t* ooff, const int64_t* olen, double* S,
                       int64_t size, const double* X,
                       int ni, const int64_t* n, const uintptr_t* cells, const uintptr_t* facets,
                       const uintptr_t* address, const uintptr_t* coeffs, const int64_t* cstride,
                       const uintptr_t* index, const uintptr_t* body,
                       int nd, const int32_t* dofs, int nx, const int32_t* xdofs, const double* x, int kstride,
                       double* out);
"""

def form_integrals(form):
    """[(integral type, id, kernel address, cells, local facets or None)] of a compiled form, cell
    integrals first (the order of DOLFINx's assembly)."""
    from dolfinx.fem import IntegralType
    ffi = cbuild.load("rodfem_fastasm", C_SOURCE, C_DECL, form.mesh.comm).ffi
    codes = {IntegralType.cell: 0, IntegralType.exterior_facet: 1}
    out = []
    for itype in sorted(form.integral_types, key=lambda t: codes[t]):
        for i in compat.integral_ids(form, itype):
            address = int(ffi.cast("uintptr_t", compat.kernel(form, itype, i).tabulate_tensor_float64))
            dom = np.asarray(compat.integration_domain(form, itype, i), dtype=np.int32)
            if itype == IntegralType.cell:
                cells, facets = np.ascontiguousarray(dom.reshape(-1)), None
            else:
                dom = dom.reshape(-1, 2)
                cells, facets = np.ascontiguousarray(dom[:, 0]), np.ascontiguousarray(dom[:, 1])
            out.append((itype, i, address, cells, facets))
    return out


def structure(A):
    """(diagonal block, off-diagonal block or None, its global columns) of A's structure, copied once."""
    Ad, Ao, garray = petsc_raw.blocks(A)
    return _Block(Ad), (_Block(Ao) if Ao is not None else None), garray


class _Block:
    """A sequential AIJ block: its structure (copied once) and its values (open/close)."""

    def __init__(self, handle):
        self.i, self.j = petsc_raw.rowij(handle)
        self.values = petsc_raw.Values(handle)

    def open(self):
        return self.values.open()

    def close(self):
        self.values.close()


class FastJacobian:
    """Assembles the compiled bilinear form `J` (Dirichlet conditions `bcs`) into its block of a
    PETSc matrix (rodfem/fem/assembly.py) without MatSetValues for the owned rows.

        fast = FastJacobian(J, bcs)
        rows, cols = fast.entries()      # local dofs: the entries the matrix must hold
        fast.attach(A, row_offset, l2g)  # the block starts at local row row_offset; l2g: dof -> global
        fast.add(A)                      # after A.zeroEntries(), before A.assemble()
    """

    @staticmethod
    def usable(J):
        from dolfinx.fem import IntegralType
        V0, V1 = J.function_spaces
        return (petsc_raw.usable() and V0 == V1 and not V0.element.needs_dof_transformations
                and V0.dofmap.index_map_bs == 1 and V0.dofmap.bs == 1
                and set(J.integral_types) <= {IntegralType.cell, IntegralType.exterior_facet})

    def __init__(self, J, bcs):
        self.J, self.bcs = J, list(bcs)
        V = J.function_spaces[0]
        self.mod = cbuild.load("rodfem_fastasm", C_SOURCE, C_DECL, V.mesh.comm)
        self.V = V
        mesh = V.mesh
        self.dofs = np.ascontiguousarray(compat.dofmap_array(V.dofmap), dtype=np.int32).reshape(-1)
        self.nd = V.dofmap.dof_layout.num_dofs
        xdofs = compat.geometry_dofmap(mesh)
        self.xdofs = np.ascontiguousarray(xdofs, dtype=np.int32).reshape(-1)
        self.nx = xdofs.shape[1] if xdofs.size else 0   # (a rank without cells: none)
        assert self.nx <= 64
        im = V.dofmap.index_map
        self.nown, nghost = im.size_local, im.num_ghosts
        bc = np.zeros(self.nown + nghost, np.int8)
        for b in self.bcs:
            idx = b.dof_indices()[0]
            bc[idx] = 1
        self.bc = bc
        self.bc_rows = np.flatnonzero(bc[:self.nown]).astype(np.int32)
        self.integrals = form_integrals(J)
        self.comm = mesh.comm
        masks = self._element_masks()
        share = self.comm.allreduce(max((m.mean() for m in masks), default=1.0), op=MPI.MAX)
        # the pattern of possible nonzeros where it is sparse enough, else every element coupling
        # (DOLFINx's pattern: its identical rows solve faster, PETSc's inodes)
        # dense also on a mesh of one cell (a rigid body): its element block is small, and dense it
        # gives PETSc's LU nonzero pivots for its constraint multipliers (crane-payload: RCM's LU instead
        # of a zero pivot and the next stage of the chain, 1.0 instead of 1.9 ms per step for the solves)
        one_cell = mesh.topology.index_map(mesh.topology.dim).size_global == 1
        self.dense = share > SPARSE_ENOUGH or one_cell
        self.masks = [np.ones_like(m) for m in masks] if self.dense else masks
        self.A, self.roff = None, 0

    def entries(self):
        """(rows, cols): local dofs of the entries the matrix must hold: the element masks' entries
        of every cell (rows of ghost dofs included: their owner holds them) without the Dirichlet
        rows and columns (kept in DOLFINx's dense pattern, as its assembly leaves them), and the
        owned diagonal."""
        cell_dofs = self.dofs.reshape(-1, self.nd)
        rows, cols = [np.arange(self.nown, dtype=np.int32)], [np.arange(self.nown, dtype=np.int32)]
        for (*_, cells, _), mask in zip(self.integrals, self.masks):
            I, J = np.nonzero(mask)
            cd = cell_dofs[cells]
            r, c = cd[:, I].ravel(), cd[:, J].ravel()
            keep = slice(None) if self.dense else (self.bc[r] == 0) & (self.bc[c] == 0)
            rows.append(r[keep])
            cols.append(c[keep])
        return np.concatenate(rows), np.concatenate(cols)

    def attach(self, A, row_offset, l2g, shared=None):
        """Assemble into A from now on: this form's owned rows start at local row `row_offset` of A,
        l2g maps its local dofs (owned and ghosts) to A's global indices.  (`shared`: A's
        `structure(A)`, read once for many forms.)"""
        self.A, self.roff = A, int(row_offset)
        self.l2g = np.asarray(l2g).astype(PETSc.IntType)
        self._structure(shared)

    def restructure(self, shared=None):
        """Re-read A's structure after entries outside it were inserted."""
        self._structure(shared)

    def _structure(self, shared=None):
        """The CSR structure of A's blocks, where the columns of the ghost dofs are, the diagonal
        positions of the Dirichlet rows, a buffer for the entries that go through MatSetValues."""
        self.diag, self.off, garray = shared or structure(self.A)
        self.ghost_col = np.zeros(1, np.int32)
        if self.off is not None:
            ghosts = np.asarray(self.l2g[self.nown:], dtype=np.int64)
            pos = np.searchsorted(garray, ghosts)
            ok = pos < len(garray)
            ok[ok] = garray[pos[ok]] == ghosts[ok]
            if len(ghosts):   # a ghost column no owned row references stays -1 (never found)
                self.ghost_col = np.where(ok, pos, -1).astype(np.int32)
        # diagonal positions of the Dirichlet rows (1 on the diagonal, as DOLFINx's insert_diagonal)
        d = self.diag
        rows = self.bc_rows + self.roff
        self.bc_diag = np.array([d.i[r] + np.flatnonzero(d.j[d.i[r]:d.i[r + 1]] == r)[0] for r in rows],
                                dtype=np.int64)
        if not hasattr(self, "gcap"):   # ghost-row buffer: every entry of the cells that touch a ghost row
            touches = (self.dofs.reshape(-1, self.nd) >= self.nown).any(axis=1)
            ntouch = sum(int(np.count_nonzero(touches[cells])) for _, _, _, cells, _ in self.integrals)
            self._buffer(max(ntouch * self.nd * self.nd, 1))
        self.__dict__.pop("_static", None)

    def _buffer(self, capacity):
        self.gcap = capacity
        self.grow = np.zeros(capacity, np.int32)
        self.gcol = np.zeros(capacity, np.int32)
        self.gval = np.zeros(capacity)
        self.__dict__.pop("_static", None)

    # -- the pattern of possible nonzeros -------------------------------------------------
    def _element_masks(self):
        """Per integral, the entries of its element matrices that are nonzero on some cell at the
        current state or at a random one (every coefficient and constant drawn, at the scales DRAWS)."""
        ffi, lib = self.mod.ffi, self.mod.lib
        coeffs, consts = self._packed()
        rng = np.random.default_rng(20261122)
        draws = [(coeffs, consts)] + [({k: scale * rng.standard_normal(c.shape) for k, c in coeffs.items()},
                                       scale * rng.standard_normal(consts.shape)) for scale in DRAWS]
        x = np.ascontiguousarray(self.V.mesh.geometry.x, dtype=np.float64)
        masks = []
        for itype, i, address, cells, facets in self.integrals:
            mask = np.zeros(self.nd * self.nd, np.uint8)
            for c, k in draws:
                c = np.ascontiguousarray(c[(itype, i)], dtype=np.float64)
                cstride = c.shape[1] if c.ndim == 2 else 0
                lib.rodfem_element_pattern(
                    len(cells), ffi.from_buffer("int32_t[]", cells),
                    ffi.from_buffer("int32_t[]", facets) if facets is not None else ffi.NULL, address,
                    self.nd, self.nx, ffi.from_buffer("int32_t[]", self.xdofs), ffi.from_buffer("double[]", x),
                    ffi.from_buffer("double[]", c if c.size else np.zeros(1)), cstride,
                    ffi.from_buffer("double[]", k if k.size else np.zeros(1)), ffi.from_buffer("uint8_t[]", mask))
            masks.append(mask.reshape(self.nd, self.nd).astype(bool))
        return masks

    # -- assembly -------------------------------------------------------------------------
    def _arguments(self):
        """The arguments of rodfem_assemble that do not change between assemblies (pointers kept alive)."""
        ffi = self.mod.ffi
        buf = lambda kind, a: ffi.from_buffer(kind, a)  # noqa: E731
        self._keep = [self.dofs, self.xdofs, self.bc, self.diag.i, self.diag.j, self.ghost_col,
                      self.grow, self.gcol, self.gval, self.bc_diag]
        off = self.off
        self._static = dict(
            dofs=buf("int32_t[]", self.dofs), xdofs=buf("int32_t[]", self.xdofs), bc=buf("int8_t[]", self.bc),
            di=buf("int32_t[]", self.diag.i), dj=buf("int32_t[]", self.diag.j),
            oi=buf("int32_t[]", off.i) if off is not None else ffi.NULL,
            oj=buf("int32_t[]", off.j) if off is not None else ffi.NULL,
            ghost_col=buf("int32_t[]", self.ghost_col),
            bc_diag=buf("int64_t[]", self.bc_diag) if len(self.bc_diag) else ffi.NULL)
        self._entities = [(itype, i, address, len(cells), buf("int32_t[]", cells),
                           buf("int32_t[]", facets) if facets is not None else ffi.NULL)
                          for itype, i, address, cells, facets in self.integrals]
        self._keep += [cells for *_, cells, _ in self.integrals]
        self._keep += [facets for *_, facets in self.integrals if facets is not None]

    def _packed(self):
        """The form's coefficients (dict by integral) and constants, as the kernels take them."""
        coeffs = compat.pack_coefficients(self.J)
        consts = np.ascontiguousarray(compat.pack_constants(self.J), dtype=np.float64)
        return coeffs, consts

    def add(self, A):
        """Add J at the current state into A (zeroed before; the caller assembles A after).  False
        when the entries for MatSetValues did not fit the buffer (it is doubled: zero A, try again)."""
        coeffs, consts = self._packed()
        ffi, lib = self.mod.ffi, self.mod.lib
        if consts.size == 0:
            consts = np.zeros(1)
        x = self.V.mesh.geometry.x
        if not (x.flags.c_contiguous and x.dtype == np.float64):
            x = np.ascontiguousarray(x, dtype=np.float64)
        if not hasattr(self, "_static"):
            self._arguments()
        st = self._static
        da = ffi.cast("double*", self.diag.open())
        oa = ffi.cast("double*", self.off.open()) if self.off is not None else ffi.NULL
        ng_total = 0
        try:
            for itype, i, address, n, cells, facets in self._entities:
                c = np.ascontiguousarray(coeffs[(itype, i)], dtype=np.float64)
                cstride = c.shape[1] if c.ndim == 2 else 0
                if c.size == 0:
                    c = np.zeros(1)
                ng = lib.rodfem_assemble(
                    n, cells, facets, address, self.nd, st["dofs"], self.nx, st["xdofs"],
                    ffi.from_buffer("double[]", x), ffi.from_buffer("double[]", c), cstride,
                    ffi.from_buffer("double[]", consts), st["bc"], self.nown,
                    st["di"], st["dj"], da, st["oi"], st["oj"], oa, st["ghost_col"],
                    ffi.from_buffer("int32_t[]", self.grow[ng_total:]),
                    ffi.from_buffer("int32_t[]", self.gcol[ng_total:]),
                    ffi.from_buffer("double[]", self.gval[ng_total:]), self.gcap - ng_total, self.roff, ffi.NULL, 0)
                if ng < 0:
                    break
                ng_total += ng
            if ng >= 0 and len(self.bc_diag):
                lib.rodfem_set(da, len(self.bc_diag), st["bc_diag"], 1.0)
        finally:
            self.diag.close()
            if self.off is not None:
                self.off.close()
        if ng < 0:
            self._buffer(2 * self.gcap)   # more entries for MatSetValues than room: again, with twice the room
            return False
        if ng_total:
            rows = self.l2g[self.grow[:ng_total]]
            cols = self.l2g[self.gcol[:ng_total]]
            vals = self.gval[:ng_total]
            order = np.argsort(rows, kind="stable")
            rows, cols, vals = rows[order], cols[order], vals[order]
            cut = np.flatnonzero(np.diff(rows)) + 1
            for r, c, v in zip(np.split(rows, cut), np.split(cols, cut), np.split(vals, cut)):
                A.setValues(r[:1], c, v, addv=PETSc.InsertMode.ADD_VALUES)
        return True
