"""The parallel direct solver: exact block elimination over the rank interfaces (a Schur complement).

A rod, beam or chain of bodies split over ranks couples the ranks through a handful of
dofs (the state at a shared node: 6 for the planar beam, 30 for the 3D rod).  Off-the-shelf
parallel LU (MUMPS, superlu_dist) does not see that: on this 2-core machine it was 4-10x
slower than serial LU and ran out of workspace at 10^4 planar elements (issue 11).

`InterfaceSchur` (a PETSc PC of type python, the default of `mpirun` runs) eliminates
instead.  Split the unknowns into an interface G (a small global set that cuts every
coupling between ranks: for each entry A_ij with i, j on different ranks, i or j is in G)
and the interiors I_r of the ranks (owned dofs not in G).  Interiors of different ranks do
not couple, so with the Schur complement (|G| x |G|, dense)

    S = A_GG - sum_r A_GIr A_IrIr^{-1} A_IrG

the solution of A x = b is

    y_r = A_IrIr^{-1} b_Ir                          (each rank, its own sparse LU)
    S x_G = b_G - sum_r A_GIr y_r                    (one allreduce of |G| numbers, dense solve)
    x_Ir = y_r - Z_r x_G,   Z_r = A_IrIr^{-1} A_IrG   (computed once per Jacobian)

This is Gaussian elimination in another order, not an iteration: the result is that of a
direct solve, to round-off (no Krylov tolerance to choose).

Each rank computes its term of S straight out of its LU (rodfem/la/partial_lu.py: the rank's
rows with the interface ordered last, Gaussian elimination stopped before it, the corner
left over is -A_GI A_II^{-1} A_IG).  A new Jacobian then costs one local factorization and
an allreduce of |G|^2 numbers; an application one forward and one backward sweep and an
allreduce of |G| numbers.  On one rank G is empty and this is a plain sparse LU (fill-reducing
order, no pivoting; its factor kept split, L in row order and U in reverse row order, for the
sweeps): the serial LU chain's stage after PETSc's LU meets a zero pivot (rodfem/nls/newton.py).

Dofs with a zero diagonal (multipliers) are ordered after the dofs they couple to, so that their
pivot is not zero; an interface node's multipliers whose constrained dofs are all on the
interface join the interface (in the interior their rows would be empty).  The local order is
the one with the least fill of RCM (either way round: the fill depends on the direction) and
AMD, the interface side last; a zero pivot switches it, for the rest of the run, to nested
dissection of the graph in RCM order, then to AMD, and a zero pivot there to sequential MUMPS,
which pivots.  MUMPS has no such partial factorization through PETSc 3.18, so that stage solves for
the interface columns instead: Z_r = A_IrIr^{-1} A_IrG, one MatMatSolve per Jacobian (MUMPS
solves the columns together; on the 3D rod, 30 columns cost more than the factorization), and
x_Ir = y_r - Z_r x_G.  For that stage the rank factors its diagonal block D (owned rows and
columns) with its interface rows replaced by identity rows, M = [[A_II, A_IG], [0, I]] (rows
zeroed in place and restored after the factorization): M [y; 0] = [b_I; 0] gives y = A_II^{-1}
b_I and M z = e_g gives z = [-Z e_g; e_g].  A local block that MUMPS cannot factor either
(singular) makes the PC fall back to MUMPS on the whole matrix for the rest of the run.
"""
import atexit
import gc
import time
import warnings
import weakref

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc
from scipy.linalg import LinAlgWarning

from rodfem.fem import petsc_raw
from rodfem.fem.assembly import allreduce_sum
from rodfem.la.partial_lu import PartialLU

INTERIOR_SOLVERS = ("rcm", "nd", "amd", "superlu", "mumps")   # rcm, nd, amd: rodfem/la/partial_lu.py, that order
FOLLOWING = {"rcm": "nd", "nd": "amd", "amd": "mumps", "superlu": "mumps"}   # after a zero pivot
PARTIAL = ("rcm", "nd", "amd")
_LIVE = weakref.WeakSet()


