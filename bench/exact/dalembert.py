"""Exact solution of the bar with a Signorini end for smooth data without gravity, by
d'Alembert's formula with the contact instants found by root finding.

Problem: that of `contact_bench.exact.characteristics` with g = 0 (notes, section 1; Dabaghi et al.
section 2). With c = sqrt(E/rho), tau = c t and u_p the constant u_L (clamped far end)
or 0 (free):

    u(x, t) = p(x + tau) + q(x - tau) + u_p,   p = f/2 + V/(2c),  q = f/2 - V/(2c)

on [0, L] from the data (f = u0 - u_p, V(x) = int_0^x v0). The end w(tau) = p(tau) +
q(-tau) stays above the barrier phi = -u_p; with g = 0 its free motion is G(tau) = w(0)
+ 2 (p(tau) - p(0)) and w = G + eta, eta the running max of phi - G (the Skorokhod
problem, inclusion (2.8) of Dabaghi et al. 2014). So at the obstacle q(-tau) = w(tau) - p(tau) is

    in contact:            q(-tau) = phi - p(tau)
    free after a contact:  q(-tau) = p(tau) + w(0) - 2 p(0) + eta  (eta constant),

and the far end reflects: clamped p(L + s) = -q(L - s), free p(L + s) = q(L - s) + p(L)
- q(L). Let B be p on [0, 2L]: the data's p on [0, L], the reflected data's q on
[L, 2L]. Every value of p and q is then sigma B(r) + kappa: a sign and a constant per
segment of the argument, the argument r of B in [0, 2L] shifted by a multiple of 2L
(p(tau + 2L) is the image of p(tau) through the obstacle then the far end). The
segments end at the contact instants and at their images 2L later.

Construction, once, on the closed forms of the data: the obstacle's phases are followed
in time, block of 2L by block of 2L; a contact starts where p reaches the threshold of
the current free phase (w = phi) and ends where p stops decreasing (w' = 2 p' = 0, or
a kink where p' jumps to >= 0); both are found on the nodes of the table below and
refined by scipy's brentq to round-off. So the contact instants are exact to about
1e-15 (a touch between two nodes, w coming down to phi and leaving again within one
cell of the table without crossing it, is not detected: none in the scenes that use
this). Tolerances: a value within 1e-13 (relative to max |B|) of the threshold, or a
slope within 1e-12 (relative to max |B'|) of 0, counts as reached (round-off of the
composed constants).

Evaluation: B is tabulated by cubic Hermite interpolation of its value and slope (both
in closed form) on a uniform grid of `cells_per_length` cells per length L (default
10000: the table over [0, 2L] is 640 KB, one 32-byte row per cell, within a core's L2
cache). Its error is that of the cubic, O(h^4) on u and O(h^3) on u_x and u_t (pulse:
7e-13 and 2e-8, `table_error`), where the characteristics solution's linear
interpolation on its grid has O(ds^2) on u and O(ds) on the slopes (pulse, 20000 cells
per length: 5e-8 and 4e-3). A point costs two rows and two cubics (`_lanes`, 8 points
at a time by explicit SIMD; for sorted x, per sample time, by runs of points in the
same pair of segments: `_grid_kernel`). Kinks: limits from the future (t -> t+), as in
`contact_bench.exact.characteristics`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import quad
from scipy.optimize import brentq

from contact_bench.api.plugin import (
    INTERVAL_SLACK,
    Fields,
    check_positive,
    checked_far_end,
    checked_interval,
    flat_points,
    grid_points,
)
from contact_bench.core.simd import vfloor, vfma, vload, vrows4, vselect_lt, vsplat, vstore

__all__ = ["DalembertSolution"]

FloatArray = NDArray[np.float64]
#: x -> (value, derivative), vectorised
Smooth = Callable[[FloatArray], tuple[FloatArray, FloatArray]]

DEFAULT_CELLS_PER_LENGTH = 10000
_VALUE_TOL = 1e-13  # a value this close (relative to max |B|) to the threshold reaches it
_SLOPE_TOL = 1e-12  # a slope this close (relative to max |B'|) to 0 is 0


class DalembertSolution:
    """Exact solution for g = 0 and smooth data; see the module docstring.

    u0(x) -> (u0, u0') and V(x) -> (V, v0) with V(x) = int_0^x v0: closed forms of the
    data, vectorised. far_end "clamped" (u(L) = u_L) or "free". The solution
    is stored for t in [0, T]; evaluating outside raises ValueError.
    """

    def __init__(self, *, L: float, E: float, rho: float, far_end: str = "clamped",
                 u_L: float = 0.0, u0: Smooth, V: Smooth, T: float,
                 cells_per_length: int = DEFAULT_CELLS_PER_LENGTH) -> None:
        self.L = L = check_positive("L", L)
        self.E = check_positive("E", E)
        self.rho = check_positive("rho", rho)
        self.T = T = check_positive("T", T)
        self.far_end, u_L = checked_far_end(far_end, u_L)
        n = int(cells_per_length)
        if n != cells_per_length or n < 1:
            raise ValueError(f"cells_per_length must be a positive integer, got "
                             f"{cells_per_length!r}")
        self.cells_per_length = n
        self.c = c = math.sqrt(self.E / self.rho)
        clamped = far_end == "clamped"
        self.u_p = u_p = u_L if clamped else 0.0
        self._u0, self._V = u0, V

        def data(x: ArrayLike) -> tuple[FloatArray, ...]:
            x = np.asarray(x, float)
            (f, df), (v, dv) = u0(x), V(x)
            return (np.asarray(f, float) - u_p, np.asarray(df, float), np.asarray(v, float),
                    np.asarray(dv, float))

        f0, _, v0, _ = (float(a) for a in data(0.0))
        fL, _, vL, _ = (float(a) for a in data(L))
        if f0 + u_p < 0.0:
            raise ValueError(f"u0(0) must be >= 0 (obstacle constraint), got {f0 + u_p!r}")
        if v0 != 0.0:
            raise ValueError(f"V(0) must be 0 (V = int_0^x v0), got {v0!r}")
        if clamped and abs(fL) > 1e-9 * max(abs(fL + u_p), abs(u_L), 1e-300):
            raise ValueError(f"clamped end: u0(L) = {fL + u_p!r} must equal u_L = {u_L!r}")
        s = 1.0 if clamped else -1.0  # B on [L, 2L]: -q(2L - y) clamped, q(2L - y) + D free
        D = 0.0 if clamped else vL / c  # free: p(L) - q(L)

        def base(y: ArrayLike, right: bool = False) -> tuple[FloatArray, FloatArray]:
            """B and B' at y in [0, 2L] (closed forms; at y = L, where B' may jump, the
            limits from the left, or from the right if `right`)."""
            y = np.asarray(y, float)
            first = y < L if right else y <= L
            f, df, v, dv = data(np.where(first, y, 2 * L - y))
            p, dp = 0.5 * f + v / (2 * c), 0.5 * df + dv / (2 * c)
            q, dq = 0.5 * f - v / (2 * c), 0.5 * df - dv / (2 * c)
            return np.where(first, p, -s * q + D), np.where(first, dp, s * dq)

        self._base = base
        h = L / n
        nodes = np.linspace(0.0, 2 * L, 2 * n + 1)
        Bn, Dl = base(nodes)
        Dr = base(nodes, right=True)[1]
        if not (np.all(np.isfinite(Bn)) and np.all(np.isfinite(Dl)) and np.all(np.isfinite(Dr))):
            raise ValueError("u0 and V (and their derivatives) must be finite on [0, L]")
        self._h = h
        self._table = _cubic_table(Bn, h * Dr[:-1], h * Dl[1:])  # a cell's own limits
        self._runs, pseg, qseg = _march(base, nodes, L, h, -u_p, f0, D, clamped,
                                        self.c * T * (1.0 + INTERVAL_SLACK))
        self._p = tuple(np.ascontiguousarray(a, dtype=float) for a in pseg)
        self._q = tuple(np.ascontiguousarray(a, dtype=float) for a in qseg)
        self._energy: float | None = None

    # ------------------------------------------------------------------ evaluation
    def _times(self, t: ArrayLike) -> FloatArray:
        return checked_interval("t", t, self.T, f"the stored interval [0, T={self.T!r}]")

    def _points(self, x: ArrayLike, t: ArrayLike) -> tuple[FloatArray, FloatArray]:
        return checked_interval("x", x, self.L, f"the bar [0, L={self.L!r}]"), self._times(t)

    def _waves(self) -> Waves:
        return Waves(*self._p, *self._q, self._table, 1.0 / self._h, float(self.c),
                     float(self.u_p))

    @property
    def nbytes(self) -> int:
        """Memory held by the table and the segments, in bytes."""
        return self._table.nbytes + sum(a.nbytes for a in self._p + self._q)

    def fields(self, x: ArrayLike, t: ArrayLike, velocity: bool = True
               ) -> tuple[FloatArray, FloatArray, FloatArray | None]:
        """(u, u_x, u_t) at once (u_t None unless `velocity`), x and t broadcast."""
        x, t = self._points(x, t)
        xf, tf, shape = flat_points(x, self.c * t)
        u, ux, ut = np.empty(xf.size), np.empty(xf.size), np.empty(xf.size)
        _points_kernel(xf, tf, self._waves(), Fields(u, ux, ut))
        return u.reshape(shape), ux.reshape(shape), (ut.reshape(shape) if velocity else None)

    def fields_into(self, x: ArrayLike, t: ArrayLike, u: FloatArray, ux: FloatArray,
                    ut: FloatArray | None = None) -> None:
        """`fields` at the points (x[m], t[k]) written into u[k, m], ux[k, m] and ut[k, m]
        (x, t 1-D; the outputs C-contiguous float arrays of shape (t.size, x.size)): what
        the error norms use. The same bits as `fields`."""
        x, t = grid_points(x, t, u, ux, ut)
        x, t = self._points(x, t)
        _grid_kernel(x, self.c * t, self._waves(),
                     Fields(u, ux, np.empty((0, 0)) if ut is None else ut))

    def u(self, x: ArrayLike, t: ArrayLike) -> FloatArray:
        """Displacement u(x, t)."""
        return self.fields(x, t, velocity=False)[0]

    def ux(self, x: ArrayLike, t: ArrayLike) -> FloatArray:
        """Strain u_x (limit t -> t+ on kinks)."""
        return self.fields(x, t, velocity=False)[1]

    def ut(self, x: ArrayLike, t: ArrayLike) -> FloatArray:
        """Velocity u_t (limit t -> t+ on kinks)."""
        return self.fields(x, t)[2]

    def stress(self, t: ArrayLike) -> FloatArray:
        """Contact stress E u_x(0, t) <= 0 (limit t -> t+)."""
        return self.E * self.ux(0.0, t)

    def contact_displacement(self, t: ArrayLike) -> FloatArray:
        """u(0, t) >= 0."""
        return self.u(0.0, t)

    def contact_intervals(self) -> list[tuple[float, float]]:
        """(impact, take-off) times of the contact periods in [0, T]."""
        c = self.c
        return [(a / c, min(b / c, self.T)) for a, b in self._runs if a / c <= self.T]

    def energy(self, t: ArrayLike) -> FloatArray:
        """1/2 int (rho u_t^2 + E u_x^2) dx at the times t: conserved (the exact solution
        of the elastic impact loses no energy), so that of the data, by scipy's quad."""
        t = self._times(t)
        if self._energy is None:
            def density(x: float) -> float:
                du = self._u0(np.asarray(x, float))[1]
                v = self._V(np.asarray(x, float))[1]
                return 0.5 * (self.rho * float(v) ** 2 + self.E * float(du) ** 2)

            self._energy = quad(density, 0.0, self.L, limit=200, epsabs=1e-15,
                                epsrel=1e-13)[0]
        return np.full(t.shape, self._energy)

    def table_error(self, samples: int = 100_000, seed: int = 0) -> tuple[float, float]:
        """The largest differences of the table from the closed forms of B and B' at
        random points of [0, 2L]: the interpolation error (value, slope)."""
        r = np.random.default_rng(seed).uniform(0.0, 2 * self.L, samples)
        B, dB = self._base(r)
        # the kernel with one segment of p (sigma 1, kappa 0, no shift) at x = r, tau = 0
        # and q's part zero (sigma 0, kappa 0): u = B(r), u_x = B'(r)
        zero, v, d = np.zeros(1), np.empty(samples), np.empty(samples)
        waves = Waves(zero, zero, np.ones(1), zero, zero, zero, zero, zero, self._table,
                      1.0 / self._h, 1.0, 0.0)
        _points_kernel(r, np.zeros(samples), waves, Fields(v, d, np.empty(samples)))
        return float(np.max(np.abs(v - B))), float(np.max(np.abs(d - dB)))


