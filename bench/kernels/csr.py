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

#: the loops' CSR index type: 32-bit indices read a third less memory per product than
#: 64-bit ones, and scipy's own (32-bit below 2^31 entries) are then used as they are;
#: 64-bit past 2^31 entries
INDEX = np.int32


class CSR(NamedTuple):
    """A sparse matrix's CSR arrays: row pointers and column indices (`index_type`),
    values."""

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


def index_type(entries: int) -> type:
    """The CSR index type for a matrix of `entries` stored values or rows (`INDEX`)."""
    return INDEX if entries < np.iinfo(INDEX).max else np.int64


def csr_arrays(A: sp.spmatrix) -> CSR:
    """A's CSR arrays for `matvec`: A's own arrays where they already have the loops' types
    (a CSR matrix with 32-bit indices and float values: nothing copied, so the
    problem's M and K are not held twice), else converted copies. The loops read them
    and never write them (the curved obstacle's G, which `contact.relinearise`
    rewrites, has arrays of its own)."""
    A = sp.csr_matrix(A)
    ix = index_type(max(A.nnz, A.shape[0] + 1, A.shape[1]))
    return CSR(A.indptr.astype(ix, copy=False), A.indices.astype(ix, copy=False),
               A.data.astype(float, copy=False))
