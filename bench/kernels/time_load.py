"""A time-dependent load in the compiled steppers: the one place where a step evaluates
`contact_bench.api.sparse.TimeLoad`.

A problem's load is F + B v(t) (`SparseProblem.load`: the closed form's density v at m
points, B its quadrature weights times the shape functions). A stepper keeps the load's
arrays in a `LoadOps` (`load_ops`) among its operators and, in its step, asks for the
load at the time level at which its own discretisation evaluates the forces
(`force_at`): an explicit step at the state's time t_n, a trapezoidal or Newmark one at
t_n and t_{n+1}, a midpoint one at t_{n+1/2}, HHT at t_{n+1+alpha}. Each stepper's
docstring says which.

Without a time load `force_at` returns the constant F itself and does no arithmetic, so
a run without one steps exactly as it did before the load existed (bit for bit).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import cfunc, float64, int64, njit

from contact_bench.kernels.csr import CSR, csr_arrays, matvec


@cfunc(float64(float64, float64, float64, float64, int64))
def NO_LOAD(x, y, z, t, code):  # pragma: no cover - compiled
    """The time load's density of a problem without one (never called)."""
    return 0.0


class LoadOps(NamedTuple):
    """A problem's time load for a compiled step: whether there is one (`on`), its
    density (a numba cfunc, or `NO_LOAD`), B (n x m, CSR), the m points (3 x m) and the
    density's codes (m)."""

    on: bool
    density: Any
    B: CSR
    X: np.ndarray
    codes: np.ndarray


def load_ops(p: Any) -> LoadOps:
    """The `LoadOps` of a `SparseProblem` (its `load`, or an empty one without)."""
    ld = getattr(p, "load", None)
    if ld is None:
        return LoadOps(False, NO_LOAD, csr_arrays(sp.csr_matrix((p.nfree, 0))),
                       np.zeros((3, 0)), np.zeros(0, np.int64))
    return LoadOps(True, ld.density, csr_arrays(ld.B), np.ascontiguousarray(ld.points, float),
                   np.asarray(ld.codes, np.int64))


def load_scratch(lo: LoadOps, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The scratch `force_at` writes, for a stepper's state: the density's m values and
    the n-vector of the load."""
    return np.empty(lo.codes.size), np.empty(n)


def initial_load(p: Any) -> np.ndarray:
    """The load at t = 0: F + B v(0) (F alone without a time load), for the set-up."""
    F = np.asarray(p.F, float)
    ld = getattr(p, "load", None)
    return F if ld is None else F + ld.at(0.0)


@njit(cache=True)
def force_at(lo, F, t, vals, Fn):  # pragma: no cover - compiled
    """The load at time t: F + B v(t) written to Fn (vals: the density's values, scratch)
    and returned; without a time load, F itself (nothing written)."""
    if not lo.on:
        return F
    for j in range(lo.codes.size):
        vals[j] = lo.density(lo.X[0, j], lo.X[1, j], lo.X[2, j], t, lo.codes[j])
    matvec(lo.B, vals, Fn)
    for i in range(F.size):
        Fn[i] += F[i]
    return Fn


@njit(cache=True)
def last_force(lo, F, Fn):  # pragma: no cover - compiled
    """The load `force_at` last wrote to Fn (F without a time load): for a step or a
    sample that reads the load of a time level evaluated earlier."""
    return Fn if lo.on else F
