"""Residual and Jacobian of a system of bodies on one block vector X = (x_1, ..., x_k, lambda).

Each body i has its own mesh, mixed space and compiled forms F_i, J_i; the unknown of a time
step (or of a static solve) is the block vector of all bodies' owned dofs followed by the
multipliers of the couplings between them (joints, all owned by rank 0).  This module knows
no joint: a `Coupling` (rodfem/core/system.py) gives its rows, columns and values in global
block indices.

    layout    = BlockLayout(comm, [V_1, ..., V_k], n_multipliers)
    assembler = BlockAssembler(layout, [BodyBlock(F_i, J_i, x_i, bcs_i) ...], coupling)
    Newton(assembler)                       # rodfem/nls/newton.py

Every body's Jacobian block goes through rodfem/fem/fastassembly.py (FFCx's element kernels
added straight into the CSR arrays of the one PETSc matrix, only the entries that can be
nonzero); a form it cannot take (64-bit PETSc indices, dof transformations) is assembled by
DOLFINx into a matrix of its own and copied into the block.  The matrix holds, from the start,
every body's entries, the couplings' entries and the whole diagonal (zero for multipliers).
"""
import numpy as np
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

from rodfem.fem import compat
from rodfem.fem.fastassembly import FastJacobian


class BlockLayout:
    """Where each block's owned dofs sit in the rank's part of X: block i (a body) at
    offsets[i]:offsets[i+1], then the multipliers (all on rank 0).  Global index of local
    position p: start + p."""

    distributed = False   # (every body over all ranks; RankLayout: each body whole on one rank)

    def __init__(self, comm, spaces, n_multipliers=0):
        self.comm, self.spaces = comm, list(spaces)
        self.n_multipliers = int(n_multipliers)
        sizes = [V.dofmap.index_map.size_local * V.dofmap.index_map_bs for V in self.spaces]
        sizes.append(self.n_multipliers if comm.rank == 0 else 0)
        self.sizes = np.array(sizes, dtype=np.int64)
        self.offsets = np.concatenate([[0], np.cumsum(self.sizes)])
        self.all_sizes = np.array(comm.allgather(self.sizes))                 # [rank, block]
        self.ranges = np.concatenate([[0], np.cumsum(self.all_sizes.sum(axis=1))])
        self.start = int(self.ranges[comm.rank])
        self.size_local, self.size_global = int(self.offsets[-1]), int(self.ranges[-1])
        self.multipliers = int(self.all_sizes[0, :-1].sum()) + np.arange(self.n_multipliers)   # global indices

    def owned_multipliers(self):
        """(positions k in the joints' multipliers, local indices in X) of the multipliers this rank owns."""
        k = np.flatnonzero((self.multipliers >= self.start) & (self.multipliers < self.start + self.size_local))
        return k, (self.multipliers[k] - self.start).astype(np.int64)

    def local_to_global(self, i):
        """Global indices of block i's local dofs (owned, then ghosts, as in its Function)."""
        V = self.spaces[i]
        imap, bs = V.dofmap.index_map, V.dofmap.index_map_bs
        owned = self.start + self.offsets[i] + np.arange(self.sizes[i])
        ghosts, owners = np.asarray(imap.ghosts, dtype=np.int64), np.asarray(imap.owners, dtype=np.int64)
        starts = np.array(self.comm.allgather(imap.local_range[0]), dtype=np.int64)
        block_start = self.ranges[:-1] + self.all_sizes[:, :i].sum(axis=1)           # per rank
        base = block_start[owners] + (ghosts - starts[owners]) * bs
        return np.concatenate([owned, (base[:, None] + np.arange(bs)[None, :]).ravel()]).astype(np.int64)

    def owner(self, rows):
        """The rank owning each global row."""
        return np.searchsorted(self.ranges, rows, side="right") - 1

    def create_vector(self):
        return PETSc.Vec().createMPI((self.size_local, self.size_global), comm=self.comm)

    def _pattern(self, entries, A=None):
        """The CSR structure (indptr, cols) of this rank's rows holding the (rows, cols) pairs of `entries`
        (global; a rank may list rows of another), the whole diagonal and A's present pattern (collective)."""
        N, lo, hi = self.size_global, self.start, self.start + self.size_local
        rows = np.concatenate([np.asarray(r, np.int64).ravel() for r, _ in entries] + [np.zeros(0, np.int64)])
        cols = np.concatenate([np.asarray(c, np.int64).ravel() for _, c in entries] + [np.zeros(0, np.int64)])
        if self.comm.size > 1:   # the entries of other ranks' rows go to their owners
            away = (rows < lo) | (rows >= hi)
            owner = self.owner(rows[away])
            got = self.comm.alltoall([np.stack([rows[away][owner == p], cols[away][owner == p]])
                                      for p in range(self.comm.size)])
            rows = np.concatenate([rows[~away]] + [g[0] for g in got])
            cols = np.concatenate([cols[~away]] + [g[1] for g in got])
        if A is None:
            # duplicates merged row by row (a linear pass and a sort within each row, not a sort of all the
            # entries: the same pattern, at 2e4 planar elements 0.54 instead of 0.93 s)
            import scipy.sparse as sp
            diagonal = np.arange(lo, hi, dtype=np.int64)
            pattern = sp.coo_matrix((np.ones(len(rows) + len(diagonal), np.int8),
                                     (np.concatenate([rows, diagonal]) - lo, np.concatenate([cols, diagonal]))),
                                    shape=(self.size_local, N)).tocsr()
            pattern.sum_duplicates()
            pattern.sort_indices()
            return pattern.indptr.astype(PETSc.IntType), pattern.indices.astype(PETSc.IntType)
        # A's keys are sorted (CSR: rows in order, columns sorted in each): merge the missing ones in
        key = np.unique(rows * N + cols)
        indptr, cols, _ = A.getValuesCSR()
        rows = self.start + np.repeat(np.arange(len(indptr) - 1, dtype=np.int64), np.diff(indptr))
        present = rows * N + np.asarray(cols, np.int64)
        at = np.searchsorted(present, key)
        missing = (at >= len(present)) | (present[np.minimum(at, len(present) - 1)] != key)
        key = np.insert(present, at[missing], key[missing])
        rows, cols = np.divmod(key, N)
        indptr = np.concatenate([[0], np.cumsum(np.bincount(rows - self.start, minlength=self.size_local))])
        return indptr.astype(PETSc.IntType), cols.astype(PETSc.IntType)

    def create_matrix(self, entries):
        """An AIJ matrix with the (rows, cols) pairs of `entries` (global; a rank may list rows of
        another) and the whole diagonal; new entries may still be inserted later."""
        N = self.size_global
        A = PETSc.Mat().createAIJ(((self.size_local, N), (self.size_local, N)), csr=self._pattern(entries), comm=self.comm)
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)   # the pattern may grow
        A.assemble()
        return A

    def extend_matrix(self, A, entries):
        """Add the (rows, cols) pairs of `entries` to A's pattern in one re-preallocation (collective; A's
        values are zeroed): many new entries at once without PETSc reallocating the matrix for each."""
        A.setPreallocationCSR(self._pattern(entries, A))
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        A.assemble()


