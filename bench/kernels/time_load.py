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
a run without one steps exactly as it did before the load existed (bit for bit). Its
`NoLoad` holds no array: numba counts references to every array of a typed tuple each
time the tuple is passed or read, so a step without a load pays nothing for the load's
arrays, and `force_at` and `last_force`, dispatched on the load's type (numba
`overload`), compile to `return F`.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numba.extending import overload

from contact_bench.core.numba_types import is_tuple_type
from contact_bench.kernels.csr import CSR, csr_arrays, matvec


class LoadOps(NamedTuple):
    """A problem's time load for a compiled step: its density (a numba cfunc), B (n x m,
    CSR), the m points (3 x m) and the density's codes (m)."""

    density: Any
    B: CSR
    X: np.ndarray
    codes: np.ndarray


class NoLoad(NamedTuple):
    """No time load: a type of its own without arrays (module docstring)."""


#: the time load of a problem without one
NO_TIME_LOAD = NoLoad()


def load_ops(p: Any) -> LoadOps | NoLoad:
    """The `LoadOps` of a `SparseProblem` (its `load`), or `NO_TIME_LOAD` without one."""
    ld = getattr(p, "load", None)
    if ld is None:
        return NO_TIME_LOAD
    return LoadOps(ld.density, csr_arrays(ld.B), np.ascontiguousarray(ld.points, float),
                   np.asarray(ld.codes, np.int64))


def load_scratch(lo: LoadOps | NoLoad, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The scratch `force_at` writes, for a stepper's state: the density's m values and
    the n-vector of the load."""
    return np.empty(load_points(lo)), np.empty(n)


def initial_load(p: Any) -> np.ndarray:
    """The load at t = 0: F + B v(0) (F alone without a time load), for the set-up."""
    F = np.asarray(p.F, float)
    ld = getattr(p, "load", None)
    return F if ld is None else F + ld.at(0.0)


def is_load_free(lo: Any) -> bool:
    """Whether `lo`, a numba type, is `NoLoad`'s (a problem without a time load)."""
    return is_tuple_type(lo, NoLoad)


def has_time_load(lo):  # pragma: no cover - compiled through its overload
    """Whether there is a time load (a `LoadOps`, not `NoLoad`): a constant of the type."""
    return not isinstance(lo, NoLoad)


@overload(has_time_load)
def _has_time_load_compiled(lo):  # pragma: no cover - compiled
    if is_load_free(lo):
        return lambda lo: False
    return lambda lo: True


def load_points(lo):  # pragma: no cover - compiled through its overload
    """The number m of the load's points (0 without a time load)."""
    return 0 if isinstance(lo, NoLoad) else lo.codes.size


@overload(load_points)
def _load_points_compiled(lo):  # pragma: no cover - compiled
    if is_load_free(lo):
        return lambda lo: 0
    return lambda lo: lo.codes.size


def force_at(lo, F, t, vals, Fn):  # pragma: no cover - compiled through its overload
    """The load at time t: F + B v(t) written to Fn (vals: the density's values, scratch)
    and returned; without a time load (`NoLoad`), F itself (nothing written). Inlined
    (numba `inline="always"`): it returns an array, which a step compiled without
    reference counting (`contact_bench.core.refcount`) may only take from inlined code."""


@overload(force_at, inline="always")
def _force_at_compiled(lo, F, t, vals, Fn):  # pragma: no cover - compiled
    if is_load_free(lo):
        return lambda lo, F, t, vals, Fn: F

    def loaded(lo, F, t, vals, Fn):
        for j in range(lo.codes.size):
            vals[j] = lo.density(lo.X[0, j], lo.X[1, j], lo.X[2, j], t, lo.codes[j])
        matvec(lo.B, vals, Fn)
        for i in range(F.size):
            Fn[i] += F[i]
        return Fn
    return loaded


def last_force(lo, F, Fn):  # pragma: no cover - compiled through its overload
    """The load `force_at` last wrote to Fn (F without a time load): for a step or a
    sample that reads the load of a time level evaluated earlier."""


@overload(last_force)
def _last_force_compiled(lo, F, Fn):  # pragma: no cover - compiled
    if is_load_free(lo):
        return lambda lo, F, Fn: F
    return lambda lo, F, Fn: Fn
