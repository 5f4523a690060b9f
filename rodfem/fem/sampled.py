"""Compiled forms on a weighted subset of their cells, projected on a basis: the reduced assembly.

For a compiled form a(x_{n+1}; x_n) (a functional, a residual or a Jacobian), the cells `cells`
with weights w_e >= 0 and a basis V (full dofs x k), with the state x = x_ref + V xi,

    functional:  sum_e w_e a_e(x)                 + sum_f a_f(x)
    residual:    sum_e w_e V_e^T b_e(x)           + sum_f V_f^T b_f(x)
    Jacobian:    sum_e w_e V_e^T A_e(x) V_e       + sum_f V_f^T A_f(x) V_f

where e runs over the sampled cells of the cell integrals (b_e, A_e the element vector and matrix
the form's own kernel (FFCx's tabulate_tensor) gives) and f over EVERY entity of the exterior-facet
integrals (point ports and boundary terms: not element integrals, kept exact, weight 1).  V_e are
the rows of V at the dofs of the entity.  Nothing of full size is touched: the state is formed on
the dofs D of the sampled entities only (x_D = x_ref[D] + V[D] xi), the coefficients are gathered
from it per entity (checked at build against DOLFINx's packing, entry by entry), and one C loop
calls the kernel and projects (each row of V nonzero in one column block: the projection runs
over that block only, and skips the element matrix's zeros).  The rows of Dirichlet dofs are not
projected (the full model replaces them by x - x_D, which x_ref + V xi meets: V vanishes there).

`separate=True` gives each cell's projected contribution on its own (one row per cell): the
training matrix of rodfem/analysis/ecsw.py.  Serial; cell and exterior-facet integrals without dof
transformations (rodfem/fem/batch.py's `batchable`).
"""
import numpy as np

from rodfem.errors import ParameterError
from rodfem.fem import cbuild, compat
from rodfem.fem.batch import batchable
from rodfem.fem.fastassembly import form_integrals

C_SOURCE = r"""
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef void (*kernel_t)(double*, const double*, const double*, const double*, const int*, const uint8_t*);

/* One integral over n entities (rank 0: functional, 1: residual, 2: Jacobian), weighted and projected.
   Entity e: cell cells[e] (its geometry nodes xdofs[cell * nx + .] in x), local facet facets[e] (or
   none), weight w[e]; its coefficients S[cidx[e * cstride + .]]; its dofs' rows ld[e * nd + .] of the
   local basis VD (nD x k, row-major; -1: a row not projected) whose nonzero columns are
   [c0[row], c1[row]).  out: 1 (functional), k (residual) or k * k (Jacobian) numbers per entity if
   `separate`, else their weighted sum. */
void rodfem_sampled(int n, const int32_t* cells, const int32_t* facets, const double* w,
                    uintptr_t kernel_address, int rank, int nd, const int32_t* ld,
                    int nx, const int32_t* xdofs, const double* x,
                    const int64_t* cidx, int cstride, const double* S, const double* consts,
                    int k, const double* VD, const int32_t* c0, const int32_t* c1,
                    int separate, double* out)
{
  kernel_t kernel = (kernel_t)kernel_address;
  int size = rank == 0 ? 1 : (rank == 1 ? nd : nd * nd);
  double* Ae = malloc(sizeof(double) * (size + (size_t)cstride + (rank == 2 ? (size_t)nd * k : 0)));
  double* coeffs = Ae + size;
  double* T = coeffs + cstride;
  double coords[3 * 64];
  uint8_t perm = 0;
  int stride = rank == 0 ? 1 : (rank == 1 ? k : k * k);
  for (int e = 0; e < n; ++e) {
    int32_t c = cells[e];
    for (int a = 0; a < nx; ++a)
      for (int d = 0; d < 3; ++d)
        coords[3 * a + d] = x[3 * (size_t)xdofs[(size_t)c * nx + a] + d];
    for (int a = 0; a < cstride; ++a) coeffs[a] = S[cidx[(size_t)e * cstride + a]];
    memset(Ae, 0, sizeof(double) * size);
    kernel(Ae, coeffs, consts, coords, facets ? facets + e : NULL, &perm);
    double we = w[e];
    double* o = separate ? out + (size_t)e * stride : out;
    const int32_t* le = ld + (size_t)e * nd;
    if (rank == 0) { o[0] += we * Ae[0]; continue; }
    if (rank == 1) {
      for (int i = 0; i < nd; ++i) {
        int32_t r = le[i];
        if (r < 0 || Ae[i] == 0.0) continue;
        double v = we * Ae[i];
        const double* Vr = VD + (size_t)r * k;
        for (int a = c0[r]; a < c1[r]; ++a) o[a] += v * Vr[a];
      }
      continue;
    }
    /* T = A_e V_e (rows i of projected dofs), then out += w V_e^T T */
    for (int i = 0; i < nd; ++i) {
      if (le[i] < 0) continue;
      double* Ti = T + (size_t)i * k;
      memset(Ti, 0, sizeof(double) * k);
      const double* Ai = Ae + (size_t)i * nd;
      int lo = k, hi = 0;
      for (int j = 0; j < nd; ++j) {
        int32_t s = le[j];
        double v = Ai[j];
        if (s < 0 || v == 0.0) continue;
        const double* Vs = VD + (size_t)s * k;
        int a0 = c0[s], a1 = c1[s];
        if (a0 < lo) lo = a0;
        if (a1 > hi) hi = a1;
        for (int a = a0; a < a1; ++a) Ti[a] += v * Vs[a];
      }
      if (hi <= lo) continue;
      int32_t r = le[i];
      const double* Vr = VD + (size_t)r * k;
      for (int a = c0[r]; a < c1[r]; ++a) {
        double v = we * Vr[a];
        if (v == 0.0) continue;
        double* oa = o + (size_t)a * k;
        for (int b = lo; b < hi; ++b) oa[b] += v * Ti[b];
      }
    }
  }
  free(Ae);
}

/* out[i] = x[i] + sum_{a in [c0[i], c1[i])} VD[i, a] xi[a]: the state on the sampled dofs */
void rodfem_sampled_state(int n, int k, const double* x, const double* VD, const int32_t* c0, const int32_t* c1,
                          const double* xi, double* out)
{
  for (int i = 0; i < n; ++i) {
    const double* Vi = VD + (size_t)i * k;
    double v = x[i];
    for (int a = c0[i]; a < c1[i]; ++a) v += Vi[a] * xi[a];
    out[i] = v;
  }
}
"""