@atexit.register   # registered after petsc4py's finalization, so it runs before it
def _clean_up():
    """Destroy the parallel PETSc objects Python has dropped while Python still runs.

    petsc4py does not destroy a parallel object when Python frees it (that must be
    collective): it puts it on a garbage list that PetscFinalize empties.  A SNES whose PC is
    this Python class would then call back into an interpreter that has shut down (a
    segmentation fault at exit).  A Newton is part of a reference cycle (its SNES calls its
    methods), so collect cycles first, then empty the list (collective: every rank exits
    through here)."""
    if _LIVE and PETSc.Sys.isInitialized() and not PETSc.Sys.isFinalized():
        gc.collect()
        PETSc.garbage_cleanup()


def interface(pairs_of_ranks):
    """The interface G: for each pair of ranks r < s, the coupled dofs of r or those of s, whichever
    are fewer.  `pairs_of_ranks[r]` lists (i, j, s) for each entry A_ij of rank r's rows with
    column j owned by rank s != r.  Every rank computes the same set from the gathered lists."""
    sides = {}
    for r, prs in enumerate(pairs_of_ranks):
        for i, j, s in prs:
            lower, upper = sides.setdefault((min(r, s), max(r, s)), (set(), set()))
            (lower if r < s else upper).add(int(i))   # the row, on rank r
            (upper if r < s else lower).add(int(j))   # the column, on rank s
    gamma = set()
    for key in sorted(sides):
        lower, upper = sides[key]
        gamma |= lower if len(lower) <= len(upper) else upper
    return np.array(sorted(gamma), dtype=np.int64)