def _march(base: Callable[..., tuple[FloatArray, FloatArray]], nodes: FloatArray,
           L: float, h: float, phi: float, w0: float, D: float, clamped: bool,
           tau_max: float) -> tuple[list[tuple[float, float]], tuple, tuple]:
    """The contact periods (in tau), and the segments of p (by start of y = x + tau:
    start, shift 2Lm, sigma, kappa) and of q (by start of z = x - tau: start, offset a
    with r = a - z, sigma, kappa); see the module docstring. w0 = w(0) = f(0). Slopes
    are limits from the right (the later tau's) where B' jumps."""
    Bn, Dn = base(nodes, True)
    p0 = float(Bn[0])
    vtol = _VALUE_TOL * max(float(np.max(np.abs(Bn))), 1e-300)
    dtol = _SLOPE_TOL * max(float(np.max(np.abs(Dn))), 1e-300)
    pseg = [(0.0, 2 * L, 0, 1.0, 0.0)]  # (start, end, m, sigma, kappa): p over tau
    allp: list[tuple] = []
    allq: list[tuple] = []  # the same for q(-tau)
    runs: list[list[float]] = []
    contact, eta = w0 <= phi and float(Dn[0]) < 0.0, 0.0
    if contact:
        runs.append([0.0, math.inf])
    block = 0
    while True:
        allp.extend(pseg)
        qseg = []
        for start, end, m, sg, kp in pseg:
            off = 2 * L * m

            def p(s: float, sg: float = sg, kp: float = kp, off: float = off) -> float:
                return sg * float(base(s - off)[0]) + kp

            def dp(s: float, sg: float = sg, off: float = off) -> float:
                return sg * float(base(s - off, True)[1])

            t = start
            while t < end:
                i0, i1 = int(math.floor((t - off) / h)) + 1, int(math.ceil((end - off) / h))
                grid = np.concatenate(([t], off + nodes[i0:i1], [end]))
                B, dB = base(grid - off, True)
                if not contact:  # w = w0 - 2 p0 + eta + 2 p comes down to phi: p <= pc
                    pc = 0.5 * (phi - w0 + 2 * p0 - eta)
                    kq = kp + w0 - 2 * p0 + eta
                    hit = np.flatnonzero(sg * B + kp < pc - vtol)
                    t1 = end if hit.size == 0 else _crossing(
                        lambda s, pc=pc: p(s) - pc, grid, int(hit[0]))
                    qseg.append((t, t1, m, sg, kq))
                    if hit.size:
                        runs.append([t1, math.inf])
                        contact = True
                else:  # in contact while p decreases: until sigma B' >= 0
                    hit = np.flatnonzero(sg * dB > dtol)
                    t1 = end if hit.size == 0 else _crossing(dp, grid, int(hit[0]))
                    qseg.append((t, t1, m, -sg, phi - kp))
                    if hit.size:
                        runs[-1][1] = t1
                        eta = phi - w0 + 2 * p0 - 2 * p(t1)
                        contact = False
                t = t1
        qseg = [seg for seg in qseg if seg[1] > seg[0]]
        allq.extend(qseg)
        # the far end: p(2L + tau) = -q(-tau) (clamped), q(-tau) + D (free)
        pseg = [(a + 2 * L, b + 2 * L, m + 1, -sg if clamped else sg,
                 -kq if clamped else kq + D) for a, b, m, sg, kq in qseg]
        block += 1
        if 2 * L * block >= tau_max:  # q known up to tau_max, p up to L + tau_max
            allp.extend(pseg)
            break
    ps, qs = np.array(allp), np.array(allq[::-1])
    # q on [0, L] is the data's: B(2L - z) reflected, -B(2L - z) clamped, B(2L - z) - D free
    pt = (ps[:, 0], 2 * L * ps[:, 2], ps[:, 3], ps[:, 4])
    qt = (np.append(-qs[:, 1], 0.0), np.append(-2 * L * qs[:, 2], 2 * L),
          np.append(qs[:, 3], -1.0 if clamped else 1.0), np.append(qs[:, 4], -D))
    return [(a, b) for a, b in runs], pt, qt