class RankLayout(BlockLayout):
    """The layout of bodies placed whole on ranks (rodfem/core/placement.py): rank r holds its own bodies'
    dofs, then the multipliers of the joints it owns, so that a joint between two bodies of one rank
    couples nothing across ranks.  Block i is the rank's i-th body; global index of local position p:
    start + p, as for BlockLayout.

    body_sizes: the sizes of this rank's bodies; bodies: their indices among all the system's bodies;
    joint_owner[k], joint_size[k]: the rank and number of multipliers of joint k (the same on every rank).
    `body_start[b]`: the global index of body b's first dof (every body, on every rank)."""

    distributed = True

    def __init__(self, comm, spaces, bodies, joint_owner, joint_size):
        self.comm, self.spaces = comm, list(spaces)
        joint_owner = np.asarray(joint_owner, dtype=np.int64)
        joint_size = np.asarray(joint_size, dtype=np.int64)
        mine = joint_size[joint_owner == comm.rank]
        self.n_multipliers = int(mine.sum())
        sizes = [V.dofmap.index_map.size_local * V.dofmap.index_map_bs for V in self.spaces]
        self.sizes = np.array(sizes + [self.n_multipliers], dtype=np.int64)
        self.offsets = np.concatenate([[0], np.cumsum(self.sizes)])
        self.size_local = int(self.offsets[-1])
        placed = comm.allgather((list(bodies), sizes, self.size_local))
        self.ranges = np.concatenate([[0], np.cumsum([p[2] for p in placed])]).astype(np.int64)
        self.start, self.size_global = int(self.ranges[comm.rank]), int(self.ranges[-1])
        self.body_start = {}
        for r, (ids, szs, _) in enumerate(placed):
            for b, lo in zip(ids, self.ranges[r] + np.concatenate([[0], np.cumsum(szs)])[:-1]):
                self.body_start[b] = int(lo)
        # the multipliers of joint k: after its owner's bodies, in the joints' order
        bodies_end = {r: int(self.ranges[r] + sum(p[1])) for r, p in enumerate(placed)}
        out, used = [], {}
        for r, n in zip(joint_owner.tolist(), joint_size.tolist()):
            lo = bodies_end[r] + used.get(r, 0)
            out.append(np.arange(lo, lo + n, dtype=np.int64))
            used[r] = used.get(r, 0) + n
        self.multipliers = np.concatenate(out) if out else np.zeros(0, np.int64)

    def local_to_global(self, i):
        """Global indices of block i's dofs (a body on one rank: all owned, no ghosts)."""
        return self.start + self.offsets[i] + np.arange(self.sizes[i], dtype=np.int64)


