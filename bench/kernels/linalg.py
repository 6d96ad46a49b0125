"""Direct solves with the schemes' matrices, factored once outside the stepping loops.

`Factor.of(S)` factors S once and solves with it in two ways:

* inside a compiled loop, one right-hand side per call: `lu_solve` over `Factor.arrays`,
  SuperLU's L and U (symmetric mode, diagonal pivots) kept as CSR arrays, so that a numba
  kernel needs no Python. The fill-reducing ordering is METIS's nested dissection of S's
  graph from `contact_bench.core.ordering.NESTED_DISSECTION_DOFS` dofs on, SuperLU's
  minimum degree on A^T + A below: the solves are bound by memory traffic, so the factor's size is
  their time, and nested dissection's factor of a 2D or 3D mesh's matrix is the smaller
  one at the sizes where a solve costs anything;
* at set-up, many right-hand sides at once (`Factor.solve_many`: the columns of the
  Delassus and Schur operators C S^-1 C^T, one call for all the contact dofs): CHOLMOD's
  supernodal Cholesky (the `cholespy` package, its default fill-reducing ordering) when S is
  symmetric positive definite, cholespy is installed and CONTACT_BENCH_CHOLMOD=1 asks
  for it; otherwise (not symmetric, not
  positive definite, cholespy missing) `lu_solve_many`, SuperLU's factor on a block of
  columns (each column the numbers of `lu_solve`, to the bit). The two agree to
  round-off; `Factor.many_backend` says which one a factor uses.

From `contact_bench.core.pardiso.PARDISO_MIN_DOFS` rows on, a symmetric S that is not
banded (`banded`: the 2D and 3D meshes' matrices) is factored by
MKL PARDISO's Cholesky when MKL loads (`Factor.of`'s `pardiso`): the loops' `lu_solve` and
the set-up's block solves call PARDISO with the kept handle (`LU.ph`, `LU.pip`); S not
positive definite (PARDISO's error -4) or MKL absent falls back to SuperLU, the reason in
`Factor.fallback`. SuperLU is the fill-in for everything smaller, unsymmetric or
indefinite.

With `CONTACT_BENCH_LDLT=1` (or `Factor.of(S, ldlt=True)`) an SPD S keeps only SuperLU's L
and D (U = D L^T to round-off in symmetric mode: half the factor's memory) and solves
L D L^T x = b, the backward sweep scattering along L's rows; S not SPD keeps L and U, the
reason in `Factor.fallback` (one line). The SPD test reads the one symmetric-mode factor
(no row interchange, every pivot positive): no second factorisation.

Every kernel module factors through `Factor` and no scheme imports a solver package:
this module is the one place that knows about them. docs/sparse.md has the measurements
behind the choice (`benchmarks/cholesky_compare.py`).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit

from contact_bench.core import pardiso as mkl_pardiso
from contact_bench.core.ordering import symmetric_lu
from contact_bench.core.pardiso import PARDISO_MIN_DOFS, pardiso_call, upper_csr
from contact_bench.core.refcount import uncounted
from contact_bench.core.timers import phase

try:  # CHOLMOD (SuiteSparse) in a wheel; optional: SuperLU does everything without it
    import cholespy
except ImportError:  # pragma: no cover - depends on the environment
    cholespy = None

#: CHOLMOD for `solve_many` only when asked (CONTACT_BENCH_CHOLMOD=1): SuperLU's block
#: solve gives the set-up's numbers to the bit and, measured so far, no slower at the
#: scenes' sizes (docs/sparse.md); CHOLMOD needs a second factorisation
USE_CHOLMOD = os.environ.get("CONTACT_BENCH_CHOLMOD", "") == "1"
#: right-hand sides per block of `Factor.solve_many`: `lu_solve_many`'s time per column
#: falls with the width up to 32-64 columns and is flat beyond
#: (results/cholesky/block_width.md)
MANY_BLOCK_COLUMNS = 64
#: largest number of values in one block of right-hand sides (the block, its solution
#: and the scratch are dense n x k arrays): fewer columns on a very large n
MANY_BLOCK_ENTRIES = 32_000_000
#: keep L D L^T (L and D only) for an SPD S instead of SuperLU's L and U (module docstring)
USE_LDLT = os.environ.get("CONTACT_BENCH_LDLT", "") == "1"
#: relative asymmetry max |S - S^T| / max |S| up to which S counts as symmetric
SYMMETRY_TOL = 1e-14
#: half-bandwidth (in S's own numbering) up to which S counts as banded and stays with
#: SuperLU whatever its size: a banded S (the 1D bars: tridiagonal) factors without fill,
#: and SuperLU's sweep solves it an order of magnitude faster than PARDISO's supernodal
#: solve, whose per-supernode overhead dominates when every supernode is one column
#: (docs/sparse.md, "PARDISO on the bar's tridiagonal S")
BANDED_MAX = 8
#: the factor's index type in the loops: 32-bit indices read a quarter less memory per
#: solve than 64-bit ones (the solves are bound by memory traffic); 64-bit past 2^31 entries
INDEX = np.int32


@uncounted
def lu_solve(fac, b, out, work):  # pragma: no cover - compiled
    """out = S^-1 b from SuperLU's Pr S Pc = L U (`fac`, an `LU`: L unit lower, U upper,
    both CSR with sorted columns, L's diagonal last in its row, U's first), or from
    Pr S Pr^T = L D L^T when U is empty (`Up` of size 0, D in `Ux`)."""
    if fac.ph.size != 0:  # PARDISO's factor: its phase 33 with the kept handle
        if pardiso_call(fac.ph, fac.pip, 33, 1, b, out) != 0:
            out[:] = np.nan  # a failed solve shows as a blow-up
        return
    Lp, Li, Lx, Up, Ui, Ux = fac.Lp, fac.Li, fac.Lx, fac.Up, fac.Ui, fac.Ux
    perm_r, perm_c = fac.perm_r, fac.perm_c
    n = b.size
    for i in range(n):
        work[perm_r[i]] = b[i]
    for i in range(n):  # L y = Pr b
        s = work[i]
        for k in range(Lp[i], Lp[i + 1] - 1):
            s -= Lx[k] * work[Li[k]]
        work[i] = s / Lx[Lp[i + 1] - 1]
    if Up.size == 0:  # D w = y, then L^T z = w by columns of L^T (L's rows), scattering
        for i in range(n):
            work[i] /= Ux[i]
        for i in range(n - 1, -1, -1):
            zi = work[i] / Lx[Lp[i + 1] - 1]
            work[i] = zi
            for k in range(Lp[i], Lp[i + 1] - 1):
                work[Li[k]] -= Lx[k] * zi
        for i in range(n):
            out[i] = work[perm_c[i]]
        return
    for i in range(n - 1, -1, -1):  # U z = y
        s = work[i]
        for k in range(Up[i] + 1, Up[i + 1]):
            s -= Ux[k] * work[Ui[k]]
        work[i] = s / Ux[Up[i]]
    for i in range(n):  # x = Pc z
        out[i] = work[perm_c[i]]


class LU(NamedTuple):
    """A factor's arrays for the compiled loops: L and U as CSR (L unit lower with its
    diagonal last in each row, U upper with its diagonal first), the permutations,
    `solves`: (1,) int64, the number of solves the compiled loops made with it (`lu`
    counts them: how a test sees what a step costs), and PARDISO's handle when the factor
    is PARDISO's (`ph`, `pip`; then `lu_solve` calls PARDISO)."""

    Lp: np.ndarray
    Li: np.ndarray
    Lx: np.ndarray
    Up: np.ndarray
    Ui: np.ndarray
    Ux: np.ndarray
    perm_r: np.ndarray
    perm_c: np.ndarray
    solves: np.ndarray
    #: PARDISO's handle (`contact_bench.core.pardiso`: `h` and `ip`), size 0 for SuperLU's
    #: factor (then L and U above are the factor; for PARDISO's they are empty)
    ph: np.ndarray
    pip: np.ndarray


