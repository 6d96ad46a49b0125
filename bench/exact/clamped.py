"""Closed form of the clamped bar (Chouly, Hild, Renard 2015), evaluated in compiled code.

L = 1, rho = E = 1, u0 = 1/2 - x/2, v0 = 0, clamped at x = 1. Derived by marching the
characteristics by hand: u = P(x+t) + Q(x-t),
  P(y) = P0(y mod 3) - floor(y/3)/4,  P0(y) = (1-y)/4 on [0,2), (y-3)/4 on [2,3);
  Q(s) = Q0(r mod 3) + floor(r/3)/4 with r = 1 - s,
  Q0(r) = r/4 on [0,1), (2-r)/4 on [1,2), (r-2)/4 on [2,3).
Exact for all t (it only uses t mod 3 and floor(t / 3)).
"""


from __future__ import annotations

import math

import numpy as np
from numba import njit

from contact_bench.api.plugin import Fields, flat_points, grid_points
from contact_bench.core.simd import vload, vselect_lt, vsplat, vstore
from contact_bench.exact.characteristics import scan_range

_GROUP = 32  # points of a group in `_run`


@njit(cache=True)
def _mod3(y: float, fl: float) -> float:
    """y mod 3 in [0, 3) given fl = floor(y / 3.0): equal to Python's y % 3.0 (np.mod)
    for y >= 0, all this scene needs (y = x + t and 1 - x + t, x in [0, 1], t >= 0).

    y - 3 fl is exact (Sterbenz) and is the remainder unless y / 3 rounded up to the
    integer fl, where it is slightly negative and + 3 gives it. Branch-free, unlike the
    libm fmod behind `%`, which is slower."""
    m = y - 3.0 * fl
    return m + 3.0 if m < 0.0 else m


@njit(cache=True, inline="always")
def _floors(x: float, t: float) -> tuple[int, int]:
    """floor((x + t) / 3) and floor((1 - (x - t)) / 3): the periods of P and Q at (x, t)."""
    return math.floor((x + t) / 3.0), math.floor((1.0 - (x - t)) / 3.0)


@njit(cache=True, inline="always")
def _at(x: float, t: float, fy: int, fr: int) -> tuple[float, float, float]:
    """`_point` given its two floors (`_floors(x, t)`)."""
    y = x + t
    ry = _mod3(y, fy)
    P = ((1.0 - ry) / 4.0 if ry < 2.0 else (ry - 3.0) / 4.0) - fy / 4.0
    dP = -0.25 if ry < 2.0 else 0.25
    r = 1.0 - (x - t)
    m = _mod3(r, fr)
    if m < 1.0:
        Q, dQ = m / 4.0, -0.25  # dQ/ds = -dQ0/dr
    elif m < 2.0:
        Q, dQ = (2.0 - m) / 4.0, 0.25
    else:
        Q, dQ = (m - 2.0) / 4.0, -0.25
    return P + (Q + fr / 4.0), dP + dQ, dP - dQ


@njit(cache=True)
def _point(x: float, t: float) -> tuple[float, float, float]:
    """(u, u_x, u_t) = (P(x+t) + Q(x-t), P' + Q', P' - Q') at one point; the slopes at
    a kink are those of the piece to the right, as np.where(r < 2, ...) gives them."""
    fy, fr = _floors(x, t)
    return _at(x, t, fy, fr)


@njit(cache=True)
def _run_end(x, m, t, fy, fr):  # pragma: no cover - compiled
    """The end e of the run of points x[m:e] (x sorted) that have the floors (fy, fr) of
    x[m] at time t. Along sorted x both floors are monotone (x + t and 1 - (x - t) are,
    rounded, and so are / 3 and floor), so they hold on a prefix: found by bisection."""
    n = x.size
    if _floors(x[n - 1], t) == (fy, fr):
        return n
    lo, hi = m, n - 1  # the floors hold at lo, not at hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if _floors(x[mid], t) == (fy, fr):
            lo = mid
        else:
            hi = mid
    return hi