C_DECL = """
void rodfem_sampled(int n, const int32_t* cells, const int32_t* facets, const double* w,
                    uintptr_t kernel_address, int rank, int nd, const int32_t* ld,
                    int nx, const int32_t* xdofs, const double* x,
                    const int64_t* cidx, int cstride, const double* S, const double* consts,
                    int k, const double* VD, const int32_t* c0, const int32_t* c1,
                    int separate, double* out);
void rodfem_sampled_state(int n, int k, const double* x, const double* VD, const int32_t* c0, const int32_t* c1,
                          const double* xi, double* out);
"""


def _cell_dofs(V):
    dm = V.dofmap
    return np.asarray(compat.dofmap_array(dm), dtype=np.int64).reshape(-1, dm.dof_layout.num_dofs), dm.bs


class ReducedState:
    """The state x_{n+1} = x_ref + V xi_{n+1} and x_n = x_ref + V xi_n on the dofs D of the sampled entities.

    x1, x0: the Functions the forms read as x_{n+1} and x_n; bc_dofs: the Dirichlet dofs (their rows of V are
    dropped: x = x_ref there); column_blocks: [(start, end)] of V's column blocks, each row of V nonzero in one of
    them (default: one block).  `dofs` (D) grows as forms are added (`add`), then `freeze()` cuts V[D]."""

    def __init__(self, V, x_ref, x1, x0, bc_dofs=(), column_blocks=None):
        self.V, self.x_ref, self.x1, self.x0 = np.asarray(V), np.asarray(x_ref), x1, x0
        self.k = self.V.shape[1]
        self.column_blocks = list(column_blocks) if column_blocks else [(0, self.k)]
        self.bc = np.zeros(self.V.shape[0], bool)
        self.bc[np.asarray(bc_dofs, dtype=np.int64)] = True
        self.dofs, self.where = np.zeros(0, np.int64), {}
        self.forms = []
        self.frozen = False
        self._last = [None, None]

    def add(self, dofs):
        assert not self.frozen
        self.dofs = np.union1d(self.dofs, np.asarray(dofs, dtype=np.int64).ravel())

    def freeze(self):
        """V[D] (Dirichlet rows zero), the column block of each row, the local numbering."""
        D = self.dofs
        self.local = np.full(self.V.shape[0], -1, np.int64)
        self.local[D] = np.arange(len(D))
        VD = self.V[D].copy()
        VD[self.bc[D]] = 0.0
        self.VD = np.ascontiguousarray(VD)
        self.xD = np.ascontiguousarray(self.x_ref[D])
        self.c0 = np.zeros(len(D), np.int32)
        self.c1 = np.zeros(len(D), np.int32)
        for a, b in self.column_blocks:
            inside = np.any(self.VD[:, a:b] != 0.0, axis=1)
            if np.any(inside & (np.any(self.VD[:, :a] != 0.0, axis=1) | np.any(self.VD[:, b:] != 0.0, axis=1))):
                raise ValueError("a row of the basis is nonzero in two column blocks")
            self.c0[inside], self.c1[inside] = a, b
        self.projected = np.where(self.bc[D] | (self.c1 == 0), -1, np.arange(len(D))).astype(np.int32)
        self.S = np.zeros(2 * len(D))
        self.frozen = True
        self._last = [None, None]
        self.mod = cbuild.load("rodfem_sampled", C_SOURCE, C_DECL)
        ffi = self.mod.ffi
        self._xi = np.zeros(self.k)
        self._args = (len(D), self.k, ffi.from_buffer("double[]", self.xD), ffi.from_buffer("double[]", self.VD),
                      ffi.from_buffer("int32_t[]", self.c0), ffi.from_buffer("int32_t[]", self.c1),
                      ffi.from_buffer("double[]", self._xi))
        self._out = [ffi.from_buffer("double[]", self.S), ffi.from_buffer("double[]", self.S[len(D):])]
        for f in self.forms:
            f.bind()

    def set(self, xi1, xi0=None):
        """x_{n+1} (and x_n) on D from the reduced coordinates (row by row over the row's column block; a half
        already at these coordinates is not formed again)."""
        for half, xi in enumerate((xi1, xi0)):
            if xi is None or (self._last[half] is not None and np.array_equal(xi, self._last[half])):
                continue
            self._xi[:] = xi
            self.mod.lib.rodfem_sampled_state(*self._args, self._out[half])
            self._last[half] = self._xi.copy()