def _crossing(fn: Callable[[float], float], grid: FloatArray, j: int) -> float:
    """Where fn changes sign between grid[j - 1] and grid[j] (grid[0] if j = 0: reached
    at the start), to round-off by scipy's brentq."""
    if j == 0:
        return float(grid[0])
    a, b = float(grid[j - 1]), float(grid[j])
    fa, fb = fn(a), fn(b)
    if fa == 0.0:
        return a
    if fb == 0.0 or fa * fb > 0.0:
        return b  # reached within the tolerance at the node itself
    return float(brentq(fn, a, b, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=200))


def _cubic_table(f: FloatArray, d0: FloatArray, d1: FloatArray) -> FloatArray:
    """Per cell the coefficients a0..a3 of the cubic in theta in [0, 1] with the node
    values f and the scaled slopes h f' of the cell's two ends d0 and d1 (Hermite), the
    table 32-byte aligned (a row is one load)."""
    n = f.size - 1
    f0, f1 = f[:-1], f[1:]
    raw = np.empty(n * 4 + 4)
    at = (-raw.ctypes.data % 32) // 8
    tab = raw[at: at + n * 4].reshape(n, 4)
    tab[:, 0], tab[:, 1] = f0, d0
    tab[:, 2] = 3.0 * (f1 - f0) - 2.0 * d0 - d1
    tab[:, 3] = 2.0 * (f0 - f1) + d0 + d1
    return tab