@njit(cache=True, inline="always")
def lu(fac, b, out, work):  # pragma: no cover - compiled
    """out = S^-1 b with S's factor `fac` (an `LU`; `lu_solve`); work: scratch (n).
    Counts the solve in `fac.solves`. Inlined into its caller: a call of its own would
    count references to every array of the factor once more per solve."""
    fac.solves[0] += 1
    lu_solve(fac, b, out, work)


@njit(cache=True)
def lu_solve_many(fac, B, out, work):  # pragma: no cover - compiled
    """out = S^-1 B for the k columns of B (n x k, rows contiguous; work: n x k) with
    `lu_solve`'s factor, each column by `lu_solve`'s operations in its order (the same
    numbers to the bit), the factor read once for all k columns; PARDISO's factor: its
    multi-right-hand-side solve, one call (work unused). The set-up's block solves
    (`Factor.solve_blocks`) and the loops' columns on demand
    (`contact_bench.kernels.contact.add_columns`) both use it."""
    n, k = B.shape
    if fac.ph.size != 0:  # PARDISO: its columns contiguous (B^T's rows), one call for all
        Bt = np.ascontiguousarray(B.T)
        Xt = np.empty((k, n))
        if pardiso_call(fac.ph, fac.pip, 33, k, Bt, Xt) != 0:
            Xt[:, :] = np.nan
        out[:, :] = Xt.T
        return
    Lp, Li, Lx, Up, Ui, Ux = fac.Lp, fac.Li, fac.Lx, fac.Up, fac.Ui, fac.Ux
    perm_r, perm_c = fac.perm_r, fac.perm_c
    for i in range(n):
        work[perm_r[i], :] = B[i, :]
    for i in range(n):
        for kk in range(Lp[i], Lp[i + 1] - 1):
            a, r = Lx[kk], Li[kk]
            for c in range(k):
                work[i, c] -= a * work[r, c]
        d = Lx[Lp[i + 1] - 1]
        for c in range(k):
            work[i, c] /= d
    if Up.size == 0:  # L D L^T (`lu_solve`)
        for i in range(n):
            for c in range(k):
                work[i, c] /= Ux[i]
        for i in range(n - 1, -1, -1):
            d = Lx[Lp[i + 1] - 1]
            for c in range(k):
                work[i, c] /= d
            for kk in range(Lp[i], Lp[i + 1] - 1):
                a, r = Lx[kk], Li[kk]
                for c in range(k):
                    work[r, c] -= a * work[i, c]
        for i in range(n):
            out[i, :] = work[perm_c[i], :]
        return
    for i in range(n - 1, -1, -1):
        for kk in range(Up[i] + 1, Up[i + 1]):
            a, r = Ux[kk], Ui[kk]
            for c in range(k):
                work[i, c] -= a * work[r, c]
        d = Ux[Up[i]]
        for c in range(k):
            work[i, c] /= d
    for i in range(n):
        out[i, :] = work[perm_c[i], :]


