"""Many bodies of the same compiled forms assembled as one: one kernel loop over all their cells.

A system of many small bodies (a chain of links, a net of cables) spent its time in Python, body
by body: packing each body's coefficients, calling DOLFINx's assembly, copying the result into
the block vector (issue 26: 1.4 ms per body per step).  Bodies whose forms are compiled from the
same UFL (the same kernels: the same model and elements; their constants, number of cells and
loads' values may differ) are here one *batch*: their cells are numbered one after the other as
if they were the cells of one disconnected mesh,

    cell e of body b           ->  cells of bodies 0..b-1 + e
    dof  i of body b           ->  offsets[b] + i        (its row in the rank's part of X)
    coefficient slot of a cell ->  an index into S = (X, the other coefficients' values)

and one C loop (rodfem/fem/fastassembly.py) calls the form's kernel for every cell of every body,
each with its body's constants (copied from their values at each assembly).  A residual, a Jacobian
or a functional is one C call (a "job": the constants and other coefficients copied in, the
coefficients gathered, the kernel loops; issue 26: a small step is a few dozen of them).  The
coefficient x_{n+1} (the iterate) is read straight from X; every other coefficient (x_n, a load's
Function) from its Function at each assembly.  The gather indices are checked at build against DOLFINx's own packing
(`pack_coefficients`), entry by entry: what the kernels see is what DOLFINx would give them, and
the sums are made in DOLFINx's order (integral by integral, cell by cell, body by body), so the
batch's residual, Jacobian and functionals are DOLFINx's, bit for bit.

Serial (a body's dofs are then all owned, X holds them all); a body spread over ranks has its
residual made by a FormBatch of its own, on its rank's cells with X the Function's local array (owned
dofs and ghosts), the ghosts' sums then sent to their owners (rodfem/fem/assembly.py's BodyBlock).  Cell
and exterior-facet integrals without dof transformations (`FastJacobian.usable`).
"""
import numpy as np
from mpi4py import MPI

from rodfem.fem import cbuild, compat
from rodfem.fem.fastassembly import C_DECL, C_SOURCE, form_integrals

COPY_SOURCE = r"""
#include <stdint.h>
#include <string.h>
/* segment k: x[off[k] : off[k] + len[k]] <-> the array at address ptr[k] */
void rodfem_put(int n, const uintptr_t* ptr, const int64_t* off, const int64_t* len, const double* x)
{
  for (int k = 0; k < n; ++k) memcpy((double*)ptr[k], x + off[k], sizeof(double) * len[k]);
}
void rodfem_get(int n, const uintptr_t* ptr, const int64_t* off, const int64_t* len, double* x)
{
  for (int k = 0; k < n; ++k) memcpy(x + off[k], (const double*)ptr[k], sizeof(double) * len[k]);
}
"""
COPY_DECL = """
void rodfem_put(int n, const uintptr_t* ptr, const int64_t* off, const int64_t* len, const double* x);
void rodfem_get(int n, const uintptr_t* ptr, const int64_t* off, const int64_t* len, double* x);
"""


class Segments:
    """The owned values of many Functions as segments of one array X: f_k.x.array[:n_k] <-> X[lo_k:lo_k + n_k],
    copied by one C call (`put`: into the Functions, `get`: into X; no ghost update)."""

    def __init__(self, functions, los, lengths, comm, arrays=None):
        """(`arrays`: views of float64 arrays instead of the Functions' values.)"""
        self.mod = cbuild.load("rodfem_segments", COPY_SOURCE, COPY_DECL, comm)
        self._views = arrays if arrays is not None else [np.asarray(f.x.array) for f in functions]
        for v in self._views:   # (the memory stays where it is)
            assert v.dtype == np.float64 and v.flags.c_contiguous
        self.ptr = np.array([v.ctypes.data for v in self._views], dtype=np.uintp)
        self.off = np.asarray(los, dtype=np.int64)
        self.len = np.asarray(lengths, dtype=np.int64)

        ffi = self.mod.ffi   # (the fixed arguments' views made once: a small step calls this ~10 times)
        self._fixed = (len(self.ptr), ffi.from_buffer("uintptr_t[]", self.ptr), ffi.from_buffer("int64_t[]", self.off),
                       ffi.from_buffer("int64_t[]", self.len))

    def _args(self, X, kind):
        # (X's view made at each call and dropped: a view kept would keep X, and an array of a PETSc
        # Vec kept is a Vec whose changes PETSc does not see, e.g. its cached norm)
        return self._fixed + (self.mod.ffi.from_buffer(kind, X),)

    def put(self, X):
        """Every Function <- its segment of X."""
        self.mod.lib.rodfem_put(*self._args(np.ascontiguousarray(X, dtype=np.float64), "double[]"))

    def get(self, X):
        """X's segments <- the Functions (X: a writable float64 array)."""
        self.mod.lib.rodfem_get(*self._args(X, "double[]"))