class BodyBlock:
    """One body's rows of the system: compiled residual F and Jacobian J = dF/dx of its state
    Function x (x_{n+1}), its Dirichlet conditions bcs (rows replaced by x - x_D = 0)."""

    def __init__(self, F, J, x, bcs):
        self.F, self.J, self.x, self.bcs = F, J, x, list(bcs)
        self.vec = compat.petsc_vec(x)
        self.b = compat.create_vector(F)
        self.fast = FastJacobian(J, self.bcs) if FastJacobian.usable(J) else None
        self.kernels = self._spread_residual()

    def _spread_residual(self):
        """A body spread over ranks: its residual by the batched kernel loop on this rank's cells
        (rodfem/fem/batch.py: x's values read in place, no packing of coefficients; DOLFINx's sums, bit for
        bit: checked against its packing when made), or None (serial bodies are batched by the assembler;
        a form the loop cannot take: DOLFINx's assembly).  At 10^5 planar elements on two ranks: a residual
        12.4 -> 9.0 ms per rank, DOLFINx's packing alone 2.3 ms of it."""
        from rodfem.fem import batch
        if self.x.function_space.mesh.comm.size == 1 or self.fast is None:
            return None
        return batch.spread_batch(self.F, self.x)

    def place(self, layout, i):
        self.layout, self.i = layout, i
        self.lo, self.hi = int(layout.offsets[i]), int(layout.offsets[i + 1])
        self.l2g = layout.local_to_global(i)

    def entries(self):
        """(rows, cols), global, of the entries the block can have."""
        if self.fast:
            r, c = self.fast.entries()
            return self.l2g[r], self.l2g[c]
        self._own = fpetsc.create_matrix(self.J)     # DOLFINx's assembly into a matrix of its own
        fpetsc.assemble_matrix(self._own, self.J, bcs=self.bcs)
        self._own.assemble()
        indptr, cols, _ = self._own.getValuesCSR()
        imap, bs = self.x.function_space.dofmap.index_map, self.x.function_space.dofmap.index_map_bs
        nodes = imap.local_to_global(np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32))
        body_global = (np.asarray(nodes, np.int64)[:, None] * bs + np.arange(bs)[None, :]).ravel()
        order = np.argsort(body_global)
        self._column = lambda g: self.l2g[order[np.searchsorted(body_global[order], g)]]
        rows = np.repeat(np.arange(len(indptr) - 1), np.diff(indptr))
        return self.l2g[rows], self._column(cols)

    def attach(self, A, shared=None):
        if self.fast:
            self.fast.attach(A, self.lo, self.l2g, shared)

    # -- the state and the residual ---------------------------------------------------------
    def set_state(self, X):
        """x <- block i of the array X (the rank's part of the block vector), ghosts updated."""
        self.x.x.array[: self.hi - self.lo] = X[self.lo:self.hi]
        self.x.x.scatter_forward()

    def residual(self, b):
        """Block i of the array b <- F(x) (Dirichlet rows: x - x_D, as DOLFINx's lifting gives them)."""
        with self.b.localForm() as bl:
            bl.set(0.0)
            if self.kernels is not None:   # (this rank's cells; x's ghosts are current: set_state)
                self.kernels.vector(self.x.x.array, bl.array)
        if self.kernels is None:
            fpetsc.assemble_vector(self.b, self.F)
        # (without conditions the lifting is zero, but DOLFINx would pack J's coefficients; so it is where x
        # meets them, as always after the start)
        if self.bcs and (self.kernels is None or self._off_conditions()):
            fpetsc.apply_lifting(self.b, [self.J], [self.bcs], [self.vec], -1.0)   # (the scale: `scale` in 0.5, `alpha` in 0.9)
        self.b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        if self.bcs:
            fpetsc.set_bc(self.b, self.bcs, self.vec, -1.0)
        b[self.lo:self.hi] = self.b.array_r[: self.hi - self.lo]

    def _off_conditions(self):
        """Whether x differs from a Dirichlet value at one of this rank's constrained dofs."""
        x = self.x.x.array
        for bc in self.bcs:
            dofs = np.asarray(bc.dof_indices()[0])
            g = compat.dirichlet_values(bc)
            if np.any(g[dofs] != x[dofs]):
                return True
        return False

    # -- the Jacobian ----------------------------------------------------------------------------
    def add_jacobian(self, A):
        """Add J into its block of A (A zeroed before, assembled after by the caller); False when
        the fast assembly ran out of room for its off-pattern entries (zero A and try again)."""
        if self.fast:
            return self.fast.add(A)
        self._own.zeroEntries()
        fpetsc.assemble_matrix(self._own, self.J, bcs=self.bcs)
        self._own.assemble()
        indptr, cols, vals = self._own.getValuesCSR()
        gcols = self._column(cols)
        for r in range(len(indptr) - 1):
            a, e = indptr[r], indptr[r + 1]
            A.setValues(self.l2g[r:r + 1].astype(PETSc.IntType), gcols[a:e].astype(PETSc.IntType), vals[a:e],
                        addv=PETSc.InsertMode.ADD_VALUES)
        return True

    def restructure(self, shared=None):
        if self.fast:
            self.fast.restructure(shared)


