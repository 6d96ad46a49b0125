"""MKL PARDISO's sparse Cholesky, called through its C entry point from Python and from
compiled (numba) code.

Why: an SPD S = M + dt^2/4 K of a 3D mesh is factored by PARDISO's supernodal Cholesky
(mtype 2, METIS nested dissection inside PARDISO, iparm[1] = 2) in a small part of the
time SuperLU's LU takes, and its factor is stored once (SuperLU's LU keeps both
triangles). MKL comes from the `mkl` wheel (libmkl_rt, LP64: 32-bit indices).

How it is called: `pardiso` is a numba external function named `SYMBOL`, resolved by
LLVM by name when the code is linked (so `cache=True` callers stay cacheable), and
`pardiso_call`, compiled, is the one place that passes its 16 arguments: the loops' solves,
the set-up's block solves, and the Python side's factorisation (phase 12) and release
(phase -1, the finaliser) all call it;
`load` registers that name at MKL's `pardiso` when libmkl_rt loads, and at a stub that
reports `UNAVAILABLE_ERROR` when it does not (MKL absent or CONTACT_BENCH_PARDISO=0), so
the code compiles either way. Every pointer argument is passed as an address (uintp).

The handle: `h` (uint64, `H_SIZE`): PARDISO's `pt` (64 words), then the addresses of the
factored matrix's upper-triangle CSR (values, row starts, column indices; the arrays are
kept alive by their `Pardiso` owner). `ip` (int32, `IP_SIZE`): iparm (64 entries), then
maxfct, mnum, mtype, phase, n, nrhs, msglvl, error and a dummy perm.

Reproducibility: MKL's conditional numerical reproducibility (CNR) is switched on before
the first MKL call (`MKL_CBWR_Set(MKL_CBWR_AUTO)`, unless MKL_CBWR is set) and iparm[33]
is set to the thread count, so that the factor and the solves are the same bits from run
to run on one machine with a fixed thread count (`THREADS`).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import glob
import os
import sys
import weakref
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from llvmlite import binding as llvm
from numba import types

from contact_bench.core.refcount import uncounted

#: the name the compiled code calls PARDISO by
SYMBOL = "contact_bench_pardiso"
#: PARDISO's solver threads (the machine's two cores); CONTACT_BENCH_PARDISO_THREADS
#: changes it
THREADS = int(os.environ.get("CONTACT_BENCH_PARDISO_THREADS", "2"))
#: the size (rows) from which `contact_bench.kernels.linalg.Factor` uses PARDISO for a
#: symmetric S: below it SuperLU factors in well under a second and keeps the numbers of
#: the small scenes (the trajectory digests) independent of MKL's CPU-dependent code path
PARDISO_MIN_DOFS = int(os.environ.get("CONTACT_BENCH_PARDISO_MIN_DOFS", "20000"))
#: the error the stub reports when MKL is not loaded
UNAVAILABLE_ERROR = -900
#: sizes of the handle's arrays (module docstring)
H_SIZE = 67
IP_SIZE = 73
_MAXFCT, _MNUM, _MTYPE, _PHASE, _N, _NRHS, _MSGLVL, _ERROR, _PERM = range(64, 73)
#: MKL's constants: the PARDISO threading domain, CNR's automatic branch
_MKL_DOMAIN_PARDISO = 4
_MKL_CBWR_AUTO = 2
#: PARDISO's error codes (the one-line reasons of `Pardiso.factor`'s failures)
ERRORS = {-1: "input inconsistent", -2: "not enough memory", -3: "reordering problem",
          -4: "not positive definite: a zero or negative pivot",
          -5: "unclassified (internal) error", -6: "reordering failed",
          -7: "diagonal matrix is singular", -8: "32-bit integer overflow",
          -9: "not enough memory for out-of-core", -10: "error opening out-of-core files",
          -11: "read/write error with out-of-core files",
          UNAVAILABLE_ERROR: "MKL PARDISO is not loaded"}

_ARGS = [ctypes.c_uint64] * 16
_STUB_TYPE = ctypes.CFUNCTYPE(None, *_ARGS)


def _stub(*args: int) -> None:
    """PARDISO's stand-in when MKL is not loaded: sets the error to `UNAVAILABLE_ERROR`."""
    ctypes.c_int32.from_address(args[15]).value = UNAVAILABLE_ERROR