def load_modules(comm):
    """The batch's compiled C modules (collective the first time in a process: rank 0 compiles)."""
    cbuild.load("rodfem_fastasm", C_SOURCE, C_DECL, comm)
    cbuild.load("rodfem_segments", COPY_SOURCE, COPY_DECL, comm)


def batchable(form, spread=False) -> bool:
    """A form the batch can take (serial, cell and exterior-facet integrals, no dof transformations).
    `spread`: also a body spread over ranks, one rank's cells with X its Function's local array (owned dofs
    and ghosts: rodfem/fem/assembly.py's BodyBlock)."""
    from dolfinx.fem import IntegralType
    if form is None or (form.mesh.comm.size != 1 and not spread):
        return False
    spaces = list(form.function_spaces) + [c.function_space for c in compat.cpp_form(form).coefficients]
    return (set(form.integral_types) <= {IntegralType.cell, IntegralType.exterior_facet}
            and all(not V.element.needs_dof_transformations for V in spaces))


def spread_batch(form, x):
    """The FormBatch of one body spread over ranks (its form on this rank's cells, X its Function x's local
    array, ghosts included), or None where the batch cannot take the form: then DOLFINx's assembly.
    Collective: every rank of the body takes the same path (a rank without cells makes its batch too;
    one rank failing while the others wait in the next collective cannot happen)."""
    if not batchable(form, spread=True):   # (the same answer on every rank: the form's own properties)
        return None
    comm = form.mesh.comm
    load_modules(comm)   # (collective: the batch's construction is then local to each rank)
    try:
        made = FormBatch([form], [x], [0], len(x.x.array))
    except Exception:    # (coefficients it cannot gather: ValueError; whatever else, DOLFINx's path on every rank)
        made = None
    return made if comm.allreduce(made is not None, op=MPI.LAND) else None


def kernel_key(form):
    """Forms with the same key run the same kernels (one compiled module) on the same layout."""
    return tuple((itype, i, address) for itype, i, address, _, _ in form_integrals(form)) + (
        len(compat.cpp_form(form).coefficients), tuple(V.dofmap.dof_layout.num_dofs for V in form.function_spaces))


def _cell_dofs(V):
    dm = V.dofmap
    return np.asarray(compat.dofmap_array(dm), dtype=np.int64).reshape(-1, dm.dof_layout.num_dofs), dm.bs