class SampledForm:
    """One compiled form on its sampled cells with weights (every exterior-facet entity, weight 1) over a
    `ReducedState` (see the module docstring).  cells: the sampled cells (None: all); weights: one per cell."""

    def __init__(self, form, state, cells=None, weights=None):
        if not batchable(form):
            raise ParameterError("hyper-reduction: the form has integrals other than cells and exterior facets, "
                                 "dof transformations, or runs in parallel (serial only)")
        from dolfinx.fem import IntegralType
        self.form, self.state = form, state
        self.mod = cbuild.load("rodfem_sampled", C_SOURCE, C_DECL, form.mesh.comm)
        self.rank = len(form.function_spaces)
        ncell = form.mesh.topology.index_map(form.mesh.topology.dim).size_local
        cells = np.arange(ncell) if cells is None else np.asarray(cells, dtype=np.int64)
        weights = np.ones(len(cells)) if weights is None else np.asarray(weights, dtype=float)
        order = np.argsort(cells)
        self.cells, weights = cells[order], weights[order]
        by_cell = dict(zip(self.cells.tolist(), weights.tolist()))
        self.integrals = []
        for itype, i, address, ent_cells, ent_facets in form_integrals(form):
            if itype == IntegralType.cell:
                keep = np.array([c in by_cell for c in ent_cells.tolist()], bool)
                w = np.array([by_cell.get(c, 0.0) for c in ent_cells[keep].tolist()])
            else:
                keep = np.ones(len(ent_cells), bool)
                w = np.ones(int(keep.sum()))
            self.integrals.append(dict(itype=itype, id=i, address=address, pos=np.flatnonzero(keep),
                                       cells=np.ascontiguousarray(ent_cells[keep], dtype=np.int32),
                                       facets=None if ent_facets is None else np.ascontiguousarray(ent_facets[keep]),
                                       w=np.ascontiguousarray(w)))
        self.coeffs = list(compat.cpp_form(form).coefficients)
        spaces = list(form.function_spaces) + [c.function_space for c in self.coeffs]
        self.cell_dofs = [_cell_dofs(V) for V in spaces]
        for it in self.integrals:
            for dofs, bs in self.cell_dofs:
                d = dofs[it["cells"]]
                state.add((bs * d[:, :, None] + np.arange(bs)).ravel())
        g = form.mesh.geometry
        self.x = np.ascontiguousarray(g.x, dtype=np.float64)
        xd = compat.geometry_dofmap(form.mesh)
        self.nx = int(xd.shape[1])
        self.xdofs = np.ascontiguousarray(xd, dtype=np.int32).reshape(-1)
        state.forms.append(self)
        if state.frozen:
            self.bind()

    def bind(self):
        """The entities' local rows and coefficient positions in the state (after `ReducedState.freeze`)."""
        st = self.state
        n = len(st.dofs)
        self.nd = self.form.function_spaces[0].dofmap.dof_layout.num_dofs if self.rank else 0
        for it in self.integrals:
            cells = it["cells"].astype(np.int64)
            if self.rank:
                dofs, bs = self.cell_dofs[0]
                assert bs == 1
                it["ld"] = np.ascontiguousarray(st.projected[st.local[dofs[cells]]], dtype=np.int32)
            else:
                it["ld"] = np.zeros(1, np.int32)
            cols = []
            for c, (dofs, bs) in zip(self.coeffs, self.cell_dofs[self.rank:]):
                slots = st.local[(bs * dofs[cells][:, :, None] + np.arange(bs)).reshape(len(cells), -1)]
                if np.shares_memory(c.x.array, st.x1.x.array):
                    cols.append(slots)
                elif np.shares_memory(c.x.array, st.x0.x.array):
                    cols.append(n + slots)
                else:
                    raise ParameterError("hyper-reduction: a form reads a coefficient other than x_n and x_{n+1} "
                                         "(a load given as a field): not supported")
            it["cidx"] = np.ascontiguousarray(np.concatenate(cols, axis=1) if cols else np.zeros((len(cells), 1), np.int64),
                                              dtype=np.int64)
            it["cstride"] = it["cidx"].shape[1] if cols else 0

    def check(self, x1, x0):
        """The gathered coefficients equal DOLFINx's packing at the full states x1, x0 (which must equal
        x_ref + V xi for the xi last `set`); ValueError otherwise."""
        self.state.x1.x.array[:] = x1
        self.state.x0.x.array[:] = x0
        packed = compat.pack_coefficients(self.form)
        for it in self.integrals:
            theirs = np.asarray(packed[(it["itype"], it["id"])]).reshape(-1, max(it["cstride"], 1))[it["pos"]]
            mine = self.state.S[it["cidx"]] if it["cstride"] else theirs
            if it["cstride"]:   # (DOLFINx >= 0.6 packs only the coefficients the integral's kernel reads)
                read = compat.kernel(self.form, it["itype"], it["id"]).enabled_coefficients
                widths = [dofs.shape[1] * bs for dofs, bs in self.cell_dofs[self.rank:]]
                used = np.repeat([bool(read[k]) for k in range(len(widths))], widths)
                mine, theirs = mine[:, used], theirs[:, used]
            if not np.allclose(mine, theirs, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(theirs).max(initial=0.0))):
                raise ValueError("hyper-reduction: the gathered coefficients differ from DOLFINx's packing")

    def _calls(self):
        """The C call's arguments per integral, but the constants and the output (made once: the arrays stay put)."""
        st, ffi = self.state, self.mod.ffi
        buf = ffi.from_buffer
        self._consts = np.zeros(max(len(np.asarray(compat.pack_constants(self.form))), 1))
        common = (buf("int32_t[]", self.xdofs), buf("double[]", self.x))
        calls = []
        for it in self.integrals:
            if not len(it["cells"]):
                continue
            calls.append((it, (len(it["cells"]), buf("int32_t[]", it["cells"]),
                               buf("int32_t[]", it["facets"]) if it["facets"] is not None else ffi.NULL,
                               buf("double[]", it["w"]), it["address"], self.rank, self.nd,
                               buf("int32_t[]", it["ld"]), self.nx, *common, buf("int64_t[]", it["cidx"]),
                               it["cstride"], buf("double[]", st.S), buf("double[]", self._consts), st.k,
                               buf("double[]", st.VD), buf("int32_t[]", st.c0), buf("int32_t[]", st.c1))))
        return calls

    def evaluate(self, separate=False):
        """The weighted, projected value at the state's last `set` (see the module docstring); `separate`:
        (one row per sampled cell of the cell integrals, the facet integrals' sum)."""
        st, ffi, lib = self.state, self.mod.ffi, self.mod.lib
        if getattr(self, "_bound", None) is not st.S:
            self._args, self._bound = self._calls(), st.S
        k = st.k
        shape = () if self.rank == 0 else ((k,) if self.rank == 1 else (k, k))
        consts = compat.pack_constants(self.form)
        self._consts[:len(consts)] = consts
        total = np.zeros(max(int(np.prod(shape)), 1))
        per_cell = np.zeros((len(self.cells),) + shape) if separate else None
        for it, args in self._args:
            if separate and it["facets"] is None:
                out = np.zeros((len(it["cells"]),) + shape)
                lib.rodfem_sampled(*args, 1, ffi.from_buffer("double[]", out.reshape(-1)))
                np.add.at(per_cell, np.searchsorted(self.cells, it["cells"]), out)
            else:
                lib.rodfem_sampled(*args, 0, ffi.from_buffer("double[]", total))
        total = float(total[0]) if self.rank == 0 else total.reshape(shape)
        return (per_cell, total) if separate else total
