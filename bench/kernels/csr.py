"""Compressed sparse row (CSR) matrices as plain arrays, for the compiled sparse kernels.

A numba kernel takes a scipy matrix as its three CSR arrays (`csr_arrays`: a `CSR`
named tuple of row pointers, column indices, values) and multiplies with `matvec` (or
`csr_matvec` on the three arrays).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from contact_bench.core.refcount import uncounted


class CSR(NamedTuple):
    """A sparse matrix's CSR arrays: row pointers and column indices (int64), values."""

    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray


@uncounted
def csr_matvec(indptr, indices, data, x, out):  # pragma: no cover - compiled
    """out = A x for A in CSR."""
    for i in range(indptr.size - 1):
        s = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            s += data[k] * x[indices[k]]
        out[i] = s


@uncounted
def matvec(A, x, out):  # pragma: no cover - compiled
    """out = A x for A a `CSR`."""
    csr_matvec(A.indptr, A.indices, A.data, x, out)


def csr_arrays(A: sp.spmatrix) -> CSR:
    """A's CSR arrays (indptr and indices as int64, values as float) for `matvec`."""
    A = sp.csr_matrix(A)
    return CSR(A.indptr.astype(np.int64), A.indices.astype(np.int64), A.data.astype(float))