class FormBatch:
    """One compiled form (`forms[b]` of body b) over all bodies' cells.

    iterates[b]: body b's Function x_{n+1}, whose values are X[offsets[b]:offsets[b] + n_b];
    size: the length of X.  `refresh()` reads the constants and the other coefficients (one
    copy each; before every assembly); `vector(X, b)` adds the residual into the array b,
    `scalars(X)` gives each body's value of a functional, `add_matrix` the Jacobian (rodfem_assemble).
    """

    def __init__(self, forms, iterates, offsets, size):
        self.forms, self.size = list(forms), int(size)
        self.nb = len(self.forms)
        first = self.forms[0]
        self.mod = cbuild.load("rodfem_fastasm", C_SOURCE, C_DECL, first.mesh.comm)
        ffi = self.mod.ffi
        self.rank = len(first.function_spaces)
        # geometry: the bodies' nodes one after the other
        xs, xdofs, nodes, self.nx = [], [], 0, 0
        for f in self.forms:
            g = f.mesh.geometry
            xs.append(np.asarray(g.x, dtype=np.float64))
            cell_nodes = compat.geometry_dofmap(f.mesh)
            self.nx = max(self.nx, int(cell_nodes.shape[1]))   # (a rank without cells: 0 columns)
            xdofs.append(np.asarray(cell_nodes, dtype=np.int64).reshape(-1) + nodes)
            nodes += len(g.x)
        self.x = np.ascontiguousarray(np.concatenate(xs))
        self.xdofs = np.ascontiguousarray(np.concatenate(xdofs), dtype=np.int32)
        # (a rank of a body spread over ranks may hold none of its cells: no nodes per cell seen there)
        ncells = [len(x) // self.nx if self.nx else 0 for x in xdofs]
        self.cell_start = np.concatenate([[0], np.cumsum(ncells)]).astype(np.int64)
        # the argument's dofs: rows of X
        if self.rank:
            self.nd = first.function_spaces[0].dofmap.dof_layout.num_dofs
            self.dofs = np.ascontiguousarray(np.concatenate(
                [offsets[b] + _cell_dofs(f.function_spaces[0])[0] for b, f in enumerate(self.forms)]).ravel(),
                dtype=np.int32)
        else:
            self.nd, self.dofs = 0, np.zeros(1, np.int32)
        # the other coefficients: their Functions, and where their values sit in S = (X, others)
        self.others, self._other_at, self._end = [], {}, self.size
        self._dofs_of = {}
        per_body = [self._gather(b, f, iterates[b], offsets[b]) for b, f in enumerate(self.forms)]
        self.S = np.zeros(self._end)
        # the entities of each integral, body by body, and their coefficients' gather indices
        self.integrals = []
        entities = [form_integrals(f) for f in self.forms]
        for k, (itype, i, address, _, facets) in enumerate(entities[0]):
            cells, fac, body, index = [], [], [], []
            for b, f in enumerate(self.forms):
                *_, c_b, f_b = entities[b][k]
                cells.append(c_b + self.cell_start[b])
                if f_b is not None:
                    fac.append(f_b)
                body.append(np.full(len(c_b), b, np.int32))
                index.append(per_body[b][c_b])
            index = np.concatenate(index)
            self.integrals.append(dict(
                address=address, n=int(sum(len(c) for c in cells)),
                cells=np.ascontiguousarray(np.concatenate(cells), dtype=np.int32),
                facets=np.ascontiguousarray(np.concatenate(fac), dtype=np.int32) if facets is not None else None,
                body=np.ascontiguousarray(np.concatenate(body)), index=index, cstride=index.shape[1],
                flat=np.ascontiguousarray(index, dtype=np.int64).ravel(),   # (the gather's index, flat)
                coeffs=np.zeros(max(index.size, 1)), key=(itype, i)))
            self.integrals[-1]["target"] = self.integrals[-1]["coeffs"][:index.size]
        self._pointers(ffi)
        self.refresh()
        self._check(iterates, offsets)

    def _gather(self, b, form, iterate, offset):
        """Per cell of body b, the positions in S of the form's packed coefficients (DOLFINx's order:
        coefficient by coefficient, dof by dof, component by component)."""
        cols = []
        ncell = self.cell_start[b + 1] - self.cell_start[b]
        for c in compat.cpp_form(form).coefficients:
            V = c.function_space
            if id(V) not in self._dofs_of:   # (bodies of one kind share their spaces: computed once)
                dofs, bs = _cell_dofs(V)
                self._dofs_of[id(V)] = (V, (bs * dofs[:, :, None] + np.arange(bs)[None, None, :]).reshape(len(dofs), -1))
            slots = self._dofs_of[id(V)][1]
            if np.shares_memory(c.x.array, iterate.x.array):
                base = offset
            else:
                key = c.x.array.ctypes.data
                if key not in self._other_at:
                    self._other_at[key] = self._end
                    self._end += len(c.x.array)
                    self.others.append(c)
                base = self._other_at[key]
            cols.append(base + slots[:ncell])
        return np.concatenate(cols, axis=1) if cols else np.zeros((ncell, 0), np.int64)

    def _pointers(self, ffi):
        buf = ffi.from_buffer
        self._p = dict(x=buf("double[]", self.x), xdofs=buf("int32_t[]", self.xdofs),
                       dofs=buf("int32_t[]", self.dofs))

    def _check(self, iterates, offsets):
        """The gathered coefficients equal DOLFINx's packing, body by body (else ValueError)."""
        X = np.zeros(self.size)
        for b, x in enumerate(iterates):
            X[offsets[b]:offsets[b] + len(x.x.array)] = x.x.array
        self._coefficients(X)
        for b, f in enumerate(self.forms):
            packed = compat.pack_coefficients(f)
            for it in self.integrals:
                mine = it["coeffs"][:it["n"] * it["cstride"]].reshape(it["n"], it["cstride"])[it["body"] == b]
                theirs = np.asarray(packed[it["key"]]).reshape(len(mine), it["cstride"])   # (a rank of a spread
                # body may have no entity of an integral: none of the boundary's facets)
                if mine.shape != theirs.shape or not np.array_equal(mine, theirs):
                    raise ValueError("the batch's coefficients differ from DOLFINx's packing")

    def _sources(self):
        """Views of the constants' values (in the kernels' order, when the compiled forms list their
        constants: rodfem/fem/jit.py) and of the other coefficients' values: `refresh` copies them
        with one call each.  Checked against DOLFINx's packing, else packed body by body."""
        comm = self.forms[0].mesh.comm
        views = [np.asarray(o.x.array) for o in self.others]
        self._other_views = Segments(None, self.size + np.concatenate([[0], np.cumsum([len(v) for v in views])])[:-1],
                                     [len(v) for v in views], comm, arrays=views) if views else None
        self._const_views = None
        packed = [np.asarray(compat.pack_constants(f), dtype=np.float64) for f in self.forms]
        self.kstride = len(packed[0])
        self.consts = np.ascontiguousarray(np.concatenate(packed)) if self.kstride else np.zeros(1)
        self._p["consts"] = self.mod.ffi.from_buffer("double[]", self.consts)
        if self.kstride and all(hasattr(f, "rodfem_constants") for f in self.forms):
            views = [np.asarray(c.value).reshape(-1) for f in self.forms for c in f.rodfem_constants]
            if sum(v.size for v in views) == self.consts.size and np.array_equal(np.concatenate(views), self.consts):
                sizes = [v.size for v in views]
                self._const_views = Segments(None, np.concatenate([[0], np.cumsum(sizes)])[:-1], sizes, comm,
                                             arrays=views)

    def refresh(self):
        """Read the bodies' constants and the coefficients other than x_{n+1}."""
        if not hasattr(self, "_other_views"):
            self._sources()
        if self._const_views is not None:   # (one C call: copies of the constants' values)
            self._const_views.get(self.consts)
        elif self.kstride:
            self.consts[:] = np.concatenate([compat.pack_constants(f) for f in self.forms])
        if self._other_views is not None:
            self._other_views.get(self.S)

    def _coefficients(self, X):
        self.S[:self.size] = X
        for it in self.integrals:
            if it["cstride"]:
                self.S.take(it["flat"], out=it["target"])

    def vector(self, X, b):
        """b[rows of X] += the residual of every body (b: an array like X), its constants and other
        coefficients read now (`refresh`, the gather and the kernel loops in one C call, rodfem_vector_job)."""
        if not hasattr(self, "_job"):
            self._make_job()
        if self._job[0] == 0 and self.kstride:   # (constants without views: packed here)
            self.refresh()
        ffi = self.mod.ffi
        self.mod.lib.rodfem_vector_job(*self._job, ffi.from_buffer("double[]", X), *self._job_integrals[:9],
                                       self.nd, self._p["dofs"], self.nx, self._p["xdofs"], self._p["x"],
                                       self.kstride, ffi.from_buffer("double[]", b))

    def scalars(self, X):
        """Each body's value of the functional at X, its constants and other coefficients read now
        (`refresh`, the gather and each integral's kernel loop in one C call, rodfem_scalar_job:
        the step's H, work and columns are a dozen functionals of a few cells each)."""
        if not hasattr(self, "_job"):
            self._make_job()
        if self._job[0] == 0 and self.kstride:   # (constants without views: packed here)
            self.refresh()
        self.mod.lib.rodfem_scalar_job(*self._job, self.mod.ffi.from_buffer("double[]", X), *self._job_integrals)
        return self.total.copy()

    def _make_job(self):
        """The arguments of the jobs (rodfem_scalar_job, _vector_job, _matrix_job in
        rodfem/fem/fastassembly.py), made once: the segments `refresh` copies, each integral's arrays
        (by address; this object keeps them), the sums."""
        if not hasattr(self, "_other_views"):
            self._sources()
        ffi, p = self.mod.ffi, self._p
        none = (0, ffi.NULL, ffi.NULL, ffi.NULL)
        consts = self._const_views._fixed if self._const_views is not None else none
        others = self._other_views._fixed if self._other_views is not None else none
        self.total = np.zeros(self.nb)
        for it in self.integrals:
            it["sums"] = np.zeros(self.nb)

        def address(a):   # (None: a NULL pointer)
            return a.ctypes.data if a is not None else 0
        self._job_arrays = [
            np.array([it["n"] for it in self.integrals], np.int64),
            np.array([address(it["cells"]) for it in self.integrals], np.uintp),
            np.array([address(it["facets"]) for it in self.integrals], np.uintp),
            np.array([it["address"] for it in self.integrals], np.uintp),
            np.array([address(it["coeffs"]) for it in self.integrals], np.uintp),
            np.array([it["cstride"] for it in self.integrals], np.int64),
            np.array([address(it["flat"]) for it in self.integrals], np.uintp),
            np.array([address(it["body"]) for it in self.integrals], np.uintp),
            np.array([address(it["sums"]) for it in self.integrals], np.uintp)]
        kinds = ("int64_t[]", "uintptr_t[]", "uintptr_t[]", "uintptr_t[]", "uintptr_t[]", "int64_t[]", "uintptr_t[]",
                 "uintptr_t[]", "uintptr_t[]")
        self._job = (*consts, p["consts"], *others, ffi.from_buffer("double[]", self.S), self.size)
        self._job_integrals = (len(self.integrals), *(ffi.from_buffer(k, a) for k, a in zip(kinds, self._job_arrays)),
                               self.nx, p["xdofs"], p["x"], self.kstride, self.nb,
                               ffi.from_buffer("double[]", self.total))

    def add_matrix(self, X, bc, nown, da, di, dj, ghost, room):
        """Add the bilinear form at X into the CSR values da (structure di, dj; rows and columns with
        bc[row] set left out); entries without a place go to room = (rows, cols, values) for
        MatSetValues.  Returns their number, or -1 if room was too small.  The constants and other
        coefficients read now (`refresh`, the gather and rodfem_assemble in one C call, rodfem_matrix_job)."""
        if not hasattr(self, "_job"):
            self._make_job()
        if self._job[0] == 0 and self.kstride:   # (constants without views: packed here)
            self.refresh()
        ffi, p = self.mod.ffi, self._p
        grow, gcol, gval = room
        return self.mod.lib.rodfem_matrix_job(
            *self._job, ffi.from_buffer("double[]", X), *self._job_integrals[:9], self.nd, p["dofs"], self.nx,
            p["xdofs"], p["x"], self.kstride, bc, nown, di, dj, da, ghost, ffi.from_buffer("int32_t[]", grow),
            ffi.from_buffer("int32_t[]", gcol), ffi.from_buffer("double[]", gval), len(grow))


class BlockBatch:
    """Bodies' blocks (rodfem/fem/assembly.py's BodyBlock, placed in the layout) of the same compiled
    residual and Jacobian, assembled as one: the residual by one kernel loop, its Dirichlet rows
    x - x_D; the Jacobian by rodfem_assemble straight into the matrix (Dirichlet rows and columns
    left out, 1 on their diagonal), as each body's FastJacobian would.

    The bodies' Functions x_{n+1} are not written at each iterate: `sync(X)` does it (the assembler's
    `update`, at the end of a Newton solve)."""

    def __init__(self, blocks, size):
        self.blocks, self.size = list(blocks), int(size)
        offsets = [blk.lo for blk in self.blocks]
        iterates = [blk.x for blk in self.blocks]
        self.F = FormBatch([blk.F for blk in self.blocks], iterates, offsets, size)
        self.J = FormBatch([blk.J for blk in self.blocks], iterates, offsets, size)
        self.bcs = [bc for blk in self.blocks for bc in blk.bcs]
        # the Dirichlet dofs (rows of X) and their values' Functions
        rows, self._g = [], []
        for blk in self.blocks:
            for bc in blk.bcs:
                dofs = np.asarray(bc.dof_indices()[0], dtype=np.int64)
                rows.append(blk.lo + dofs)
                self._g.append((np.asarray(compat.dirichlet_values(bc)), dofs))
        self.bc_rows = np.concatenate(rows) if rows else np.zeros(0, np.int64)
        self.bc = np.zeros(self.size, np.int8)
        self.bc[self.bc_rows] = 1
        self.g = np.zeros(len(self.bc_rows))
        self.lifted = [blk for blk in self.blocks if blk.bcs]
        self.states = Segments(iterates, offsets, [blk.hi - blk.lo for blk in self.blocks],
                               self.blocks[0].x.function_space.mesh.comm)
        self._room(1024)

    def refresh(self):
        """The Dirichlet values (at every assembly, as DOLFINx reads them; the residual's constants, x_n
        and other coefficients: read by its kernel loop's call, FormBatch.vector)."""
        if self._g:
            self.g = np.concatenate([g[dofs] for g, dofs in self._g])

    def _room(self, n):
        self.room = (np.zeros(n, np.int32), np.zeros(n, np.int32), np.zeros(n))

    def entries(self):
        out = [blk.entries() for blk in self.blocks]
        return (np.concatenate([r for r, _ in out]), np.concatenate([c for _, c in out]))

    def attach(self, A):
        from rodfem.fem.fastassembly import structure
        shared = structure(A)   # (read once for all the bodies)
        for blk in self.blocks:
            blk.attach(A, shared)
        self.A = A
        self._structure(shared)

    def restructure(self):
        from rodfem.fem.fastassembly import structure
        shared = structure(self.A)
        for blk in self.blocks:
            blk.restructure(shared)
        self._structure(shared)

    def _structure(self, shared):
        self.diag = shared[0]
        self.bc_diag = np.concatenate([blk.fast.bc_diag for blk in self.blocks])
        ffi = self.J.mod.ffi   # (the views add_jacobian passes, made again with the structure)
        self._views = (ffi.from_buffer("int8_t[]", self.bc), ffi.from_buffer("int32_t[]", self.diag.i),
                       ffi.from_buffer("int32_t[]", self.diag.j), ffi.from_buffer("int32_t[]", np.zeros(1, np.int32)),
                       ffi.from_buffer("int64_t[]", self.bc_diag))

    def set_state(self, X):
        """(The iterate is read from X at assembly.)"""

    def sync(self, X):
        """Every body's Function x_{n+1} <- its block of X."""
        self.states.put(X)

    def residual(self, X, b):
        """b += the bodies' residuals; Dirichlet rows x - x_D.  The lifting J[:, D] (x_D - x) is zero
        when the iterate meets its conditions (always, after the start); where it does not, DOLFINx's."""
        self.refresh()
        self.F.vector(X, b)
        if len(self.bc_rows):
            gap = self.g - X[self.bc_rows]
            if np.any(gap != 0.0):
                self._lift(X, b)
            b[self.bc_rows] = -gap
        return True

    def _lift(self, X, b):
        from dolfinx.fem import petsc as fpetsc
        self.sync(X)
        for blk in self.lifted:
            with blk.b.localForm() as bl:
                bl.set(0.0)
            fpetsc.apply_lifting(blk.b, [blk.J], [blk.bcs], [blk.vec], -1.0)   # (the scale: `scale` in 0.5, `alpha` in 0.9)
            b[blk.lo:blk.hi] += blk.b.array_r[: blk.hi - blk.lo]

    def add_jacobian(self, A, X):
        """Add the bodies' Jacobians into A (zeroed before); False when the room for entries outside
        the pattern was too small (it is doubled: zero A and try again)."""
        ffi = self.J.mod.ffi
        da = ffi.cast("double*", self.diag.open())
        bc, di, dj, no_ghost, bc_diag = self._views
        try:
            ng = self.J.add_matrix(X, bc, self.size, da, di, dj, no_ghost, self.room)
            if ng >= 0 and len(self.bc_diag):
                self.J.mod.lib.rodfem_set(da, len(self.bc_diag), bc_diag, 1.0)
        finally:
            self.diag.close()
        if ng < 0:
            self._room(2 * len(self.room[0]))
            return False
        if ng:
            from petsc4py import PETSc
            rows, cols, vals = (a[:ng] for a in self.room)
            for r, c, v in zip(rows, cols, vals):
                A.setValues([int(r)], [int(c)], [float(v)], addv=PETSc.InsertMode.ADD_VALUES)
        return True


def group(blocks, size):
    """The blocks in batches of the same compiled forms (serial, every block with a fast Jacobian; a
    batch of one body still saves DOLFINx's packing and calls), and the others: (batches, other blocks)."""
    by_key, others = {}, []
    for blk in blocks:
        if blk.fast is not None and batchable(blk.F) and batchable(blk.J):
            by_key.setdefault((kernel_key(blk.F), kernel_key(blk.J)), []).append(blk)
        else:
            others.append(blk)
    batches = []
    for members in by_key.values():
        try:
            batches.append(BlockBatch(members, size))
        except ValueError:   # coefficients the batch cannot gather: body by body
            others += members
    return batches, others


class Functionals:
    """One functional of many bodies (their H, supplied work, an observable), each body's value:
    the bodies of the same compiled form in batches (serial), a body spread over ranks by a batch of
    its own on this rank's cells (its value here: this rank's part of the sum), the others by DOLFINx.

        f = Functionals(forms, iterates, offsets, size)   # forms[b]: body b's form or None
        f.values(X)                                        # [value of body b, for b with a form]
    """

    def __init__(self, forms, iterates, offsets, size, batch=True):
        from dolfinx import fem
        self._assemble = fem.assemble_scalar
        present = [b for b, f in enumerate(forms) if f is not None]
        spread = [b for b in present if forms[b].mesh.comm.size > 1]
        by_key = {}
        for b in present:
            if batch and b not in spread and batchable(forms[b]):
                by_key.setdefault(kernel_key(forms[b]), []).append(b)
        self.batches = []
        self.single = [b for b in present if b not in spread and not (batch and batchable(forms[b]))]
        for members in by_key.values():
            try:
                self.batches.append((FormBatch([forms[b] for b in members], [iterates[b] for b in members],
                                               [offsets[b] for b in members], size), members))
            except ValueError:
                self.single += members
        self.spread = self._spread(forms, iterates, spread) if batch and spread else []
        self.single += [b for b in spread if b not in {m for _, m, _ in self.spread}]
        self.forms, self.order = forms, present

    @staticmethod
    def _spread(forms, iterates, bodies):
        """[(batch, b, x)] of the bodies spread over ranks that the batch can take (`spread_batch`; at 10^5
        planar elements on two ranks DOLFINx packed every functional's coefficients at every call, 0.25 s
        of a 20-step run)."""
        made = [(spread_batch(forms[b], iterates[b]), b, iterates[b]) for b in bodies]
        return [m for m in made if m[0] is not None]

    def values(self, X):
        """Each body's value at X (X: the system's x_{n+1}; the bodies' other coefficients as they are)."""
        if not self.single and not self.spread and len(self.batches) == 1 and self.batches[0][1] == self.order:
            return self.batches[0][0].scalars(X).tolist()   # (one batch: its order)
        out = {}
        for batch, members in self.batches:
            out.update(zip(members, batch.scalars(X).tolist()))
        for batch, b, x in self.spread:   # (x's ghosts are current: set_state)
            out[b] = float(batch.scalars(x.x.array)[0])
        for b in self.single:
            out[b] = self._assemble(self.forms[b])
        return [out[b] for b in self.order]