# ---------------------------------------------------------------------- kernels
# A point: y = x + tau in the segment j of p (pS[j] <= y < pS[j + 1]: at a kink the
# later tau's), r = y - pM[j]; z = x - tau in the segment k of q (qS[k] < z <= qS[k + 1]:
# at a kink the smaller z, the later tau), r = qA[k] - z; row i = floor(r / h) clipped to
# the table, theta = r / h - i; u = (sp P(theta) + kp) + (sq Q(theta) + kq) + u_p,
# u_x = (sp P' - sq Q') / h and u_t = c (sp P' + sq Q') / h, Horner's rule with fused
# multiply-adds. Every point goes through the one 8-lane function `_lanes` (a lone point
# in all 8 lanes, x's last few points padded): the same bits whatever the path.


class Waves(NamedTuple):
    """The solution as the kernels read it: p's segments (starts pS, shifts pM, signs pSg,
    constants pK), q's (qS, qA, qSg, qK), the table of B and P (`tab`, 1 / its step `ih`),
    the wave speed c and the particular solution u_p (module comment above)."""

    pS: np.ndarray
    pM: np.ndarray
    pSg: np.ndarray
    pK: np.ndarray
    qS: np.ndarray
    qA: np.ndarray
    qSg: np.ndarray
    qK: np.ndarray
    tab: np.ndarray
    ih: float
    c: float
    up: float