def is_symmetric(S: sp.spmatrix) -> bool:
    """Whether max |S - S^T| <= `SYMMETRY_TOL` max |S|."""
    S = sp.csr_matrix(S)
    if S.shape[0] != S.shape[1]:
        return False
    scale = float(abs(S).max()) if S.nnz else 0.0
    return float(abs(S - S.T).max()) <= SYMMETRY_TOL * scale if scale else True


def cholmod_factor(S: sp.spmatrix) -> Any | None:
    """CHOLMOD's Cholesky factor of S (a `cholespy.CholeskySolverD`), or None when S is
    not symmetric, not positive definite, or cholespy is not installed."""
    if cholespy is None or not is_symmetric(S):
        return None
    C = sp.csc_matrix(S)
    C.sort_indices()
    try:
        return cholespy.CholeskySolverD(C.shape[0], C.indptr.astype(np.int32),
                                        C.indices.astype(np.int32),
                                        np.ascontiguousarray(C.data, float),
                                        cholespy.MatrixType.CSC)
    except ValueError:  # "Matrix is not positive definite!"
        return None


def spd_failure(symmetric: bool, perm_r: np.ndarray, perm_c: np.ndarray,
                D: np.ndarray) -> str:
    """Why SuperLU's symmetric-mode factor does not show S to be SPD, in one line."""
    if not symmetric:
        return f"S is not symmetric (beyond {SYMMETRY_TOL:g} relative): kept L and U"
    if not np.array_equal(perm_r, perm_c):
        return "S is not positive definite (its elimination interchanged rows): kept L and U"
    i = int(np.argmin(D))
    return (f"S is not positive definite (pivot {i} = {float(D[i]):.3g} <= 0): "
            "kept L and U")