@njit(cache=True)
def _fields_kernel(x, t, u, ux, ut):  # pragma: no cover - compiled
    """`_point` at the points (x[n], t[n]) (1-D arrays)."""
    for n in range(x.size):
        u[n], ux[n], ut[n] = _point(x[n], t[n])


@njit(cache=True, inline="always")
def _piece_p(ry: float) -> int:
    """P's piece at ry = y mod 3 (>= 0): 0 on [0, 2), 1 on [2, 3)."""
    return 0 if ry < 2.0 else 1


@njit(cache=True, inline="always")
def _piece_q(m: float) -> int:
    """Q0's piece at m = r mod 3 (>= 0): 0 on [0, 1), 1 on [1, 2), 2 on [2, 3)."""
    return 0 if m < 1.0 else (1 if m < 2.0 else 2)


@njit(cache=True)
def _run(x, m, e, t, fy, fr, row, want_v):  # pragma: no cover - compiled
    """`_at` at the points x[m:e], which share the floors fy, fr, into the row's `Fields`
    u, ux (ut if want_v): one row's run, 8 points a vector, the same IEEE operations lane by lane
    (/ 4.0 is * 0.25 exactly; 3 fy and fy / 4 are the values `_at` forms), and the last
    points one by one.

    By groups of up to _GROUP points: along the run ry = (x + t) - 3 fy increases and
    m = (1 - (x - t)) - 3 fr decreases (rounded sums of monotone terms), so when the
    group's first and last points are in the same pieces of P and Q0 (and need no + 3),
    all its points are, and the group is one affine formula per field, without selects:
    P = (ry - c1) s1 - fy / 4 and Q = (m - c2) s2, where (1 - ry) q = (ry - 1) (-q) and
    (2 - m) q = (m - 2) (-q) exactly (rounding is symmetric), m q = (m - 0) q; u_x and u_t
    are constants. Otherwise the group takes the selects."""
    u, ux, ut = row
    f3, f4, r3, r4 = 3.0 * fy, fy / 4.0, 3.0 * fr, fr / 4.0
    T, F3, F4, R3, R4 = vsplat(t), vsplat(f3), vsplat(f4), vsplat(r3), vsplat(r4)
    zero, one, two, three = vsplat(0.0), vsplat(1.0), vsplat(2.0), vsplat(3.0)
    q, mq = vsplat(0.25), vsplat(-0.25)
    j = m
    while j + 8 <= e:
        stop = j + min(e - j, _GROUP) // 8 * 8
        xa, xb = x[j], x[stop - 1]
        ra, rb = (xa + t) - f3, (xb + t) - f3
        ma, mb = (1.0 - (xa - t)) - r3, (1.0 - (xb - t)) - r3
        pp, pq = _piece_p(ra), _piece_q(ma)
        if ra >= 0.0 and mb >= 0.0 and _piece_p(rb) == pp and _piece_q(mb) == pq:
            C1, S1 = (one, mq) if pp == 0 else (three, q)
            C2, S2 = (zero, q) if pq == 0 else ((two, mq) if pq == 1 else (two, q))
            dp = -0.25 if pp == 0 else 0.25
            dq = 0.25 if pq == 1 else -0.25
            UX, UT = vsplat(dp + dq), vsplat(dp - dq)
            while j < stop:
                X = vload(x, j)
                P = (((X + T) - F3) - C1) * S1 - F4
                Q = (((one - (X - T)) - R3) - C2) * S2
                vstore(u, j, P + (Q + R4))
                vstore(ux, j, UX)
                if want_v:
                    vstore(ut, j, UT)
                j += 8
            continue
        while j < stop:
            X = vload(x, j)
            ry = (X + T) - F3
            ry = vselect_lt(ry, zero, ry + three, ry)
            P = vselect_lt(ry, two, (one - ry) * q, (ry - three) * q) - F4
            dP = vselect_lt(ry, two, mq, q)
            r = (one - (X - T)) - R3
            r = vselect_lt(r, zero, r + three, r)
            Q = vselect_lt(r, one, r * q, vselect_lt(r, two, (two - r) * q, (r - two) * q))
            dQ = vselect_lt(r, one, mq, vselect_lt(r, two, q, mq))
            vstore(u, j, P + (Q + R4))
            vstore(ux, j, dP + dQ)
            if want_v:
                vstore(ut, j, dP - dQ)
            j += 8
    for i in range(j, e):
        a, b, c = _at(x[i], t, fy, fr)
        u[i] = a
        ux[i] = b
        if want_v:
            ut[i] = c