_STUB = _STUB_TYPE(_stub)


def _find_mkl_rt() -> str | None:
    """libmkl_rt's path: the `mkl` wheel's (in this environment's lib/), else the system's."""
    for root in dict.fromkeys((sys.prefix, sys.base_prefix, sys.exec_prefix)):
        hits = sorted(glob.glob(os.path.join(root, "lib", "libmkl_rt.so*")))
        if hits:
            return hits[0]
    return ctypes.util.find_library("mkl_rt")


def load() -> tuple[ctypes.CDLL | None, str]:
    """(libmkl_rt, "") when MKL loads, else (None, why not in one line); registers
    `SYMBOL` for the compiled code either way (module docstring)."""
    lib, why = None, ""
    if os.environ.get("CONTACT_BENCH_PARDISO", "") == "0":
        why = "CONTACT_BENCH_PARDISO=0"
    else:
        path = _find_mkl_rt()
        if path is None:
            why = "libmkl_rt not found (the mkl wheel is not installed)"
        else:
            try:
                lib = ctypes.CDLL(path)
                lib.pardiso.argtypes, lib.pardiso.restype = _ARGS, None
                if "MKL_CBWR" not in os.environ:
                    lib.MKL_CBWR_Set(ctypes.c_int(_MKL_CBWR_AUTO))
                lib.MKL_Domain_Set_Num_Threads(ctypes.c_int(THREADS),
                                               ctypes.c_int(_MKL_DOMAIN_PARDISO))
            except (OSError, AttributeError) as e:
                lib, why = None, f"libmkl_rt did not load: {e}"
    address = (ctypes.cast(lib.pardiso, ctypes.c_void_p).value if lib is not None
               else ctypes.cast(_STUB, ctypes.c_void_p).value)
    llvm.add_symbol(SYMBOL, address)
    return lib, why


MKL, UNAVAILABLE = load()

pardiso = types.ExternalFunction(SYMBOL, types.void(*([types.uintp] * 16)))


@uncounted
def pardiso_call(h, ip, phase, nrhs, b, x):  # pragma: no cover - compiled
    """PARDISO's `phase` on the handle (h, ip) with nrhs right-hand sides b (n x nrhs,
    each column contiguous) into x; returns PARDISO's error (0: none)."""
    ip[_PHASE] = phase
    ip[_NRHS] = nrhs
    ip[_ERROR] = 0
    base = ip.ctypes.data
    four = np.uint64(4)
    pardiso(h.ctypes.data, base + four * np.uint64(_MAXFCT), base + four * np.uint64(_MNUM),
            base + four * np.uint64(_MTYPE), base + four * np.uint64(_PHASE),
            base + four * np.uint64(_N), h[64], h[65], h[66],
            base + four * np.uint64(_PERM), base + four * np.uint64(_NRHS), base,
            base + four * np.uint64(_MSGLVL), b.ctypes.data, x.ctypes.data,
            base + four * np.uint64(_ERROR))
    return ip[_ERROR]


def _release(h: np.ndarray, ip: np.ndarray, *keep: np.ndarray) -> None:
    """PARDISO's phase -1: frees the factor's memory (the finaliser of `Pardiso`; `keep`:
    the matrix arrays whose addresses the handle holds, alive until then)."""
    if MKL is None or not h[:64].any():
        return
    dummy = np.zeros(1)
    pardiso_call(h, ip, -1, 1, dummy, dummy)
    h[:64] = 0