class InterfaceSchur:
    """PCPYTHON context: exact elimination of the rank interiors, dense Schur complement on the interface."""

    def __init__(self):
        self.pattern = None       # nonzero count the interface was computed for
        self.solver = "rcm"       # local LU: rcm (least fill of RCM, AMD) -> nd -> amd (partial LU) -> mumps
        self.plu = None           # the partial LU (rcm, nd, amd)
        self.fallback = None      # KSP with MUMPS on the whole matrix (a local block singular)
        self.ksp = None
        self.nG = 0
        self._no_interface = np.zeros(0)
        self.ready = False        # set up for the current operator
        self.failed = False       # serial: no order without a zero pivot (Newton takes the next LU)
        self.times = dict.fromkeys(("extract", "zero", "lu", "restore", "Z", "S", "solve"), 0.0)
        _LIVE.add(self)

    # -- PCPYTHON interface ---------------------------------------------------------
    def setFromOptions(self, pc):
        opts = PETSc.Options(pc.getOptionsPrefix())
        solver = opts.getString("schur_local_solver", self.solver)
        if solver not in INTERIOR_SOLVERS:
            raise ValueError(f"-{pc.getOptionsPrefix()}schur_local_solver {solver}: one of {INTERIOR_SOLVERS}")
        self.solver = solver

    def setUp(self, pc):
        A, _ = pc.getOperators()
        self.comm = A.getComm().tompi4py()
        nz = self._pattern_key(A)
        if self.fallback is not None and nz != self.pattern:
            # a new pattern (contact entries added): MUMPS afresh (MUMPS 5.7 crashes in its
            # redistribution when a factorization is redone on a matrix whose pattern grew)
            self.fallback.destroy()
            self._fall_back(pc)
            self.pattern = nz
        if self.fallback is None:
            if nz != self.pattern:
                self._split(A)
                self.pattern = nz
            if self._factor(A):
                self.ready = True
                return
            if self.comm.size == 1:   # a zero pivot in every order: Newton goes on to the next LU
                petsc_raw.pc_set_failed(pc)
                self.failed = self.ready = True
                return
            self._fall_back(pc)
        self.fallback.setOperators(A)
        self.fallback.setUp()
        self.ready = True

    def _pattern_key(self, A):
        """What changes when A's nonzero pattern changes, the same on every rank: A's identity and its
        number of nonzeros summed over the ranks (collective).  Not PETSc's nonzero state: entries put
        in preallocated places (the contact's pattern grown ahead) leave it unchanged."""
        nz = A.getInfo(PETSc.Mat.InfoType.LOCAL)["nz_used"]
        return (A.handle, nz if self.comm.size == 1 else self.comm.allreduce(nz, op=MPI.SUM))

    def apply(self, pc, b, x):
        """x = A^{-1} b; a singular A (no finite solution on some rank, or MUMPS refusing it) marks
        the PC failed on every rank: Newton sees DIVERGED_LINEAR_SOLVE, not a PETSc error."""
        if self.failed:
            x.set(np.nan)
            return
        if not self.ready:
            # a context made afresh by the options (Newton's settings applied again after a failed
            # step) while the chord Newton keeps its Jacobian: PETSc does not set it up again
            self.setUp(pc)
        if self.plu is not None and self.nG == 0 and self.comm.size == 1 and self.fallback is None:
            # one rank's partial LU: two sweeps in C, no interface (nothing to warn or reduce);
            # a Newton step of the 3D rod applies it 8 times
            t0, out = time.perf_counter(), x.getArray()
            self.plu.forward(b.getArray(readonly=True))
            self.plu.backward(self._no_interface, out)
            self.times["solve"] += time.perf_counter() - t0
            if not np.isfinite(out).all():
                petsc_raw.pc_set_failed(pc)
            return
        try:
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", LinAlgWarning)
                self._apply(b, x)
        except PETSc.Error:   # MUMPS (the fallback) on a singular matrix
            x.set(np.nan)
        with np.errstate(invalid="ignore"):
            finite = bool(np.all(np.isfinite(x.getArray(readonly=True))))
        if allreduce_sum(self.comm, [0.0 if finite else 1.0])[0] > 0.0:   # (any rank's solution not finite)
            petsc_raw.pc_set_failed(pc)

    def _apply(self, b, x):
        if self.fallback is not None:
            self.fallback.solve(b, x)
            return
        t0 = time.perf_counter()
        barr = b.getArray(readonly=True)
        if self.plu is not None:
            zG = self.plu.forward(barr)
            xG = np.zeros(0)
            if self.nG:
                g = np.zeros(self.nG)
                g[self.G_own_pos] = barr[self.G_own]
                xG = self._solve_interface(allreduce_sum(self.comm, g + zG))
            out = x.getArray()
            self.plu.backward(xG, out)
            if self.nG:
                out[self.G_own] = xG[self.G_own_pos]
            self.times["solve"] += time.perf_counter() - t0
            return
        self.rhs.array[:] = barr
        self.rhs.array[self.G_own] = 0.0
        self.ksp.solve(self.rhs, self.sol)
        y = self.sol.array
        if self.nG:
            g = np.zeros(self.nG)
            g[self.G_own_pos] = barr[self.G_own]
            g -= self.AGC @ y[self.C]
            xG = self._solve_interface(allreduce_sum(self.comm, g))
            if len(self.ZG):
                y = y - self.Z @ xG[self.ZG]
            y[self.G_own] = xG[self.G_own_pos]
        x.getArray()[:] = y
        self.times["solve"] += time.perf_counter() - t0

    def _solve_interface(self, g):
        from scipy.linalg import lu_solve
        return lu_solve(self.S_lu, g)

    def reset(self, pc):
        self.pattern = None
        self.ready = self.failed = False

    def destroy(self, pc):
        self.release()

    def release(self):
        """Destroy the PETSc objects this context made (it sets itself up again when used)."""
        for obj in [self.ksp, self.fallback, getattr(self, "rhs", None), getattr(self, "sol", None),
                    getattr(self, "B", None), getattr(self, "X", None)]:
            if obj is not None:
                obj.destroy()
        self.ksp = self.fallback = self.B = self.X = self.plu = None
        self.pattern = None
        self.ready = False

    def view(self, pc, viewer):
        viewer.printfASCII(f"  interface Schur complement: {self.nG} interface dofs, local LU {self.describe()}\n")

    def describe(self):
        return "mumps" if self.fallback is not None else f"schur({self.solver})"

    # -- the interface (once per nonzero pattern) ------------------------------------
    def _split(self, A):
        """The interface G and the index sets of its blocks, from the matrix's nonzero structure.

        Only the off-diagonal block (a few entries per interface) and integer passes over the
        diagonal block's column indices are needed, not the values (cost O(nnz) once per run)."""
        comm = self.comm
        if comm.size == 1:
            return self._split_serial(A)
        lo, hi = A.getOwnershipRange()
        n = hi - lo
        ranges = np.array(A.getOwnershipRanges())
        Ad, Ao, garray = petsc_raw.blocks(A)
        if Ao is not None:
            oi, oj = petsc_raw.rowij(Ao)
            ocols = garray[oj]
            orows = np.repeat(np.arange(n), np.diff(oi))
        else:
            ocols = orows = np.zeros(0, np.int64)
        owner = np.searchsorted(ranges, ocols, side="right") - 1
        G = interface(comm.allgather(np.stack([orows + lo, ocols, owner], axis=1)))
        di, dj = petsc_raw.rowij(Ad)
        G = self._with_multipliers(A, G, lo, di, dj, orows, ocols)
        self.G, self.nG = G, len(G)
        own = (G >= lo) & (G < hi)
        self.G_own = (G[own] - lo).astype(PETSc.IntType)   # local indices of the owned interface dofs
        self.G_own_pos = np.flatnonzero(own)                 # and their positions in G
        in_G = np.zeros(n, bool)
        in_G[self.G_own] = True
        # interior rows with an entry in an interface column (A_IG), and those columns
        hit = np.flatnonzero(in_G[dj])
        hit_rows = np.searchsorted(di, hit, side="right") - 1
        hit_cols = dj[hit] + lo
        ohit = np.flatnonzero(np.isin(ocols, G))
        rows = np.concatenate([hit_rows, orows[ohit]]).astype(np.int64)
        cols = np.concatenate([hit_cols, ocols[ohit]]).astype(np.int64)
        interior = ~in_G[rows]
        self.R = np.unique(rows[interior])                               # local rows
        self.ZG = np.unique(np.searchsorted(G, cols[interior]))          # positions in G
        # interior columns of this rank that interface rows (of any rank) reference (A_GI)
        mine = [dj[di[r]:di[r + 1]] + lo for r in self.G_own]
        mine += [ocols[oi[r]:oi[r + 1]] for r in self.G_own] if Ao is not None else []
        referenced = np.concatenate(comm.allgather(np.concatenate(mine) if mine else np.zeros(0, np.int64)))
        self.C_all = np.setdiff1d(np.unique(referenced), G).astype(PETSc.IntType)   # global, every rank's
        mask = (self.C_all >= lo) & (self.C_all < hi)
        self.C = (self.C_all[mask] - lo).astype(PETSc.IntType)            # this rank's, local indices
        self.C_pos = np.flatnonzero(mask)                                  # their positions in C_all
        self.rows_R = (self.R + lo).astype(PETSc.IntType)
        self.rows_Gown = G[own].astype(PETSc.IntType)
        self.cols_G = G.astype(PETSc.IntType)
        self.cols_GC = np.concatenate([G, self.C_all]).astype(PETSc.IntType)
        self.K = self._partial_structure(n, in_G, di, dj, (oi, oj, ocols) if Ao is not None else None)
        self.B = self.X = self.plu = None
        self.rhs = PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF)
        self.sol = self.rhs.duplicate()
        if self.solver not in PARTIAL:
            self._make_ksp()

    def _split_serial(self, A):
        """One rank: no interface (G empty), K = A (what `_split` finds there, without its passes over
        the entries: a third of a 16-element 3D rod's first step)."""
        n = A.getSize()[0]
        di, dj = petsc_raw.rowij(petsc_raw.blocks(A)[0])
        none = np.zeros(0, PETSc.IntType)
        self.G, self.nG = np.zeros(0, np.int64), 0
        self.G_own, self.G_own_pos, self.R, self.ZG = none, np.zeros(0, np.int64), np.zeros(0, np.int64), none
        self.C_all = self.C = self.rows_R = self.rows_Gown = self.cols_G = self.cols_GC = none
        self.C_pos = np.zeros(0, np.int64)
        self.K = self._partial_structure(n, np.zeros(n, bool), di, dj, None)
        self.B = self.X = self.plu = None
        self.rhs = PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF)
        self.sol = self.rhs.duplicate()
        if self.solver not in PARTIAL:
            self._make_ksp()

    def _with_multipliers(self, A, G, lo, di, dj, orows, ocols):
        """G and the dofs with a zero diagonal (multipliers) coupled to it: a multiplier whose
        constrained dofs are all on the interface would have an empty row in A_II (singular)."""
        n = len(di) - 1
        diagonal = A.getDiagonal()
        zero = diagonal.array == 0
        diagonal.destroy()
        in_G = np.zeros(n, bool)
        own = (G >= lo) & (G < lo + n)
        in_G[G[own] - lo] = True
        touches = np.zeros(n, bool)   # rows with an entry in an interface column
        touches[np.searchsorted(di, np.flatnonzero(in_G[dj]), side="right") - 1] = True
        touches[orows[np.isin(ocols, G)]] = True
        extra = np.flatnonzero(zero & touches & ~in_G) + lo
        return np.union1d(G, np.concatenate(self.comm.allgather(extra))).astype(np.int64)

    def _partial_structure(self, n, in_G, di, dj, off):
        """K = [[A_II, A_IG], [A_GI, 0]] of this rank for rodfem/la/partial_lu.py: its CSR (rows: the
        interior in local order, then G), where each entry's value is found (src: the diagonal
        block's values, then the off-diagonal block's, then the gathered A_GC rows), the interior
        (src and interior None: one rank, K the diagonal block itself)."""
        interior = np.flatnonzero(~in_G)
        nI, nG = len(interior), self.nG
        if nG == 0 and off is None:   # (one rank, no interface: K is the diagonal block, in its CSR order)
            return dict(ki=np.asarray(di, np.int64), kj=np.asarray(dj, np.int64), nI=nI, src=None, nD=len(dj),
                        nO=0, interior=None)
        imap = np.full(n, -1, np.int64)
        imap[interior] = np.arange(nI)
        imap[self.G_own] = nI + self.G_own_pos       # owned interface columns -> their place in G
        # the interior rows' entries of the diagonal block, in its CSR order (the few interface rows' left out:
        # no pass of a row index per entry, no sort; a rank's half of 10^5 planar elements: 0.46 -> 0.1 s)
        keep = np.ones(len(dj), bool)
        for r in self.G_own:
            keep[di[r]:di[r + 1]] = False
        src = np.flatnonzero(keep)
        kj = imap[dj[src]]
        per_row = np.diff(di)[interior].astype(np.int64)
        nD, nO = len(dj), 0
        if off is not None:   # an interior row's entries in other ranks' columns (all in G) follow its own
            oi, oj, ocols = off
            nO = len(oj)
            orows = np.repeat(np.arange(n), np.diff(oi))
            okeep = ~in_G[orows]
            pos = np.minimum(np.searchsorted(self.G, ocols[okeep]), max(nG - 1, 0))
            if np.count_nonzero(okeep) and (nG == 0 or not np.array_equal(self.G[pos], ocols[okeep])):
                raise RuntimeError("interface: an interior row couples to another rank outside G")
            rows = imap[orows[okeep]]
            ends = np.cumsum(per_row)[rows]          # (inserted before a row's end: after its own entries, in order)
            kj = np.insert(kj, ends, nI + pos)
            src = np.insert(src, ends, nD + np.flatnonzero(okeep))
            per_row = per_row + np.bincount(rows, minlength=nI)
        per_row = np.concatenate([per_row, np.zeros(nG, np.int64)])
        if nG and len(self.C):   # the interface rows' entries in this rank's interior columns (A_GC), last
            kj = np.concatenate([kj, np.tile(imap[self.C], nG)])
            src = np.concatenate([src, nD + nO + np.arange(nG * len(self.C))])
            per_row[nI:] = len(self.C)
        ki = np.concatenate([[0], np.cumsum(per_row)])
        return dict(ki=ki, kj=kj.astype(np.int64, copy=False), nI=nI, src=src.astype(np.int64, copy=False),
                    nD=nD, nO=nO, interior=interior)

    def _make_ksp(self):
        if self.ksp is not None:
            self.ksp.destroy()
        self.ksp = PETSc.KSP().create(PETSc.COMM_SELF)
        self.ksp.setType("preonly")
        pc = self.ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType(self.solver)
        if self.solver == "mumps":   # sequential MUMPS on this rank's block
            from rodfem.la.lu_chain import mumps_options
            prefix = "rodfem_schur_local_"
            mumps_options(prefix)
            self.ksp.setOptionsPrefix(prefix)
            pc.setFromOptions()

    # -- a new Jacobian: local LU and S -------------------------------------------------
    def _factor(self, A):
        """Factor the local part and form S; False: singular (for every local LU)."""
        from scipy.linalg import lu_factor
        T, t0 = self.times, time.perf_counter()
        if self.nG:   # the interface rows (all ranks'): A_GG and their entries in the interiors
            block = np.zeros((self.nG, len(self.cols_GC)))
            if len(self.rows_Gown):
                block[self.G_own_pos] = A.getValues(self.rows_Gown, self.cols_GC)
            block = allreduce_sum(self.comm, block)
            self.A_GG = block[:, :self.nG]
            self.AGC = np.ascontiguousarray(block[:, self.nG + self.C_pos])
        T["extract"] += time.perf_counter() - t0
        if self.solver in PARTIAL:
            ok = self._factor_partial(A)
        else:
            ok = self._factor_with_columns(A)
        if ok and self.nG:
            with warnings.catch_warnings():   # a singular S: apply() finds the non-finite solution
                warnings.simplefilter("ignore", LinAlgWarning)
                self.S_lu = lu_factor(self.S)
        return ok

    def _factor_partial(self, A):
        """The partial LU of K (rodfem/la/partial_lu.py): S = A_GG + sum_r T_r.  On a zero pivot (any
        rank) the next local LU; False when none is left."""
        while self.solver in PARTIAL:
            t0 = time.perf_counter()
            if self.plu is None:
                K = self.K
                diagonal = A.getDiagonal()   # zero on the multipliers' rows: they are eliminated late
                self.plu = PartialLU(K["ki"], K["kj"], K["nI"], self.nG, K["src"], K["nD"], K["nO"],
                                     method=self.solver, where=K["interior"],
                                     postpone=(diagonal.array if K["interior"] is None
                                               else diagonal.array[K["interior"]]) == 0)
                diagonal.destroy()
            Ad, Ao, _ = petsc_raw.blocks(A, columns=False)
            values = [petsc_raw.Values(h, read=True) for h in (Ad, Ao) if h is not None]
            addresses = [v.open() for v in values]
            try:
                corner = self.plu.factor(addresses[0], addresses[1] if Ao is not None else None,
                                         self.AGC if self.nG else None)
            finally:
                for v in values:
                    v.close()
            self.times["lu"] += time.perf_counter() - t0
            # the ranks' corners summed and their zero pivots counted in one reduction
            t1 = time.perf_counter()
            sums = np.zeros(self.nG * self.nG + 1)
            if corner is not None:
                sums[:-1] = np.ravel(corner) if self.nG else 0.0
            else:
                sums[-1] = 1.0
            sums = allreduce_sum(self.comm, sums)
            if sums[-1] == 0.0:
                if self.nG:
                    self.S = self.A_GG + sums[:-1].reshape(self.nG, self.nG)
                    self.times["S"] += time.perf_counter() - t1
                return True
            self.solver, self.plu = FOLLOWING[self.solver], None
        if self.comm.size == 1:   # a stage of Newton's serial LU chain: the pivoting LUs come next there
            return False
        self._make_ksp()
        return self._factor_with_columns(A)

    def _factor_with_columns(self, A):
        """Factor the local block with its interface rows as identity rows; Z, S (the MUMPS stage)."""
        T, t1 = self.times, time.perf_counter()
        if self.nG:
            A_RG = A.getValues(self.rows_R, self.cols_G) if len(self.rows_R) else np.zeros((0, self.nG))
        D = A.getDiagonalBlock()
        saved = [D.getRow(int(i)) for i in self.G_own]
        D.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
        D.zeroRows(self.G_own, diag=1.0)
        t2 = time.perf_counter()
        T["zero"] += t2 - t1
        try:
            ok = self._local_lu(D)
        finally:
            t3 = time.perf_counter()
            T["lu"] += t3 - t2
            for i, (cols, vals) in zip(self.G_own, saved):
                D.setValues([int(i)], cols, vals, addv=PETSc.InsertMode.INSERT_VALUES)
            D.assemble()
            t4 = time.perf_counter()
            T["restore"] += t4 - t3
        if not ok:
            return False
        if not self.nG:
            return True
        # Z = A_II^{-1} A_IG on the interface columns next to this rank's interior, all columns in
        # one MatMatSolve (MUMPS solves them together, 3x faster than one by one)
        n = self.rhs.getSize()
        own_pos = {int(p): k for k, p in enumerate(self.G_own_pos)}
        k = len(self.ZG)
        if self.B is None or self.B.getSize() != (n, k):
            self.B = PETSc.Mat().createDense((n, k), comm=PETSc.COMM_SELF)
            self.B.setUp()
            self.X = self.B.duplicate()
        rhs = self.B.getDenseArray()
        rhs[:] = 0.0
        sign = np.ones(k)
        for j, g in enumerate(self.ZG):
            if g in own_pos:            # M z = e_g gives z = [-Z e_g; e_g]
                rhs[self.G_own[own_pos[g]], j] = 1.0
                sign[j] = -1.0
            else:                       # an interface column owned by another rank
                rhs[self.R, j] = A_RG[:, g]
        self.B.assemble()
        self.ksp.getPC().getFactorMatrix().matSolve(self.B, self.X)
        self.Z = self.X.getDenseArray() * sign
        self.Z[self.G_own, :] = 0.0
        t5 = time.perf_counter()
        T["Z"] += t5 - t4
        S = np.zeros((self.nG, self.nG))
        S[:, self.ZG] = self.AGC @ self.Z[self.C, :]
        self.S = self.A_GG - self.comm.allreduce(S, op=MPI.SUM)
        T["S"] += time.perf_counter() - t5
        return True

    def _local_lu(self, D):
        """LU of the local block (collective: all ranks agree); the next of FOLLOWING on a zero pivot."""
        while True:
            self.ksp.setOperators(D)
            pc = self.ksp.getPC()
            pc.setReusePreconditioner(False)
            try:   # a zero pivot is a failed set-up, not an error
                self.ksp.setUp()
                pc.setReusePreconditioner(True)   # keep this factor when D's rows are restored
                ok = not petsc_raw.pc_failed(pc)
            except PETSc.Error:
                ok = False
            if self.comm.allreduce(ok, op=MPI.LAND):
                return True
            if self.solver not in FOLLOWING:   # (superlu: chosen by the user)
                return False
            self.solver = FOLLOWING[self.solver]
            self._make_ksp()

    def _fall_back(self, pc):
        """MUMPS on the whole matrix, for the rest of the run (a local block no LU can factor)."""
        prefix = (pc.getOptionsPrefix() or "") + "schur_fallback_"
        ksp = PETSc.KSP().create(pc.getComm())
        ksp.setOptionsPrefix(prefix)
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        ksp.getPC().setFactorSolverType("mumps")
        opts = PETSc.Options(prefix)
        for key, value in (("mat_mumps_icntl_14", 400),   # workspace: the default estimate is too small
                           ("mat_mumps_icntl_7", 0)):     # AMD (the METIS ordering failed at 10^4 elements)
            if not opts.hasName(key):
                opts[key] = value
        ksp.setFromOptions()
        self.fallback = ksp