def banded(A: sp.spmatrix, width: int = BANDED_MAX) -> bool:
    """Whether every nonzero of A lies within `width` of the diagonal (A's numbering):
    read from each column's first and last row, no array of A's size beside it."""
    C = A if sp.isspmatrix_csc(A) else sp.csc_matrix(A)
    if not C.has_sorted_indices:
        C = C.sorted_indices()
    counts = np.diff(C.indptr)
    cols = np.flatnonzero(counts)
    if cols.size == 0:
        return True
    first = C.indices[C.indptr[cols]]
    last = C.indices[C.indptr[cols + 1] - 1]
    return bool(max(np.max(cols - first), np.max(last - cols)) <= width)


def pardiso_by_default(*parts: sp.spmatrix) -> bool:
    """`Factor.of`'s default choice for S (or for the sum of `parts`): PARDISO when S has at
    least `PARDISO_MIN_DOFS` rows, is not `banded` (a part is not) and MKL loads."""
    return (parts[0].shape[0] >= PARDISO_MIN_DOFS and mkl_pardiso.MKL is not None
            and not all(banded(X) for X in parts))


@dataclass
class Factor:
    """S factored once: SuperLU's arrays for the compiled loops' `lu_solve`, and
    `solve_many` for blocks of right-hand sides (module docstring)."""

    arrays: LU
    n: int
    #: the CSC matrix, kept only until `solve_many` has made CHOLMOD's factor of it
    S: sp.csc_matrix | None = field(default=None, repr=False)
    #: "cholmod" or "superlu": what `solve_many` uses
    many_backend: str = "superlu"
    #: CHOLMOD's factor, made by the first `solve_many`
    chol: Any = field(default=None, repr=False)
    #: "pardiso" (PARDISO's Cholesky), "ldlt" (SuperLU's L and D kept) or "lu" (L and
    #: U): what the loops' solves use
    kind: str = "lu"
    #: why the factor asked for (PARDISO's, or an L D L^T) was not made and SuperLU's L
    #: and U stand in (one line: PARDISO's refusal, S not symmetric or not SPD), else ""
    fallback: str = ""

    #: PARDISO's factor (`contact_bench.core.pardiso.Pardiso`) when `kind` is "pardiso"
    pardiso: Any = field(default=None, repr=False)

    @classmethod
    @phase("factor")
    def of(cls, S: sp.spmatrix, ldlt: bool | None = None,
           pardiso: bool | None = None) -> Factor:
        """S (square, nonsingular) factored by SuperLU (`symmetric_lu`), ordered by nested
        dissection from `contact_bench.core.ordering.NESTED_DISSECTION_DOFS` dofs on
        (S[q][:, q] factored in its natural order, q folded into the permutations) and by
        minimum degree below; `solve_many` will use
        CHOLMOD if asked (`USE_CHOLMOD`) and S is symmetric positive definite (read from
        SuperLU's symmetric-mode factor: no row interchange, U's diagonal positive).
        `ldlt` (default `USE_LDLT`): keep L and D only when S is SPD (module docstring);
        otherwise L and U, the reason in `fallback`.

        `pardiso` (default: S has at least `PARDISO_MIN_DOFS` rows, is not `banded`
        and MKL loads): a
        symmetric S is factored by PARDISO's Cholesky (`contact_bench.core.pardiso`)
        and the loops solve with it; S not positive definite, or MKL not loaded, falls
        back to SuperLU with the reason in `fallback` (one line, no second PARDISO
        factorisation)."""
        C = sp.csc_matrix(S)
        n = S.shape[0]
        use = pardiso_by_default(C) if pardiso is None else bool(pardiso)
        why = ""
        symmetric = is_symmetric(C)  # tested once: PARDISO's input, then L D L^T's
        if use and not symmetric:
            why = f"S is not symmetric (beyond {SYMMETRY_TOL:g} relative): SuperLU's L and U"
        elif use:
            made, why = mkl_pardiso.factor(upper_csr(C), n)
            if made is not None:
                return cls.of_pardiso(made, n)
            why = f"PARDISO refused S: {why}: SuperLU's L and U"
        lu, q = symmetric_lu(C)
        Lc, Uc, perm_r, perm_c = lu.L, lu.U, lu.perm_r, lu.perm_c
        if q is not None:  # row q[i] of S is row i of S[q][:, q]: b[q[i]] goes where b'[i] goes
            qinv = np.empty_like(q)
            qinv[q] = np.arange(q.size)
            perm_r, perm_c = perm_r[qinv], perm_c[qinv]
        del lu  # SuperLU's own storage of the factor, freed before the CSR copies
        Lm = sp.csr_matrix(Lc)
        del Lc
        Lm.sort_indices()
        D = Uc.diagonal()
        spd = symmetric and np.array_equal(perm_r, perm_c) and bool(np.all(D > 0))
        want = USE_LDLT if ldlt is None else bool(ldlt)
        keep_u = not (want and spd)
        fallback = spd_failure(symmetric, perm_r, perm_c, D) if want and not spd else ""
        if keep_u:
            Um = sp.csr_matrix(Uc)
            Um.sort_indices()
            Up, Ui, Ux = Um.indptr, Um.indices, Um.data
            del Um
        else:  # U = D L^T: L and D are the whole factor
            Up, Ui, Ux = np.zeros(0, np.int64), np.zeros(0, np.int64), D
        del Uc
        ix = INDEX if max(Lm.nnz, Ux.size) < np.iinfo(INDEX).max else np.int64
        arrays = LU(Lm.indptr.astype(ix), Lm.indices.astype(ix), Lm.data,
                    Up.astype(ix), Ui.astype(ix), Ux,
                    np.asarray(perm_r, ix), np.asarray(perm_c, ix), np.zeros(1, np.int64),
                    np.zeros(0, np.uint64), np.zeros(0, np.int32))
        chol = USE_CHOLMOD and cholespy is not None and spd
        return cls(arrays, S.shape[0], C if chol else None, "cholmod" if chol else "superlu",
                   kind="lu" if keep_u else "ldlt", fallback=why or fallback)

    @classmethod
    def of_pardiso(cls, made: Any, n: int) -> Factor:
        """The factor around PARDISO's (`contact_bench.core.pardiso.Pardiso`): its handle
        in the loops' arrays, SuperLU's arrays empty."""
        ix, f0 = INDEX, np.zeros(0)
        empty = np.zeros(0, ix)
        arrays = LU(np.zeros(1, ix), empty, f0, empty, empty, f0, empty, empty,
                    np.zeros(1, np.int64), made.h, made.ip)
        return cls(arrays, n, kind="pardiso", pardiso=made)

    @classmethod
    @phase("factor")
    def of_sum(cls, A: sp.spmatrix, B: sp.spmatrix, c: float, ldlt: bool | None = None,
               pardiso: bool | None = None) -> Factor:
        """S = A + c B factored as `of(S)` would, without S held whole beside PARDISO's
        factor while it is made (the set-up's peak memory): where PARDISO factors (the
        same rule) and A and B are symmetric, PARDISO reads the sum of their upper
        triangles, S's upper triangle entry for entry (c B_ij + A_ij, the same rounding);
        otherwise, and if PARDISO refuses, `of(A + c B)`."""
        n = A.shape[0]
        use = pardiso_by_default(A, B) if pardiso is None else bool(pardiso)
        if not (use and is_symmetric(A) and is_symmetric(B)):
            return cls.of(sp.csc_matrix(A + c * B), ldlt=ldlt, pardiso=pardiso)
        made, why = mkl_pardiso.factor(upper_csr(sp.triu(A, format="csr")
                                                 + c * sp.triu(B, format="csr")), n)
        if made is not None:
            return cls.of_pardiso(made, n)
        fac = cls.of(sp.csc_matrix(A + c * B), ldlt=ldlt, pardiso=False)
        fac.fallback = f"PARDISO refused S: {why}: SuperLU's L and U"
        return fac

    @property
    def entries(self) -> int:
        """The values the loops' factor holds: L and U, L and D, or PARDISO's L."""
        if self.pardiso is not None:
            return self.pardiso.entries
        return int(self.arrays.Lx.size + self.arrays.Ux.size)

    @property
    def nbytes(self) -> int:
        """The factor's memory: the loops' arrays, or PARDISO's own (analysis and
        numerical factorisation, iparm[15] + iparm[16])."""
        if self.pardiso is not None:
            return self.pardiso.factor_bytes
        return int(sum(a.nbytes for a in self.arrays))

    @property
    def l_entries(self) -> int:
        """The values of the factor's L (SuperLU's, with its diagonal; PARDISO's)."""
        return self.entries if self.pardiso is not None else int(self.arrays.Lx.size)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """S^-1 b for one right-hand side (`lu_solve`)."""
        out = np.empty(self.n)
        lu_solve(self.arrays, np.ascontiguousarray(b, float), out, np.empty(self.n))
        return out

    def solve_many(self, B: np.ndarray | sp.spmatrix) -> np.ndarray:
        """S^-1 B (n x k, dense result with contiguous rows) for k right-hand sides at
        once (`solve_blocks`). Used at set-up (Delassus and Schur operators)."""
        out = np.empty((self.n, B.shape[1]))
        for j0, j1, X in self.solve_blocks(B):
            out[:, j0:j1] = X
        return out

    def solve_blocks(self, B: np.ndarray | sp.spmatrix
                     ) -> Iterator[tuple[int, int, np.ndarray]]:
        """(j0, j1, S^-1 B[:, j0:j1]) over B's columns in blocks of `MANY_BLOCK_COLUMNS`
        (at most `MANY_BLOCK_ENTRIES` values): CHOLMOD when S is SPD (and asked for), else
        `lu_solve_many`. For a caller that keeps only part of each block's solution,
        so that the whole n x k result is never held."""
        k = B.shape[1]
        if self.S is not None:  # the factor or the fallback is decided once
            self.chol = cholmod_factor(self.S)
            self.S = None
            if self.chol is None:
                self.many_backend = "superlu"
        chol = self.chol
        Bc = sp.csc_matrix(B) if sp.issparse(B) else None
        step = max(1, min(MANY_BLOCK_COLUMNS, MANY_BLOCK_ENTRIES // max(self.n, 1)))
        for j0 in range(0, k, step):
            j1 = min(k, j0 + step)
            blk = np.ascontiguousarray(Bc[:, j0:j1].toarray() if Bc is not None
                                       else B[:, j0:j1], dtype=float)
            X = np.empty(blk.shape)
            if chol is None:  # SuperLU's or PARDISO's factor (one call for the block)
                lu_solve_many(self.arrays, blk, X, np.empty(blk.shape))
            else:
                chol.solve(blk, X)
            yield j0, j1, X
