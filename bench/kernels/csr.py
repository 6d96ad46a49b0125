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

#: the loops' CSR index type: numba's loops over 64-bit indices are the faster ones
#: (a 32-bit CSR product measured about 30% slower: docs/sparse.md), so the indices are
#: copied to 64 bits; the values are shared
INDEX = np.int64


class CSR(NamedTuple):
    """A sparse matrix's CSR arrays: row pointers and column indices (`INDEX`), values."""

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
    """A's CSR arrays for `matvec`: A's own arrays where they already have the loops' types
    (`INDEX` indices, float values: the values of a scipy matrix are shared, so the
    problem's M and K values are not held twice), else converted copies. The loops read
    them and never write them (the curved obstacle's G, which `contact.relinearise`
    rewrites, has arrays of its own)."""
    A = sp.csr_matrix(A)
    return CSR(A.indptr.astype(INDEX, copy=False), A.indices.astype(INDEX, copy=False),
               A.data.astype(float, copy=False))