class SegmentPair(NamedTuple):
    """One pair of segments (of p and of q) splat over 8 lanes: pM, qA, p's sign and
    constant, q's sign and constant."""

    PM: object
    QA: object
    SP: object
    KP: object
    SQ: object
    KQ: object


@njit(cache=True, inline="always")
def _lanes(X, T, seg, UP, C, tab, ih):  # pragma: no cover - compiled
    """(u, u_x, u_t) at the 8 points X of one pair of segments (the `SegmentPair` seg;
    module comment above)."""
    PM, QA, SP, KP, SQ, KQ = seg
    zero, last, IH = vsplat(0.0), vsplat(float(tab.shape[0] - 1)), vsplat(ih)
    two, three = vsplat(2.0), vsplat(3.0)
    S1 = ((X + T) - PM) * IH
    F1 = vfloor(S1)
    F1 = vselect_lt(F1, zero, zero, vselect_lt(last, F1, last, F1))
    H1 = S1 - F1
    S2 = (QA - (X - T)) * IH
    F2 = vfloor(S2)
    F2 = vselect_lt(F2, zero, zero, vselect_lt(last, F2, last, F2))
    H2 = S2 - F2
    a0, a1, a2, a3 = vrows4(tab, F1)
    pv = vfma(H1, vfma(H1, vfma(H1, a3, a2), a1), a0)
    pd = vfma(H1, vfma(H1, three * a3, two * a2), a1)
    b0, b1, b2, b3 = vrows4(tab, F2)
    qv = vfma(H2, vfma(H2, vfma(H2, b3, b2), b1), b0)
    qd = vfma(H2, vfma(H2, three * b3, two * b2), b1)
    DP, DQ = (SP * pd) * IH, (SQ * qd) * IH
    return (vfma(SP, pv, KP) + vfma(SQ, qv, KQ)) + UP, DP - DQ, C * (DP + DQ)


@njit(cache=True, inline="always")
def _seg_p(pS, y):  # pragma: no cover - compiled
    return max(np.searchsorted(pS, y, side="right") - 1, 0)


@njit(cache=True, inline="always")
def _seg_q(qS, z):  # pragma: no cover - compiled
    return max(np.searchsorted(qS, z, side="left") - 1, 0)