class BlockAssembler:
    """F(X) and J(X) of the blocks and their coupling (see the module docstring).

    coupling: None, or an object with ``entries()`` -> [(rows, cols)] global index arrays,
    ``residual(X, b)`` and ``jacobian(X, A)`` adding its terms (global indices, any rank), and
    ``update(X)`` called before either with the iterate; optionally ``grow()`` (collective), called
    before each Jacobian: None, or [(rows, cols)] to add to the pattern first (`extend_matrix`), and
    ``local_rows`` (True: it adds to its own rank's rows only; with a RankLayout no entry is then
    exchanged between ranks).
    """

    def __init__(self, layout, blocks, coupling=None, batch=False):
        """batch: assemble bodies of the same compiled forms together (rodfem/fem/batch.py; serial, or
        bodies placed whole on ranks: a RankLayout)."""
        self.layout, self.blocks, self.coupling = layout, list(blocks), coupling
        self.comm = layout.comm
        for i, blk in enumerate(self.blocks):
            blk.place(layout, i)
        self.bcs = [bc for blk in self.blocks for bc in blk.bcs]
        self.vector = layout.create_vector()    # the unknown X that Newton iterates on
        self.batches, self.single = [], self.blocks
        if batch and (self.comm.size == 1 or layout.distributed):   # (bodies on one rank each)
            from rodfem.fem.batch import group
            self.batches, self.single = group(self.blocks, layout.size_local)
        self.units = self.batches + self.single   # what assembles: batches, and the blocks on their own
        entries = [u.entries() for u in self.units] + (coupling.entries() if coupling else [])
        self.A = layout.create_matrix(entries)
        # bodies whole on ranks and a coupling that adds to its own rank's rows only: no entry for another
        # rank, so the matrix's assembly exchanges none (PETSc skips its stash) and the residual needs none
        self.local_rows = layout.distributed and (coupling is None or bool(getattr(coupling, "local_rows", False)))
        if self.local_rows:
            self.A.setOption(PETSc.Mat.Option.NO_OFF_PROC_ENTRIES, True)
        for u in self.units:
            u.attach(self.A)
        self._state = self._nonzero_state(self.A)

    def create_vector(self):
        return self.layout.create_vector()

    def create_matrix(self):
        return self.A

    def update(self, xin):
        """Make the forms see the iterate xin (into X and every body's Function)."""
        X = self._iterate(xin)
        for batch in self.batches:
            batch.sync(X)

    def _iterate(self, xin):
        """X <- xin, seen by the bodies on their own and the coupling (a batch reads X itself)."""
        if xin.handle != self.vector.handle:
            xin.copy(self.vector)
        X = self.vector.getArray(readonly=True)
        for blk in self.single:
            blk.set_state(X)
        if self.coupling:
            self.coupling.update(self.vector)
        return X

    def pull(self):
        """X <- every block's Function (the reverse of `update`)."""
        X = self.vector.getArray()
        for blk in self.blocks:
            X[blk.lo:blk.hi] = blk.x.x.array[: blk.hi - blk.lo]

    def residual(self, xin, b):
        X = self._iterate(xin)
        arr = b.getArray()
        arr[:] = 0.0
        for batch in self.batches:
            batch.residual(X, arr)
        for blk in self.single:
            blk.residual(arr)
        del arr
        if self.coupling:
            self.coupling.residual(self.vector, b)
            if not self.local_rows:
                b.assemblyBegin()
                b.assemblyEnd()

    def jacobian(self, xin, A):
        X = self.vector.getArray(readonly=True)   # the iterate of the last residual (SNES: the same x)
        grow = getattr(self.coupling, "grow", None)
        extra = grow() if grow is not None else None   # entries the coupling needs that the pattern lacks
        if extra is not None:
            self.layout.extend_matrix(A, extra)
            for u in self.units:
                u.restructure()
            self._state = self._nonzero_state(A)
        while True:
            A.zeroEntries()
            if all(u.add_jacobian(A, X) for u in self.batches) and all(blk.add_jacobian(A) for blk in self.single):
                break
        if self.coupling:
            self.coupling.jacobian(self.vector, A)
        A.assemble()
        state = self._nonzero_state(A)
        if state != self._state:   # an entry outside the pattern was inserted: re-read the structure
            for u in self.units:
                u.restructure()
            self._state = state

    @staticmethod
    def _nonzero_state(A):
        from rodfem.fem import petsc_raw
        return petsc_raw.nonzero_state(A) if petsc_raw.usable() else 0


def allreduce_max(comm, array):
    """Elementwise maximum over the ranks (each entry known on the rank that owns it, -1 or -inf elsewhere)."""
    array = np.ascontiguousarray(array, dtype=float if np.asarray(array).dtype.kind == "f" else np.int64)
    comm.Allreduce(MPI.IN_PLACE, array, op=MPI.MAX)
    return array


def allreduce_sum(comm, array):
    """The sum over the ranks of a float array, as a new array (one MPI_Allreduce on its buffer: without
    mpi4py's pickling of the lower-case allreduce, microseconds instead of tens of them)."""
    array = np.array(array, dtype=float, order="C")
    if comm.size > 1:
        comm.Allreduce(MPI.IN_PLACE, array, op=MPI.SUM)
    return array