class Pardiso(NamedTuple):
    """A PARDISO factor: its handle (`h`, `ip`: module docstring) and the upper-triangle
    CSR it was made from (`a`, `ia`, `ja`, kept alive for the handle's addresses)."""

    h: np.ndarray
    ip: np.ndarray
    a: np.ndarray
    ia: np.ndarray
    ja: np.ndarray

    @property
    def entries(self) -> int:
        """The factor's nonzeros (PARDISO's iparm[17])."""
        return int(self.ip[17])

    @property
    def factor_bytes(self) -> int:
        """PARDISO's memory kept for the solves: the analysis' permanent memory and the
        numerical factorisation's, bytes (iparm[15] + iparm[16], reported in KB)."""
        return 1024 * int(self.ip[15] + self.ip[16])

    @property
    def peak_bytes(self) -> int:
        """PARDISO's peak memory of analysis and factorisation, bytes (iparm[14..16])."""
        ip = self.ip
        return 1024 * int(max(ip[14], ip[15] + ip[16]))


def upper_csr(S: sp.spmatrix) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """S's upper triangle as CSR (data, indptr, indices), sorted columns, every diagonal
    entry stored (PARDISO's symmetric input)."""
    U = sp.triu(sp.csr_matrix(S), format="coo")
    n = S.shape[0]
    d = np.arange(n)
    U = sp.csr_matrix((np.concatenate([U.data, np.zeros(n)]),
                       (np.concatenate([U.row, d]), np.concatenate([U.col, d]))), shape=(n, n))
    U.sum_duplicates()
    U.sort_indices()
    return U.data, U.indptr, U.indices


def factor(S_upper_csr: tuple[np.ndarray, np.ndarray, np.ndarray], n: int
           ) -> tuple[Pardiso | None, str]:
    """PARDISO's Cholesky (mtype 2) of the SPD matrix whose upper triangle (diagonal
    included, every diagonal entry stored, sorted columns) is the CSR (data, indptr,
    indices): (the factor, "") or (None, the one-line reason: e.g. "not positive
    definite"). Analysis and factorisation in one call (phase 12); a failed handle is
    released at once, a made one when its `h` is collected."""
    if MKL is None:
        return None, f"MKL PARDISO is not available ({UNAVAILABLE})"
    a = np.ascontiguousarray(S_upper_csr[0], dtype=float)
    ia = np.ascontiguousarray(S_upper_csr[1], dtype=np.int32)
    ja = np.ascontiguousarray(S_upper_csr[2], dtype=np.int32)
    buf = np.zeros(H_SIZE, np.uint64)
    h = buf[:]  # a view: the finaliser watches it and keeps `buf` for phase -1
    h[64], h[65], h[66] = a.ctypes.data, ia.ctypes.data, ja.ctypes.data
    ip = np.zeros(IP_SIZE, np.int32)
    ip[0] = 1  # every iparm entry given here
    ip[1] = 2  # METIS nested dissection
    ip[7] = 0  # no iterative refinement
    ip[9] = 13  # pivot perturbation (unused by mtype 2)
    ip[17] = -1  # report the factor's nonzeros
    ip[33] = THREADS  # CNR: reproducible with this many threads
    ip[34] = 1  # zero-based indices
    ip[_MAXFCT], ip[_MNUM], ip[_MTYPE], ip[_N], ip[_MSGLVL] = 1, 1, 2, n, 0
    dummy = np.zeros(1)
    err = int(pardiso_call(h, ip, 12, 1, dummy, dummy))
    if err:
        _release(buf, ip)
        if err == -4:
            return None, "not positive definite (PARDISO error -4: a zero or negative pivot)"
        return None, f"PARDISO error {err} ({ERRORS.get(err, 'unknown')})"
    weakref.finalize(h, _release, buf, ip, a, ia, ja)
    return Pardiso(h, ip, a, ia, ja), ""


def is_spd(A: sp.spmatrix) -> bool | None:
    """Whether the symmetric A is positive definite, read from PARDISO's Cholesky (error
    -4: not); None when PARDISO cannot tell (MKL not loaded, another error)."""
    if MKL is None:
        return None
    made, why = factor(upper_csr(A), A.shape[0])
    if made is not None:
        return True
    return False if why.startswith("not positive definite") else None
