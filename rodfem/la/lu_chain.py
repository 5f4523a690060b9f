"""The serial chain of direct solvers: the LU to use after another met a zero pivot.

PETSc's own LU does not pivot; a saddle point (multipliers, zero densities in statics) makes it
fail, and Newton (rodfem/nls/newton.py) switches once, for the rest of the run, to the next LU
of `LU_CHAIN`; the parallel solver (rodfem/la/schur.py) runs the same chain inside the ranks.
"""
from petsc4py import PETSc

# The LUs to try, in order, each after the previous one met a zero pivot (name: PETSc options).
# PETSc's own LU does not pivot: in RCM order a multiplier (the 3D rod's collocated constraints,
# joints) is a zero pivot.  Next comes the partial LU of rodfem/la/partial_lu.py (the parallel
# solver's, here with no interface), which orders the multipliers after the dofs they constrain:
# on the 3D rod's Jacobian (1024 elements, 73,758 unknowns, only its possible nonzeros:
# rodfem/fem/fastassembly.py) it factors in 27 ms and solves in 1.9 ms (in AMD order, the least fill of
# the orders it tries); PETSc's LU in AMD order meets
# a zero pivot there, SuperLU takes 157 / 9.7 ms, MUMPS 390 / 27 ms.  (PETSc's own remedy,
# -pc_factor_nonzeros_along_diagonal, gave 26 / 3.1 ms there but a factor too inaccurate for
# Newton on the tendon arm, and a segmentation fault on its full element pattern.)  An unpivoted
# LU reached that way that then fails Newton with an inaccurate factor (a small pivot, not a zero
# one: rodfem/nls/newton.py, ACCURATE_LU) hands over to the next LU too.  SuperLU's 32-bit memory
# index runs out on large matrices (the 3D rod at 10^4 elements, 1e8 nonzeros: "Not enough memory",
# and destroying that failed factor crashes): above SUPERLU_NONZEROS MUMPS comes straight after.
LU_CHAIN = {"petsc": {"pc_type": "lu", "pc_factor_mat_solver_type": "petsc", "pc_factor_mat_ordering_type": "rcm"},
            "schur": {"pc_type": "python", "pc_python_type": "rodfem.la.schur.InterfaceSchur"},
            "petsc-amd": {"pc_type": "lu", "pc_factor_mat_solver_type": "petsc", "pc_factor_mat_ordering_type": "amd"},
            "superlu": {"pc_type": "lu", "pc_factor_mat_solver_type": "superlu"},
            "mumps": {"pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}}
PIVOTING = ("superlu", "mumps")
SUPERLU_NONZEROS = 4e7


def lu_name(settings):
    """The LU_CHAIN name of the LU that `settings` select."""
    if settings.get("pc_type") == "python":
        return "schur"
    solver = settings.get("pc_factor_mat_solver_type", "petsc")
    if solver == "petsc" and settings.get("pc_factor_mat_ordering_type", "rcm") == "amd":
        return "petsc-amd"
    return solver


# PETSc's LU in RCM order is the serial default (the chains, rods and beams of most scenes: a band).  A
# structure that is no band (a net of strings joined at its crossings: a 2D graph) fills RCM's whole
# envelope; there the partial LU comes first, whose AMD order keeps each multiplier after the dofs it
# constrains (PETSc's LU in AMD order met a zero pivot there).  A 20 x 20 cable net, 20,400 unknowns:
# 3.0e6 entries of the factor in RCM order, 4.3e5 in the partial LU's; ms per step 46.8 -> 14.3.
# `first_lu` decides at the first Jacobian of a system of at least ORDER_TRIAL unknowns by the entries of
# RCM's envelope per entry of the matrix: the beam chains and the hanging cable 0.47 (PETSc's LU kept);
# cable nets of 6 x 6 (2,004 unknowns), 10 x 10 and 14 x 14 crossings 2.1, 3.4 and 4.6, where the partial
# LU's steps took 1.88, 5.63 and 7.10 ms against 2.20, 12.75 and 21.64 (20 steps of each, serial).
ORDER_TRIAL, WIDE = 2000, 2.0


def rcm_envelope(A):
    """The number of entries, per entry of the sequential AIJ matrix A, in the lower envelope of A in RCM
    order (sum over the rows of the distance from the row's first entry to the diagonal): about RCM's fill."""
    import numpy as np

    from rodfem.fem import petsc_raw
    ki, kj = petsc_raw.rowij(petsc_raw.blocks(A)[0])
    rows, _ = A.getOrdering("rcm")
    perm = np.asarray(rows.getIndices())
    rows.destroy()
    n = len(ki) - 1
    position = np.empty(n, np.int64)
    position[perm] = np.arange(n)
    filled = np.diff(ki) > 0
    first = np.full(n, n, np.int64)
    first[filled] = np.minimum.reduceat(position[kj], ki[:-1][filled])
    return float(np.sum(np.maximum(position - np.minimum(first, position), 0))) / max(len(kj), 1)


def first_lu(A):
    """The LU to start with on A (sequential AIJ, its first Jacobian): "schur" (the partial LU) when A has at
    least ORDER_TRIAL rows and RCM's envelope more than WIDE entries per entry of A, else "petsc"."""
    from rodfem.fem import petsc_raw
    if A.getSize()[0] < ORDER_TRIAL or not petsc_raw.usable():
        return "petsc"
    return "schur" if rcm_envelope(A) > WIDE else "petsc"


def next_lu(A, failed):
    """The LU to use after `failed` met a zero pivot on A (sequential AIJ or the local block of a
    rank), or None when there is none left."""
    names = list(LU_CHAIN)
    if failed not in names or failed == names[-1]:
        return None
    following = names[names.index(failed) + 1]
    if following == "superlu" and A.getInfo(PETSc.Mat.InfoType.LOCAL)["nz_used"] > SUPERLU_NONZEROS:
        following = "mumps"
    return following


def mumps_options(prefix):
    """MUMPS with AMD ordering and 4x its workspace estimate (its default METIS ordering and
    workspace failed on these chains at 10^4 elements), unless the user chose otherwise."""
    opts = PETSc.Options()
    for key, value in (("mat_mumps_icntl_7", 0), ("mat_mumps_icntl_14", 300)):
        if not opts.hasName(prefix + key):
            opts[prefix + key] = value


def backward_error(A, solve, b=None):
    """|A x - b| / |b| of x = solve(b) (a factor's accuracy: round-off for a stable LU, large after a small
    pivot of an unpivoted one); b = A x* for a fixed x* (entries 1 to 2) when not given.  inf when the
    solve raises or returns non-finite values; nan when b is not finite (then A or b says nothing of
    the factor)."""
    import numpy as np
    made = []
    if b is None:
        xs = A.createVecRight()
        lo, hi = xs.getOwnershipRange()
        xs.getArray()[:] = 1.0 + np.arange(lo, hi) % 7 / 7.0
        b = A.createVecLeft()
        A.mult(xs, b)
        made += [xs, b]
    x, r = A.createVecRight(), A.createVecLeft()
    made += [x, r]
    try:
        nb = b.norm()
        if not np.isfinite(nb):
            return float("nan")
        try:
            solve(b, x)
        except PETSc.Error:
            return float("inf")
        A.mult(x, r)
        r.axpy(-1.0, b)
        e = r.norm() / nb if nb else r.norm()
        return e if np.isfinite(e) else float("inf")
    finally:
        for v in made:
            v.destroy()
