"""A numerical reference: a stored fine trajectory evaluated by P1 interpolation in space and
linear interpolation in time (`NumericalReference`), for scenes without an exact solution."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from contact_bench.api.plugin import Fields, flat_points, grid_points


@njit(cache=True)
def _interval(nodes, p):  # pragma: no cover - compiled
    """clip(searchsorted(nodes, p, side="right") - 1, 0, nodes.size - 2) for one point:
    the interval [nodes[i], nodes[i + 1]] holding p, the end ones outside (NaN, which
    numpy sorts last, in the last one). Binary search over increasing nodes."""
    n = nodes.size
    if p != p:
        return n - 2
    lo, hi = 0, n
    while lo < hi:  # the first i with p < nodes[i] (side="right")
        mid = (lo + hi) >> 1
        if p < nodes[mid]:
            hi = mid
        else:
            lo = mid + 1
    return min(max(lo - 1, 0), n - 2)


@njit(cache=True)
def _clip01(v):  # pragma: no cover - compiled
    """np.clip(v, 0.0, 1.0) (keeps NaN and -0.0, as it does)."""
    if v < 0.0:
        return 0.0
    if v > 1.0:
        return 1.0
    return v


@njit(cache=True)
def _point(U, V, want_v, e, a, h, k, b):  # pragma: no cover - compiled
    """(u, u_x, u_t) in the cell e (weight a, length h) and the sample interval k
    (weight b): the formulas of `NumericalReference._field` and `.ux`, in their order."""
    a1, b1 = 1.0 - a, 1.0 - b
    u0, u1 = U[k, e], U[k, e + 1]
    w0, w1 = U[k + 1, e], U[k + 1, e + 1]
    u = b1 * (a1 * u0 + a * u1) + b * (a1 * w0 + a * w1)
    ux = b1 * ((u1 - u0) / h) + b * ((w1 - w0) / h)
    v = 0.0
    if want_v:
        v = b1 * (a1 * V[k, e] + a * V[k, e + 1]) + b * (a1 * V[k + 1, e] + a * V[k + 1, e + 1])
    return u, ux, v


@njit(cache=True)
def _where_x(nodes, xp):  # pragma: no cover - compiled
    """Cell e, its length h and weight a of the point xp (as `NumericalReference._where`)."""
    e = _interval(nodes, xp)
    h = nodes[e + 1] - nodes[e]
    return e, h, _clip01((xp - nodes[e]) / h)


@njit(cache=True)
def _where_t(times, tp):  # pragma: no cover - compiled
    """Sample interval k and weight b of the time tp (as `NumericalReference._where`)."""
    k = _interval(times, tp)
    return k, _clip01((tp - times[k]) / (times[k + 1] - times[k]))


@njit(cache=True)
def _grid_kernel(ref, x, t, out):  # pragma: no cover - compiled
    """The fields of the `Stored` ref at the points (x[m], t[j]) into the `Fields` out: u[j,
    m], ux[j, m] (and ut[j, m] unless ut is empty), by the formulas of `_point` on row
    views. The cells of the points x (any order) are found once, the sample interval once
    per time. The row views and unsigned cell indices (no wraparound test) halve the cost of
    2-D indexing; what is left is mostly the loads of the four stored rows each time needs."""
    nodes, times, U, V = ref
    u, ux, ut = out
    want_v = ut.size > 0
    nx = x.size
    c0 = np.empty(nx, np.uint64)
    c1 = np.empty(nx, np.uint64)
    wa = np.empty(nx)
    hs = np.empty(nx)
    for m in range(nx):
        e, hs[m], wa[m] = _where_x(nodes, x[m])
        c0[m] = e
        c1[m] = e + 1
    for j in range(t.size):
        k, b = _where_t(times, t[j])
        b1 = 1.0 - b
        U0, U1 = U[k], U[k + 1]
        uj, uxj = u[j], ux[j]
        V0, V1 = (V[k], V[k + 1]) if want_v else (U0, U1)
        vj = ut[j] if want_v else uj
        for m in range(nx):  # the test of want_v is hoisted out of the loop by LLVM
            e, f, a, h = c0[m], c1[m], wa[m], hs[m]
            a1 = 1.0 - a
            u0, u1, w0, w1 = U0[e], U0[f], U1[e], U1[f]
            uj[m] = b1 * (a1 * u0 + a * u1) + b * (a1 * w0 + a * w1)
            uxj[m] = b1 * ((u1 - u0) / h) + b * ((w1 - w0) / h)
            if want_v:
                vj[m] = b1 * (a1 * V0[e] + a * V0[f]) + b * (a1 * V1[e] + a * V1[f])


@njit(cache=True)
def _points_kernel(ref, x, t, out):  # pragma: no cover - compiled
    """The fields of the `Stored` ref at the points (x[n], t[n]) (1-D arrays) into the
    `Fields` out (ut empty: no velocity). The sample interval is looked up again only
    when the time changes."""
    nodes, times, U, V = ref
    u, ux, ut = out
    want_v = ut.size > 0
    k, b, last = 0, 0.0, np.nan
    for n in range(x.size):
        tp = t[n]
        if not tp == last:  # NaN never equals: looked up each time
            k, b = _where_t(times, tp)
            last = tp
        e, h, a = _where_x(nodes, x[n])
        f, fx, fv = _point(U, V, want_v, e, a, h, k, b)
        u[n] = f
        ux[n] = fx
        if want_v:
            ut[n] = fv


class Stored(NamedTuple):
    """A stored trajectory as the kernels read it: mesh nodes, sample times, and the
    nodal U and V, one row per sample."""

    nodes: np.ndarray
    times: np.ndarray
    U: np.ndarray
    V: np.ndarray


class NumericalReference:
    """A stored fine trajectory as a reference: P1 in space, linear in time.

    x: mesh nodes, t: sample times (increasing), U, V: (K, nodes) nodal values,
    S: (K,) contact stress. Arrays given to the evaluators broadcast against each other.

    `u`, `ux`, `ut` are numpy; `fields` and `fields_into` (what the error norms use)
    compiled, with bitwise the same values: the same formulas in the same order
    (clipping outside the nodes to the end cells, as numpy does).
    """

    def __init__(self, x: np.ndarray, t: np.ndarray, U: np.ndarray, V: np.ndarray,
                 S: np.ndarray, description: str) -> None:
        # contiguous float arrays (no copy when they are already): the kernels' operands
        self.x, self.t = np.ascontiguousarray(x, float), np.ascontiguousarray(t, float)
        self.U, self.V = np.ascontiguousarray(U, float), np.ascontiguousarray(V, float)
        self.S = S
        self.description = description
        shape = (self.t.size, self.x.size)
        if min(shape) < 2 or self.U.shape != shape or self.V.shape != shape:
            # the kernels index without bounds checks
            raise ValueError(f"NumericalReference: needs at least 2 nodes and 2 sample "
                             f"times and U, V of shape {shape}, got {self.U.shape}, "
                             f"{self.V.shape}")

    def _stored(self) -> Stored:
        return Stored(self.x, self.t, self.U, self.V)

    def _check_times(self, t: np.ndarray) -> None:
        """ValueError (naming the first bad value) unless every t is in the stored
        interval, up to round-off."""
        bad = (t < self.t[0] - 1e-12 * self.t[-1]) | (t > self.t[-1] * (1 + 1e-12))
        if np.any(bad):
            raise ValueError(f"t outside the stored interval [0, {self.t[-1]:g}] of the "
                             f"numerical reference (t = {t[bad].flat[0]!r})")

    def _where(self, x: np.ndarray, t: np.ndarray):
        x, t = np.broadcast_arrays(np.asarray(x, float), np.asarray(t, float))
        self._check_times(t)
        e = np.clip(np.searchsorted(self.x, x, side="right") - 1, 0, self.x.size - 2)
        h = self.x[e + 1] - self.x[e]
        a = np.clip((x - self.x[e]) / h, 0.0, 1.0)
        k = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, self.t.size - 2)
        b = np.clip((t - self.t[k]) / (self.t[k + 1] - self.t[k]), 0.0, 1.0)
        return e, h, a, k, b

    def _field(self, F: np.ndarray, x: np.ndarray, t: np.ndarray) -> np.ndarray:
        e, _, a, k, b = self._where(x, t)
        f0 = (1 - a) * F[k, e] + a * F[k, e + 1]
        f1 = (1 - a) * F[k + 1, e] + a * F[k + 1, e + 1]
        return (1 - b) * f0 + b * f1

    def u(self, x: np.ndarray, t: np.ndarray) -> np.ndarray:
        return self._field(self.U, x, t)

    def ut(self, x: np.ndarray, t: np.ndarray) -> np.ndarray:
        return self._field(self.V, x, t)

    def ux(self, x: np.ndarray, t: np.ndarray) -> np.ndarray:
        e, h, _, k, b = self._where(x, t)
        s0 = (self.U[k, e + 1] - self.U[k, e]) / h
        s1 = (self.U[k + 1, e + 1] - self.U[k + 1, e]) / h
        return (1 - b) * s0 + b * s1

    def fields(self, x: np.ndarray, t: np.ndarray, velocity: bool = True
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """(u, u_x, u_t) at the points (x, t) broadcast together (u_t None unless
        `velocity`), compiled: bitwise the values of `u`, `ux`, `ut`."""
        xf, tf, shape = flat_points(x, t)
        self._check_times(tf)
        u, ux = np.empty(xf.size), np.empty(xf.size)
        ut = np.empty(xf.size) if velocity else np.empty(0)
        _points_kernel(self._stored(), xf, tf, Fields(u, ux, ut))
        return u.reshape(shape), ux.reshape(shape), (ut.reshape(shape) if velocity else None)

    def fields_into(self, x: np.ndarray, t: np.ndarray, u: np.ndarray, ux: np.ndarray,
                    ut: np.ndarray | None = None) -> None:
        """`fields` at the points (x[m], t[k]) written into u[k, m], ux[k, m] and ut[k, m]
        (x, t 1-D, x in any order; the outputs writeable C-contiguous float64 arrays of
        shape (t.size, x.size), see `grid_points`): what the error norms use, without
        temporaries. Nothing is written when t leaves the stored interval."""
        x, t = grid_points(x, t, u, ux, ut)
        self._check_times(t)
        _grid_kernel(self._stored(), x, t,
                     Fields(u, ux, np.empty((0, 0)) if ut is None else ut))

    def stress(self, t: np.ndarray) -> np.ndarray:
        return np.interp(np.asarray(t, float), self.t, self.S)
