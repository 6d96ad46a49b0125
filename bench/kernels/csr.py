"""Compressed sparse row (CSR) matrices as plain arrays, for the compiled sparse kernels.

A numba kernel takes a scipy matrix as its three CSR arrays (`csr_arrays`: row pointers,
column indices, values) and multiplies with `csr_matvec`.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit


@njit(cache=True)
def csr_matvec(indptr, indices, data, x, out):  # pragma: no cover - compiled
    """out = A x for A in CSR."""
    for i in range(indptr.size - 1):
        s = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            s += data[k] * x[indices[k]]
        out[i] = s


def csr_arrays(A: sp.spmatrix) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A's CSR arrays (indptr and indices as int64, values as float) for `csr_matvec`."""
    A = sp.csr_matrix(A)
    return A.indptr.astype(np.int64), A.indices.astype(np.int64), A.data.astype(float)