@njit(cache=True)
def _points_kernel(x, tau, waves, out):  # pragma: no cover - compiled
    """Point by point (x, tau flat, of the same size) into the `Fields` out: each in all
    8 lanes. waves: the `Waves`."""
    pS, pM, pSg, pK, qS, qA, qSg, qK, tab, ih, c, up = waves
    u, ux, ut = out
    buf = np.empty((3, 8))
    for m in range(x.size):
        jp, jq = _seg_p(pS, x[m] + tau[m]), _seg_q(qS, x[m] - tau[m])
        seg = SegmentPair(vsplat(pM[jp]), vsplat(qA[jq]), vsplat(pSg[jp]), vsplat(pK[jp]),
                          vsplat(qSg[jq]), vsplat(qK[jq]))
        U, UX, UT = _lanes(vsplat(x[m]), vsplat(tau[m]), seg, vsplat(up), vsplat(c), tab, ih)
        vstore(buf[0], 0, U)
        vstore(buf[1], 0, UX)
        vstore(buf[2], 0, UT)
        u[m], ux[m], ut[m] = buf[0, 0], buf[1, 0], buf[2, 0]


@njit(cache=True)
def _run_end(x, m, n, tk, jp, jq, pS, qS):  # pragma: no cover - compiled
    """The first index e > m such that x[e] (sorted) is not in segments (jp, jq), by the
    same comparisons as `_seg_p` and `_seg_q` (bisection: they are monotone in x)."""
    lo, hi = m + 1, n  # x[lo - 1] is in; the answer is in [lo, hi]
    yend = pS[jp + 1] if jp + 1 < pS.size else math.inf
    zend = qS[jq + 1] if jq + 1 < qS.size else math.inf
    while lo < hi:
        mid = (lo + hi) // 2
        if x[mid] + tk < yend and x[mid] - tk <= zend:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True)
def _grid_kernel(x, tau, waves, out):  # pragma: no cover - compiled
    """Every time tau[k] against the points x into the `Fields` out: u[k], ux[k] (and ut[k]
    unless ut is empty); waves: the `Waves`. Sorted x: per time, the runs of points with the
    same segments (one search per run, `_run_end`), 8 points at a time (x's last few
    padded); other x: point by point. The same bits either way (`_lanes`)."""
    pS, pM, pSg, pK, qS, qA, qSg, qK, tab, ih, c, up = waves
    u, ux, ut = out
    want_v = ut.size > 0
    n = x.size
    ordered = True
    for m in range(1, n):
        if not x[m - 1] <= x[m]:
            ordered = False
            break
    if not ordered:
        one, spare = np.empty(n), np.empty(0 if want_v else n)
        for k in range(tau.size):
            one[:] = tau[k]
            _points_kernel(x, one, waves, Fields(u[k], ux[k], ut[k] if want_v else spare))
        return
    pad, buf = np.empty(8), np.empty((3, 8))
    UP, C = vsplat(up), vsplat(c)
    for k in range(tau.size):
        tk = tau[k]
        uk, uxk = u[k], ux[k]
        utk = ut[k] if want_v else uk
        T = vsplat(tk)
        m = 0
        jp = jq = 0
        while m < n:
            # the segments of x[m]: _seg_p's and _seg_q's, walked up from the last run's
            y, z = x[m] + tk, x[m] - tk
            while jp + 1 < pS.size and y >= pS[jp + 1]:
                jp += 1
            while jq + 1 < qS.size and z > qS[jq + 1]:
                jq += 1
            e = _run_end(x, m, n, tk, jp, jq, pS, qS)
            seg = SegmentPair(vsplat(pM[jp]), vsplat(qA[jq]), vsplat(pSg[jp]), vsplat(pK[jp]),
                              vsplat(qSg[jq]), vsplat(qK[jq]))
            # 8 points at a time, past e while x has them: the next run writes those
            # points again (runs in order), so only the last run pads its last points
            j = m
            while j < e and j + 8 <= n:
                U, UX, UT = _lanes(vload(x, j), T, seg, UP, C, tab, ih)
                vstore(uk, j, U)
                vstore(uxk, j, UX)
                if want_v:
                    vstore(utk, j, UT)
                j += 8
            if j < e:
                for i in range(8):
                    pad[i] = x[min(j + i, e - 1)]
                U, UX, UT = _lanes(vload(pad, 0), T, seg, UP, C, tab, ih)
                vstore(buf[0], 0, U)
                vstore(buf[1], 0, UX)
                vstore(buf[2], 0, UT)
                for i in range(j, e):
                    uk[i] = buf[0, i - j]
                    uxk[i] = buf[1, i - j]
                    if want_v:
                        utk[i] = buf[2, i - j]
            m = e
