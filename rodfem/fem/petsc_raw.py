"""The few PETSc C functions petsc4py 3.18 does not wrap, called through ctypes.

- the diagonal and off-diagonal blocks of an MPIAIJ matrix and its off-diagonal column map
  (MatMPIAIJGetSeqAIJ), the CSR structure of a sequential AIJ block (MatGetRowIJ) and its
  value array (MatSeqAIJGetArray / MatSeqAIJRestoreArray: the restore marks it changed; or the
  Read variants, which do not);
- why a PC failed (PCGetFailedReason: a zero pivot in a factorization), and setting it.

The library is the one petsc4py has loaded (same process, same handles).  PetscInt must be
32-bit (Debian's PETSc); callers check `usable()`.
"""
import ctypes
import ctypes.util

import numpy as np
from petsc4py import PETSc

_lib = None


def usable():
    return PETSc.IntType == np.int32


def lib():
    global _lib
    if _lib is None:
        import petsc4py
        names = []
        try:
            conf = petsc4py.get_config()
            names.append(f"{conf['PETSC_DIR']}/lib/libpetsc_{conf.get('PETSC_ARCH', '') or 'real'}.so")
        except Exception:   # pragma: no cover - depends on the installation
            pass
        names += ["libpetsc_real.so.3.18", "libpetsc_real.so", ctypes.util.find_library("petsc_real"),
                  ctypes.util.find_library("petsc")]
        for name in filter(None, names):
            try:
                candidate = ctypes.CDLL(name)
                candidate.MatSeqAIJGetArray   # noqa: B018 - the symbol must be there
                _lib = candidate
                break
            except (OSError, AttributeError):
                continue
        else:
            raise OSError("the PETSc library petsc4py uses was not found")
    return _lib


def _check(code, what):
    if code != 0:
        raise RuntimeError(f"PETSc {what} failed (error {code})")


def blocks(A, columns=True):
    """(diagonal block handle, off-diagonal block handle or None, global columns of the off-diagonal
    block's local columns) of an assembled AIJ matrix (sequential: (A, None, empty)); `columns` False:
    None for the columns (they cost a copy of the off-diagonal block's structure)."""
    if A.getType() in ("seqaij", "seqaijcusparse"):
        return A.handle, None, np.zeros(0, np.int64)
    Ad, Ao = ctypes.c_void_p(), ctypes.c_void_p()
    colmap = ctypes.POINTER(ctypes.c_int32)()
    _check(lib().MatMPIAIJGetSeqAIJ(ctypes.c_void_p(A.handle), ctypes.byref(Ad), ctypes.byref(Ao),
                                    ctypes.byref(colmap)), "MatMPIAIJGetSeqAIJ")
    if not columns:
        return Ad.value, Ao.value, None
    i, j = rowij(Ao.value)
    ncols = int(j.max()) + 1 if j.size else 0
    garray = np.ctypeslib.as_array(colmap, shape=(ncols,)).astype(np.int64) if ncols else np.zeros(0, np.int64)
    return Ad.value, Ao.value, garray


def rowij(handle):
    """Copies of the CSR row pointers and column indices of a sequential AIJ matrix."""
    L = lib()
    h = ctypes.c_void_p(handle)
    n, done = ctypes.c_int32(), ctypes.c_int()
    ia, ja = ctypes.POINTER(ctypes.c_int32)(), ctypes.POINTER(ctypes.c_int32)()
    _check(L.MatGetRowIJ(h, 0, 0, 0, ctypes.byref(n), ctypes.byref(ia), ctypes.byref(ja), ctypes.byref(done)),
           "MatGetRowIJ")
    if not done.value:
        raise RuntimeError("MatGetRowIJ gave no structure")
    i = np.ctypeslib.as_array(ia, shape=(n.value + 1,)).copy()
    j = np.ctypeslib.as_array(ja, shape=(int(i[-1]),)).copy() if i[-1] else np.zeros(0, np.int32)
    _check(L.MatRestoreRowIJ(h, 0, 0, 0, ctypes.byref(n), ctypes.byref(ia), ctypes.byref(ja), ctypes.byref(done)),
           "MatRestoreRowIJ")
    return i, j


class Values:
    """The value array of a sequential AIJ matrix: open() gives its address, close() gives it back.

    `read=True`: MatSeqAIJGetArrayRead / RestoreArrayRead, which leave the matrix's state alone
    (a restored writable array counts as a change: a solver would set itself up again)."""

    def __init__(self, handle, read=False):
        self.handle = ctypes.c_void_p(handle)
        self._ptr = ctypes.c_void_p()
        self.read = read

    def open(self):
        name = "MatSeqAIJGetArrayRead" if self.read else "MatSeqAIJGetArray"
        _check(getattr(lib(), name)(self.handle, ctypes.byref(self._ptr)), name)
        return self._ptr.value or 0

    def close(self):
        name = "MatSeqAIJRestoreArrayRead" if self.read else "MatSeqAIJRestoreArray"
        _check(getattr(lib(), name)(self.handle, ctypes.byref(self._ptr)), name)


def pc_failed(pc):
    """Whether the last set-up of `pc` failed (a zero pivot, no memory: PCGetFailedReason != 0)."""
    reason = ctypes.c_int()
    _check(lib().PCGetFailedReason(ctypes.c_void_p(pc.handle), ctypes.byref(reason)), "PCGetFailedReason")
    return reason.value != 0


def pc_set_failed(pc, failed=True):
    """PCSetFailedReason: PC_FACTOR_NUMERIC_ZEROPIVOT (a python PC's factorization met a zero pivot)
    or PC_NOERROR (a python PC put in place of a failed LU does not clear the LU's failure itself,
    and KSP would report it, DIVERGED_PC_FAILED, for the new PC)."""
    reason = 2 if failed else 0
    _check(lib().PCSetFailedReason(ctypes.c_void_p(pc.handle), ctypes.c_int(reason)), "PCSetFailedReason")


def nonzero_state(A):
    """MatGetNonzeroState: changes whenever A's nonzero pattern changes (the same on every rank)."""
    state = ctypes.c_int64()
    _check(lib().MatGetNonzeroState(ctypes.c_void_p(A.handle), ctypes.byref(state)), "MatGetNonzeroState")
    return state.value
