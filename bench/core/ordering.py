"""Fill-reducing orderings for sparse direct factorisations, and the positive-definiteness
test built on one.

A 2D or 3D mesh's matrix factors with much less fill when ordered by METIS's nested
dissection (the `pymetis` wheel) than by SuperLU's minimum degree, from a few thousand
dofs on; below that, and on a band, minimum degree is as good or better. The factor's
size is also its time, so the ordering decides whether a 3D factorisation takes seconds
or many minutes (docs/sparse.md). Shared by the assembly's mass checks (`is_spd`) and
the kernels' factors (`contact_bench.kernels.linalg`). Bottom layer: imports only
`contact_bench.core.pardiso` (PARDISO's SPD test of a large matrix).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import SuperLU, splu

from contact_bench.core import pardiso

try:  # METIS's nested dissection; minimum degree without it
    import pymetis
except ImportError:  # pragma: no cover - a dependency
    pymetis = None

#: size from which a matrix is ordered by nested dissection instead of minimum degree
NESTED_DISSECTION_DOFS = 5000


def nested_dissection(S: sp.spmatrix) -> np.ndarray | None:
    """METIS's nested-dissection ordering q of S's graph (the pattern of S + S^T without
    the diagonal; S[q][:, q] is the matrix to factor), or None without pymetis."""
    if pymetis is None:
        return None
    A = sp.csr_matrix(S, dtype=float)
    A = abs(A) + abs(A.T)
    A.setdiag(0.0)
    A.eliminate_zeros()
    A.sort_indices()
    perm, _ = pymetis.nested_dissection(pymetis.CSRAdjacency(A.indptr, A.indices))
    return np.asarray(perm, dtype=np.int64)


@contextmanager
def forced_ordering(nested: bool) -> Iterator[None]:
    """Within the block, every symmetric factorisation (`symmetric_lu`: the kernels'
    factors, `is_spd`) is ordered by nested dissection (`nested`) or by minimum degree,
    whatever its size: for measuring one ordering against the other
    (benchmarks/cholesky_compare.py, benchmarks/ordering_diff.py)."""
    global NESTED_DISSECTION_DOFS
    keep = NESTED_DISSECTION_DOFS
    NESTED_DISSECTION_DOFS = 0 if nested else np.iinfo(np.int64).max
    try:
        yield
    finally:
        NESTED_DISSECTION_DOFS = keep


def symmetric_lu(A: sp.spmatrix) -> tuple[SuperLU, np.ndarray | None]:
    """SuperLU's symmetric-mode factor of A (diagonal pivots: a symmetric elimination)
    and its ordering q: A[q][:, q] factored in its natural order, q METIS's nested
    dissection, from `NESTED_DISSECTION_DOFS` rows on; below, A itself with SuperLU's
    minimum degree on A^T + A, and q None. RuntimeError when A is exactly singular."""
    C = sp.csc_matrix(A)
    q = nested_dissection(C) if C.shape[0] >= NESTED_DISSECTION_DOFS else None
    lu = splu(C if q is None else C[q][:, q], diag_pivot_thresh=0.0,
              permc_spec="MMD_AT_PLUS_A" if q is None else "NATURAL",
              options={"SymmetricMode": True})
    return lu, q


def is_spd(A: sp.spmatrix) -> bool:
    """Whether a sparse symmetric matrix is positive definite: its symmetric elimination
    (`symmetric_lu`; a symmetric permutation keeps the answer) made no row interchange
    and has only positive pivots; PARDISO's Cholesky (`contact_bench.core.pardiso`)
    from `PARDISO_MIN_DOFS` rows on, when MKL loads (one factorisation either way)."""
    if A.shape[0] >= pardiso.PARDISO_MIN_DOFS:
        answer = pardiso.is_spd(A)
        if answer is not None:
            return answer
    try:
        lu, _ = symmetric_lu(A)
    except RuntimeError:  # exactly singular
        return False
    return bool(np.all(lu.perm_r == lu.perm_c) and np.all(lu.U.diagonal() > 0))