@njit(cache=True)
def _grid_kernel(x, t, u, ux, ut):  # pragma: no cover - compiled
    """`_point` at the points (x[m], t[k]) into u[k, m], ux[k, m] (and ut[k, m] unless
    ut is empty): every sample time against the same points, without broadcast copies.

    For sorted x (the error norms' Gauss points), the two floors (two divisions) are
    found per run of points that share them (`_run_end`: one to three runs per time on
    the bar), and the points of a run are `_at` with them (`_run`): the same operations
    on the same floors, so the same bits as point by point, without the divisions that
    bounded the loop (what the norms gain: `benchmarks/norm_cost.py`). Other x: point
    by point."""
    want_v = ut.size > 0
    n = x.size
    ordered = scan_range(x)[2]  # nondecreasing, no NaN (else point by point)
    for k in range(t.size):
        tk = t[k]
        if not ordered:
            for m in range(n):
                a, b, c = _point(x[m], tk)
                u[k, m] = a
                ux[k, m] = b
                if want_v:
                    ut[k, m] = c
            continue
        m = 0
        while m < n:
            fy, fr = _floors(x[m], tk)
            e = _run_end(x, m, tk, fy, fr)
            _run(x, m, e, tk, fy, fr, Fields(u[k], ux[k], ut[k] if want_v else u[k]), want_v)
            m = e


class ClampedBarExact:
    """The closed form above (rho = E = c = 1)."""

    energy = 0.125

    def fields(self, x, t, velocity: bool = True):
        """(u, u_x, u_t) at once (u_t None unless `velocity`): what the error norms use."""
        xf, tf, shape = flat_points(x, t)
        u, ux, ut = np.empty(xf.size), np.empty(xf.size), np.empty(xf.size)
        _fields_kernel(xf, tf, u, ux, ut)
        return u.reshape(shape), ux.reshape(shape), (ut.reshape(shape) if velocity else None)

    def fields_into(self, x: np.ndarray, t: np.ndarray, u: np.ndarray, ux: np.ndarray,
                    ut: np.ndarray | None = None) -> None:
        """`fields` at the points (x[m], t[k]) written into u[k, m], ux[k, m] and ut[k, m]
        (x, t 1-D; the outputs C-contiguous float arrays of shape (t.size, x.size)):
        what the error norms use, without temporaries."""
        x, t = grid_points(x, t, u, ux, ut)
        _grid_kernel(x, t, u, ux, np.empty((0, 0)) if ut is None else ut)

    def u(self, x, t):
        return self.fields(x, t, velocity=False)[0]

    def ut(self, x, t):
        return self.fields(x, t)[2]

    def ux(self, x, t):
        return self.fields(x, t, velocity=False)[1]

    def stress(self, t):
        """E u_x(0, t): -1/2 in contact, on the open intervals (1, 2) mod 3, else 0 (at the
        jumps t = 1 and 2 the value outside contact; GetFEM's demo takes -1/2 at t = 1)."""
        t = np.asarray(t, float)
        return np.where((np.mod(t, 3.0) > 1.0) & (np.mod(t, 3.0) < 2.0), -0.5, 0.0)
