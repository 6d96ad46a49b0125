"""Exact solution of the bar with a Signorini end, by characteristics (any data).

Problem (notes, section 1)::

    rho u_tt - E u_xx = -rho g            on (0, L) x (0, T),  g >= 0
    0 <= u(0,t)  _|_  E u_x(0,t) <= 0     Signorini at the obstacle x = 0
    far end: u(L,t) = u_L (clamped)  or  u_x(L,t) = 0 (free)
    u(x,0) = u0(x),  u_t(x,0) = v0(x),    u0 in H1, v0 in L2, u0(0) >= 0

Method (notes, section 2a; section 2 of Dabaghi, Petrov, Pousin, Renard 2014), written
around a STATIC particular solution so that every stored quantity stays bounded
(O(data)) for all times. With c = sqrt(E/rho), tau = c t, gam = g/c^2:

    u(x, t) = p(x + tau) + q(x - tau) + u_p(x),    u_p'' = gam,
    free end:    u_p = gam (x^2/2 - L x)          (u_p'(L) = 0, u_p(0) = 0)
    clamped end: u_p = u_L + gam (x^2 - L^2)/2    (u_p(L) = u_L, u_p'(0) = 0)

(rho u_tt - E u_xx = -E u_p'' = -rho g for any p, q.) On [0, L], p = f/2 + V/(2c),
q = f/2 - V/(2c) with f = u0 - u_p and V(x) = int_0^x v0. Let a = u_p'(0) (-gam L free,
0 clamped) and phi = -u_p(0) (0 free, gam L^2/2 - u_L clamped). At the obstacle
w(tau) = p(tau) + q(-tau) = u(0,t) - u_p(0), so u(0,t) >= 0 is w >= phi: a FIXED barrier.
The stress is E u_x(0) = E (p'(tau) + q'(-tau) + a). While w > phi the end is stress
free, q'(-tau) = -p'(tau) - a, so w' = p' - q'(-tau) = 2 p' + a: the free motion of w is
G(tau) = w(0) + 2 (p(tau) - p(0)) + a tau (a linear drift; g = 0: no drift), and w is the
solution of the one-sided Skorokhod problem (inclusion (2.8) of Dabaghi et al. 2014)

    w(tau) = G(tau) + eta(tau),  eta(tau) = max(0, max_{s <= tau} (phi - G(s))),
    q(-tau) = w(tau) - p(tau),   E u_x(0) = E (2 p' + a - w') = -E eta' <= 0.

The far end reflects: free p(L + s) = q(L - s) + p(L) - q(L) (u_x(L) = 0, u_p'(L) = 0);
clamped p(L + s) = -q(L - s) (u(L) = u_L = u_p(L)). For g = 0, u_p is 0 (free) or the
constant u_L (clamped), and the method is Dabaghi et al.'s.

Bounded magnitudes. G and eta drift (like a tau, and eta compensates it: the mean
contact force carries the weight), so they are never formed globally: each block of
length L in tau restarts the Skorokhod problem from the value w_start of w at its
beginning, G_loc(r) = w_start + 2 (p(tau) - p(tau_0)) + a r, eta_loc = max(0, max(phi -
G_loc)), which is the same problem (the old eta is a constant shift) on O(data) numbers.
p and q are bounded for a free far end (a linear drift would be a strain that u_x(L) = 0
forbids). For a clamped end they can drift linearly (mean strain: p(y) ~ beta y,
q(z) ~ beta z, e.g. the clamped bar of the notes, 2b); there they are stored per block
with a gauge offset o_k = p(kL) (P^_k = P_k - o_k, Q^_k = Q_k + o_k), and only the
bounded increments delta_k = o_{k+1} - o_k are kept: u needs the offsets of two
neighbouring blocks only. So round-off is that of O(data) numbers (no c T or (c T)^2
factor). What remains is the accumulation of that round-off from block to block (and
the contact dynamics can amplify it); how far that goes on the dropped bar at long times
is measured in docs/exact-solutions.md.

Discretisation. One grid R in a local coordinate r in [0, L] carries a block of length L
of both p and q: block k holds P_k(r) = p(kL + r) and Q_k(r) = q((1 - k)L - r). The far
end gives P_k from Q_{k-1} and the obstacle gives Q_k from P_{k-1}, both node by node on
the same local grid, so blocks are marched one after the other, each fully vectorised
(np.maximum.accumulate for the running max). All positions are local (r, never
k L + r). Memory and cost are linear in T: about 85 bytes per node at peak (48 stored),
(L + c T) / ds nodes (plus the inserted ones below).

Grid. ds = L / cells_per_length. Default: 20000 cells per length L, but at most
DEFAULT_MAX_NODES (1e7) nodes in all (about 0.9 GB at peak), i.e. cells_per_length =
min(20000, max(20, 1e7 // (number of blocks))), number of blocks ~ (L + c T)/L + 1.
(Dropped bar of the notes: 20000 up to T ~ 160, 3329 at T = 1000.) Give ds or
cells_per_length to choose. The kinks of tuple (piecewise linear) data are added to
the base grid, and so are the instants where the running max is overtaken inside a
cell (an impact, or a re-impact): d = phi - G_loc is linear in a cell, so the crossing
is exact. Without these inserted nodes an impact between two grid nodes would be
smeared over one cell (an O(ds) error in u_t, u_x and in the energy). Inserted nodes
are kept in all later blocks (the kink they mark travels on; each adds one node per
later block); a crossing closer than 1e-9 cells to a node is snapped to that node. To
keep memory linear in T, a block holds at most twice its base number of nodes: beyond
that, further crossings are not inserted (O(ds) smearing of those impacts). The
attribute inserted_nodes counts the inserted nodes, capped_nodes those left out at the
cap (crossings and take-off vertices).

Data: f = u0 - u_p is sampled at the grid nodes; int_0^x v0 uses the midpoint rule per
cell (exact at the nodes for piecewise linear v0, and for v0 with jumps at nodes: tuple
data may repeat an abscissa to describe a jump). Evaluation: p and q are interpolated
linearly between nodes (in local coordinates); u_p is evaluated exactly; derivatives are
cell slopes (the chord slopes: u_p' at the cell midpoint is the chord slope of the
quadratic u_p), propagated through the reflections as slopes (not recomputed from
differences of values, which would amplify round-off by 1/ds).

Convention on nodes (where the derivative jumps): u_t, u_x and the contact stress are the
limits from the future, t -> t+ at fixed x (for p' the cell to the right of x + tau, for
q' the cell to the left of x - tau). So stress(t_impact) is already the contact value and
stress(t_take_off) is 0. At x = 0 the two cells are matched in local block coordinates,
so that round-off in c t cannot pair cells of different times.

Accuracy. u0 is read as its nodal interpolant (tuple data: exactly), so f = u0 - u_p
has f'' = -gam in every cell: p and q are stored as piecewise QUADRATIC, node values,
chord slopes and a curvature sign per cell (second derivative +-gam/2; the far-end
reflection and contact flip the sign, flight keeps it). Crossings (d quadratic in a
cell: exact root) and take-off points inside a cell (the vertex of a concave d, when it
tops the running max) are inserted as nodes. The stored representation plus u_p is then
an exact solution of the problem for the interpolated data (nodal interpolant of u0,
cell averages of v0); its energy is conserved to round-off. Hence for piecewise linear
u0 and piecewise constant v0 whose kinks and jumps lie on the grid (tuple data: always;
callables: at multiples of ds) u, u_t, u_x, the stress, the contact times and the energy
are exact to round-off, with or without gravity (dropped bar: energy 500 to 1e-12 on
any grid). A callable u0 that is not piecewise linear on the grid (e.g. a static
equilibrium, quadratic) is off by its interpolation error, O(ds^2 |u0''|) in u and
O(ds |u0''|) in u_x. A piecewise linear but non-constant v0 makes p, q cubic inside
cells: values exact at nodes, error O(ds^2 |v0'| / c) in u between them, O(ds |v0'|) in
u_t, and the energy is that of the averaged data (conserved exactly, off by O(ds^2)
from the energy of the true data). Callable data with kinks or jumps off the grid give
O(ds) local errors. Lower ds to tighten. Past the node cap (above), crossings are
smeared over one cell (O(ds) local errors).

Evaluation on a grid (`fields_into`: the Gauss points of a mesh against the sample
times, what the error norms use). For one time, x + tau and x - tau are monotone in x,
so along sorted points the cells of p and of q come in runs of consecutive points.
Where the points are dense in the cells (several per cell on average), the runs are
found by a walk over the cells (the run's end estimated from x, then checked on the
points' own local coordinates, so that every point gets the cell that the pointwise
search gives it, node conventions included), and on a run the fields are polynomials in
x - x_a (x_a its first point): u quadratic, u_x and u_t linear, evaluated 8 points at a
time. They differ from the pointwise values (`fields`) by round-off only (the
polynomials are rounded otherwise): a few eps of the data scale (u: max |u| +
L max |u_x|; u_x, u_t: their maxima plus gam L, c gam L;
tests/test_characteristics_runs.py bounds it by 2e-15). Sorted points sparse in the
cells (fewer than _RUN_POINTS per cell: the Gauss points of a mesh on the fine grid of a
smooth scene such as pulse) have no runs: each point needs its own cells. They are
evaluated point by point, with the very values of `fields` (the expressions of the
pointwise kernel, lane by lane, on the cells it finds), but 8 points at a time in
vectors and for a group of sample times at once (`_sparse_kernel`, the comment above
it): in a sample time every point's blocks are k and k + 1, so a point's cell is
guessed from its local coordinate and its block's few nodes off the base grid (the
kinks and inserted nodes, `_sparse_table`), then checked on the cell's nodes as the
pointwise search checks its own; a failed guess (round-off at a node) takes the
pointwise search. A grid with many such nodes per block, and unsorted x, are evaluated
by the pointwise kernel itself. A sample time where some point has no cell (only past
the stored blocks) is evaluated point by point too.

A coarse grid is exact where the data qualify (above): `coarse_solution` builds one,
which is what the scenes with such data use (build and evaluation cost scale with the
number of cells).

contact_intervals() uses the max construction: node j is in contact iff d_j >= 0 and
d_j >= max_{i<j} d_i up to a round-off tolerance (64 eps times the bounded block scale);
inserted crossing nodes are in contact; runs of contact nodes give (impact, take-off)
times; a run of a single node is a grazing touch (zero-length interval). In a contact
node w is set to phi exactly.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from numba import njit, types
from numba.extending import intrinsic
from numpy.typing import ArrayLike, NDArray

from contact_bench.api.plugin import (
    INTERVAL_SLACK,
    Fields,
    check_positive,
    checked_far_end,
    checked_interval,
    flat_points,
    grid_points,
)
from contact_bench.core.simd import (
    array_data,
    f64x8,
    gather_indices,
    gather_lanes,
    gather_pairs,
    is_float_array,
    is_index_array,
    vany,
    vdiv,
    vfloor,
    vfma,
    vgather,
    vload,
    vprefetch,
    vselect_eq,
    vselect_ge,
    vselect_le,
    vselect_lt,
    vsplat,
    vstore,
    vstore_index,
)

__all__ = ["CharacteristicsSolution", "DEFAULT_CELLS_PER_LENGTH", "DEFAULT_MAX_NODES",
           "coarse_solution"]

FloatArray = NDArray[np.float64]
Fn = Callable[[FloatArray], FloatArray]
Data = Callable[[FloatArray], ArrayLike] | tuple[ArrayLike, ArrayLike] | float

DEFAULT_CELLS_PER_LENGTH = 20000
DEFAULT_MAX_NODES = 10_000_000  # default grid: at most this many nodes in all blocks
_MIN_DEFAULT_CELLS = 20  # floor of the default cells per length (memory ~ T beyond)
_ROUND = 64 * np.finfo(float).eps  # relative round-off of the marched (bounded) values
_SNAP = 1e-9  # a crossing closer than this (in cells) after a node is put on the node
_T_SLACK = INTERVAL_SLACK  # relative slack on t in [0, T] and x in [0, L]
_GAUSS = np.array([-1.0, 1.0]) / math.sqrt(3.0)  # 2-point Gauss-Legendre on [-1, 1]
_RUN_POINTS = 6.0  # `fields_into` by runs from this many points per cell (estimated)


def _data_function(name: str, data: Any, L: float) -> tuple[Fn, FloatArray, Fn | None]:
    """A vectorised function of x for u0 / v0, its kinks inside (0, L), and (when known
    exactly) the slope function to be evaluated at cell midpoints."""
    if isinstance(data, tuple):
        if len(data) != 2:
            raise ValueError(f"{name} as a tuple must be (x_samples, values), "
                             f"got {len(data)} items")
        xs = np.asarray(data[0], dtype=float)
        vs = np.asarray(data[1], dtype=float)
        if xs.ndim != 1 or vs.shape != xs.shape or xs.size < 2:
            raise ValueError(f"{name}: x_samples and values must be 1D of equal length >= 2")
        if not (np.all(np.isfinite(xs)) and np.all(np.isfinite(vs))):
            raise ValueError(f"{name}: samples must be finite")
        if np.any(np.diff(xs) < 0):
            raise ValueError(f"{name}: x_samples must be nondecreasing")
        tol = _T_SLACK * L
        if xs[0] > tol or xs[-1] < L - tol:
            raise ValueError(f"{name}: x_samples [{xs[0]:g}, {xs[-1]:g}] must cover [0, L={L:g}]")

        def f(x: FloatArray) -> FloatArray:
            return np.interp(x, xs, vs)

        with np.errstate(divide="ignore", invalid="ignore"):
            seg = np.where(np.diff(xs) > 0, np.diff(vs) / np.diff(xs), 0.0)

        def slope(x: FloatArray) -> FloatArray:
            return seg[np.clip(np.searchsorted(xs, x, side="right") - 1, 0, seg.size - 1)]

        return f, xs[(xs > 0.0) & (xs < L)], slope
    if isinstance(data, (int, float, np.floating, np.integer)) and not isinstance(data, bool):
        const = float(data)

        def fc(x: FloatArray) -> FloatArray:
            return np.full(np.shape(x), const)

        return fc, np.empty(0), lambda x: np.zeros(np.shape(x))
    if callable(data):
        def fcall(x: FloatArray) -> FloatArray:
            val = np.asarray(data(x), dtype=float)
            return np.array(np.broadcast_to(val, np.shape(x)), dtype=float)

        return fcall, np.empty(0), None
    raise ValueError(f"{name} must be a callable, a number or a tuple (x_samples, values)")


def _merge_nodes(base: FloatArray, extra: FloatArray, tol: float) -> FloatArray:
    """Sorted union of base (sorted) and extra, dropping extras within tol of a node."""
    if extra.size == 0:
        return base
    extra = np.unique(extra)
    i = np.searchsorted(base, extra)
    left = base[np.clip(i - 1, 0, base.size - 1)]
    right = base[np.clip(i, 0, base.size - 1)]
    extra = extra[(np.abs(extra - left) > tol) & (np.abs(right - extra) > tol)]
    if extra.size > 1:
        extra = extra[np.concatenate(([True], np.diff(extra) > tol))]
    return np.sort(np.concatenate((base, extra)))



def _before(d: FloatArray) -> FloatArray:
    """max(0, max_{i<j} d_i) for each j."""
    run = np.maximum(np.maximum.accumulate(d), 0.0)
    before = np.empty_like(run)
    before[0] = 0.0
    before[1:] = run[:-1]
    return before


class _Block:
    """One block during the march: local nodes R, node values P, Q (and d = phi - G);
    per cell the shifted chords dP, dQ and the curvature signs sP, sQ (second
    r-derivative s gam / 2)."""

    def __init__(self, R: FloatArray, P: FloatArray, Q: FloatArray, dP: FloatArray,
                 dQ: FloatArray, sP: NDArray[np.int8], sQ: NDArray[np.int8],
                 half: float) -> None:
        self.R, self.P, self.Q, self.dP, self.dQ, self.sP, self.sQ = R, P, Q, dP, dQ, sP, sQ
        self.half = half
        self.h = np.diff(R)
        self.d = np.empty(0)

    def d_shape(self) -> tuple[FloatArray, FloatArray]:
        """Per cell: d'' and d'(r_j+) of d = phi - G, G = w_start + 2 (P - P(0)) + a r."""
        kd = -2.0 * self.half * self.sP
        # the chord from the node values of d (consistent with them, so that roots are
        # placed relative to the values: round-off in d only moves a root by O(eps)/d')
        return kd, np.diff(self.d) / self.h - 0.5 * kd * self.h

    def split(self, j: NDArray[np.intp], xi: FloatArray, dnew: FloatArray) -> None:
        """Insert a node at R[j] + xi in the cells j (sorted, distinct); d there = dnew.
        Values follow the quadratic; the chords of the two halves are the chord plus
        kappa/2 (xi - h) and kappa/2 xi (no differences of values)."""
        h = self.h[j]
        th = xi / h
        pos = j + 1
        left = j + np.arange(j.size)
        for name, sname in (("P", "sP"), ("Q", "sQ")):
            v, sg = getattr(self, name), getattr(self, sname)
            kap = self.half * sg[j]
            vn = v[j] + th * (v[j + 1] - v[j]) + 0.5 * kap * xi * (xi - h)
            setattr(self, name, np.insert(v, pos, vn))
            dname = "d" + name
            dv = getattr(self, dname)
            dj = dv[j]
            dv = np.insert(dv, pos, dj + 0.5 * kap * xi)
            dv[left] = dj + 0.5 * kap * (xi - h)
            setattr(self, dname, dv)
            setattr(self, sname, np.insert(sg, pos, sg[j]))
        self.R = np.insert(self.R, pos, self.R[j] + xi)
        self.d = np.insert(self.d, pos, dnew)
        self.h = np.diff(self.R)


class CharacteristicsSolution:
    """Exact solution by characteristics; see the module docstring.

    u0, v0: vectorised callables of x, numbers (constants), or tuples (x_samples, values)
    read as piecewise linear. ds: grid step (L/ds must be an integer), or
    cells_per_length: the number of cells per length L (default 20000, fewer for long
    runs so that the grid has at most DEFAULT_MAX_NODES nodes). The solution is stored
    for t in [0, T]; evaluating outside raises ValueError.
    """

    def __init__(self, *, L: float, E: float, rho: float, g: float = 0.0,
                 far_end: str = "clamped", u_L: float = 0.0,
                 u0: Data, v0: Data, T: float, ds: float | None = None,
                 cells_per_length: int | None = None) -> None:
        self.L = L = check_positive("L", L)
        self.E = E = check_positive("E", E)
        self.rho = rho = check_positive("rho", rho)
        self.T = T = check_positive("T", T)
        g = float(g)
        if not (g >= 0.0 and math.isfinite(g)):
            raise ValueError(f"g must be >= 0 and finite, got {g!r}")
        self.g = g
        self.far_end, u_L = checked_far_end(far_end, u_L)
        self.u_L = u_L
        self.c = c = math.sqrt(E / rho)
        self.gam = gam = g / c**2

        if ds is not None and cells_per_length is not None:
            raise ValueError("give ds or cells_per_length, not both")
        if ds is not None:
            ds = check_positive("ds", ds)
            n = round(L / ds)
            if n < 1 or abs(n * ds - L) > 1e-9 * L:
                raise ValueError(f"L/ds must be an integer, got L/ds = {L / ds!r}")
        elif cells_per_length is not None:
            n = int(cells_per_length)
            if n != cells_per_length or n < 1:
                raise ValueError(f"cells_per_length must be a positive integer, got "
                                 f"{cells_per_length!r}")
        else:
            blocks = math.ceil(c * T * (1.0 + 1e-9) / L) + 2
            n = min(DEFAULT_CELLS_PER_LENGTH,
                    max(_MIN_DEFAULT_CELLS, DEFAULT_MAX_NODES // blocks - 1))
        self.cells_per_length = n
        self.ds = L / n

        # ---- the static particular solution u_p (u_p'' = gam) and the barrier
        clamped = far_end == "clamped"
        if clamped:
            def up(x: FloatArray) -> FloatArray:
                return u_L + 0.5 * gam * (x * x - L * L)

            def dup(x: FloatArray) -> FloatArray:
                return gam * x
        else:
            def up(x: FloatArray) -> FloatArray:
                return gam * (0.5 * x * x - L * x)

            def dup(x: FloatArray) -> FloatArray:
                return gam * (x - L)
        self._up, self._dup = up, dup
        self._a = a = float(dup(np.float64(0.0)))  # u_p'(0): drift of G
        self._phi = phi = -float(up(np.float64(0.0)))  # barrier: w >= phi

        f_u0, kinks_u0, slope_u0 = _data_function("u0", u0, L)
        f_v0, kinks_v0, _ = _data_function("v0", v0, L)

        # ---- block 0: the data on the local grid (symmetric under r -> L - r)
        snap = _SNAP * self.ds
        kinks = np.concatenate((kinks_u0, kinks_v0))
        R = _merge_nodes(np.linspace(0.0, L, n + 1), np.concatenate((kinks, L - kinks)), snap)
        h = np.diff(R)
        mid = 0.5 * (R[1:] + R[:-1])
        U = f_u0(R)
        v_mid = f_v0(mid)
        V = np.concatenate(([0.0], np.cumsum(v_mid * h)))
        if not (np.all(np.isfinite(U)) and np.all(np.isfinite(V))):
            raise ValueError("u0 and v0 must be finite on [0, L]")
        if U[0] < 0.0:
            raise ValueError(f"u0(0) must be >= 0 (obstacle constraint), got {U[0]!r}")
        if clamped:
            scale = max(float(np.max(np.abs(U))), abs(u_L))
            if abs(U[-1] - u_L) > 1e-9 * scale:
                raise ValueError(f"clamped end: u0(L) = {U[-1]!r} must equal u_L = {u_L!r}")
        du0 = np.diff(U) / h if slope_u0 is None else slope_u0(mid)
        F = U - up(R)
        dF = du0 - dup(mid)  # chord slopes: u_p' at the midpoint is the chord of u_p
        p_data, dp_data = 0.5 * F + V / (2.0 * c), 0.5 * dF + v_mid / (2.0 * c)
        q_data, dq_data = 0.5 * F - V / (2.0 * c), 0.5 * dF - v_mid / (2.0 * c)
        P0, dP0 = p_data, dp_data
        Q0 = np.interp(L - R, R, q_data)  # Q_0(r) = q(L - r), dQ_0/dr = -q'(L - r)
        Q0[0], Q0[-1] = q_data[-1], q_data[0]
        dQ0 = -dq_data[np.clip(np.searchsorted(R, L - mid) - 1, 0, h.size - 1)]
        # slopes are stored shifted by a/2: dP = p' + a/2, dQ = -(q' + a/2), so that
        # u_x = dP - dQ + gam x, u_t = c (dP + dQ), and the stress-free reflection at the
        # obstacle is an exact negation (stress exactly 0 in flight)
        dP0, dQ0 = dP0 + 0.5 * a, dQ0 - 0.5 * a
        if clamped:  # gauge o_0 = p(0): P^_0 = P_0 - o_0, Q^_0 = Q_0 + o_0
            o0 = float(P0[0])
            P0, Q0 = P0 - o0, Q0 + o0
            P0[0] = 0.0
            free_const = 0.0
        else:
            free_const = float(P0[-1] - Q0[0])  # p(L) - q(L)
        w_start = phi + float(U[0])  # w(0) = u0(0) - u_p(0) >= phi

        # ---- march: blocks k = 1..K cover s = kL + r up to (K + 1) L >= L + c T + margin.
        # Per cell: chord slopes (shifted, see above) and the curvature sign s (the
        # second r-derivative of P_k or Q_k is s gam / 2, s = +-1: u0 is read as its nodal
        # interpolant, so f'' = -gam, and the reflections only flip signs).
        tau_max = c * T * (1.0 + 1e-9) + 3.0 * self.ds
        K = max(1, math.ceil(tau_max / L))
        node_cap = 2 * R.size  # per block: memory stays linear in T
        s0 = -np.ones(R.size - 1, dtype=np.int8)
        grids, Ps, Qs, dPs, dQs, sPs, sQs = [R], [P0], [Q0], [dP0], [dQ0], [s0], [s0.copy()]
        deltas = [float(P0[-1]) if clamped else 0.0]  # o_{k+1} - o_k
        runs: list[tuple[float, float]] = []
        open_start: float | None = None
        inserted = 0
        capped = 0  # nodes not inserted because of the node cap
        half = 0.5 * gam
        tk = R / c
        for k in range(1, K + 1):
            B = _Block(grids[-1], Ps[-1], Qs[-1], dPs[-1], dQs[-1], sPs[-1], sQs[-1], half)
            delta = deltas[-1]
            # w at the block start from the stored values at that point (same gauge), not
            # carried: a separately carried w would let round-off at the shared node grow
            w_start = float(B.P[0] + B.Q[-1])
            # obstacle: Q_k(r) = q(-tau), tau = (k-1)L + r, from P_{k-1}; local Skorokhod
            B.d = phi - (w_start + 2.0 * (B.P - B.P[0]) + a * B.R)
            # round-off of the (bounded) values at hand
            tol = _ROUND * (abs(phi) + abs(w_start) + 2.0 * float(np.max(np.abs(B.P)))
                            + abs(a) * L)
            room = node_cap - B.R.size
            if gam:
                # concave cells whose vertex tops the running max: a take-off (or a brief
                # contact) inside the cell, insert the vertex
                before = _before(B.d)
                kd, b0 = B.d_shape()
                j = np.flatnonzero((kd < 0) & (b0 > 0) & (b0 + kd * B.h < 0))
                if j.size:
                    xi = b0[j] / -kd[j]
                    dv = B.d[j] + 0.5 * b0[j] * xi
                    th = xi / B.h[j]
                    keep = (dv > before[j + 1] + tol) & (th > _SNAP) & (th < 1.0 - _SNAP)
                    capped += max(int(np.count_nonzero(keep)) - max(room, 0), 0)
                    j, xi, dv = j[keep][:max(room, 0)], xi[keep][:max(room, 0)], dv[keep][
                        :max(room, 0)]
                    if j.size:
                        B.split(j, xi, dv)
                        inserted += j.size
                        room -= j.size
            before = _before(B.d)
            run = np.maximum(before, B.d)  # max(0, max_{i<=j} d_i)
            contact = B.d >= before - tol
            # running max overtaken inside cell (j, j+1): insert the crossing node (d is
            # quadratic in the cell: exact root); also a re-impact right after a take-off
            # at node j inside a convex cell
            kd, b0 = B.d_shape()
            ell = before[1:]
            j = np.flatnonzero((B.d[1:] > ell + tol) & ~(contact[:-1] & (b0 >= 0.0)))
            refused = j[:0]
            if j.size:
                lev = ell[j]
                c0 = np.minimum(B.d[j] - lev, 0.0)
                bj, kj = b0[j], kd[j]
                S = np.sqrt(np.maximum(bj * bj - 2.0 * kj * c0, 0.0))
                with np.errstate(divide="ignore", invalid="ignore"):
                    xi = np.where(bj >= 0.0, -2.0 * c0 / (bj + S), (S - bj) / kj)
                th = xi / B.h[j]
                ok = np.isfinite(th)
                th = np.where(ok, th, 0.0)
                left = j[ok & (th <= _SNAP)]
                contact[left] = True  # crossing on the left node
                inner = ok & (th > _SNAP) & (th < 1.0 - _SNAP)
                if np.count_nonzero(inner) > room:
                    refused = j[inner]
                    capped += refused.size
                    inner[:] = False  # cap reached: not inserted (O(ds) smearing)
                j, xi, lev = j[inner], xi[inner], lev[inner]
                if j.size:
                    pos = j + 1
                    B.split(j, xi, lev)
                    run = np.insert(run, pos, lev)
                    contact = np.insert(contact, pos, True)
                    inserted += j.size
            G = phi - B.d
            w = G + run
            w[contact] = phi  # in contact w is on the barrier
            Qk = w - B.P + delta
            # chords of Q_k: dQ_k/dr = -q'(-tau) = w'(tau) - p'(tau); w' = 0 in a contact
            # cell, else w' = G' = 2 p' + a (eta' = 0; a crossing snapped to a node is
            # taken at the node). Shifted by a/2 (see block 0): contact dQ = -dP, else dP.
            # Curvature: contact Q'' = -P'', flight Q'' = G'' - P'' = P''.
            kd, b0 = B.d_shape()
            full = contact[:-1] & contact[1:] & (b0 >= -tol / B.h)
            dQk = np.where(full, -B.dP, B.dP)
            # a crossing not inserted (node cap) is left inside its cell: the
            # cell is neither contact nor flight; take the chord of the values there
            # (an O(ds) smearing of that impact, consistent with the node values)
            if refused.size:
                dQk[refused] = (Qk[refused + 1] - Qk[refused]) / B.h[refused] - 0.5 * a
            sQk = np.where(full, -B.sP, B.sP).astype(np.int8)
            # far end: P_k(r) = p(L + s), s = (k-1)L + r, from Q_{k-1}
            if clamped:
                Pk = -B.Q - delta
                dPk = -B.dQ
                sPk = -B.sQ
                Pk[0] = 0.0  # gauge o_k = p(kL)
            else:
                Pk = B.Q + free_const
                dPk = B.dQ + a  # u_x(L) = dP - dQ + gam L = 0
                sPk = B.sQ.copy()
                Pk[0] = Ps[-1][-1]  # same point as the previous block's end
            grids.append(B.R)
            Ps.append(Pk)
            Qs.append(Qk)
            dPs.append(dPk)
            dQs.append(dQk)
            sPs.append(sPk)
            sQs.append(sQk)
            deltas.append(float(Pk[-1]) if clamped else 0.0)
            # contact runs, times t = ((k-1)L + r)/c (block k's first node repeats the
            # previous block's last one)
            tk = ((k - 1) * L + B.R) / c
            tk[-1] = k * L / c
            e = np.diff(np.concatenate(([open_start is not None], contact)).astype(np.int8))
            for i in np.flatnonzero(e):
                if e[i] > 0:
                    open_start = float(tk[i])
                else:
                    assert open_start is not None
                    runs.append((open_start, float(tk[max(i - 1, 0)])))
                    open_start = None
        if open_start is not None:
            runs.append((open_start, float(tk[-1])))
        self._runs = runs
        self.inserted_nodes = inserted
        self.capped_nodes = capped

        # ---- global arrays: blocks kept whole (the shared end node appears twice, once
        # in each block's gauge); cells of block k are nodes node0[k] + (0..m_k - 1)
        sizes = np.array([r.size for r in grids], dtype=np.int64)
        self._sizes = sizes
        self._node0 = np.concatenate(([0], np.cumsum(sizes)[:-1]))
        self._cell0 = self._node0 - np.arange(K + 1)  # first cell of each block
        self._ncells = int(np.sum(sizes - 1))
        self._r = np.concatenate(grids)
        self._s0 = np.concatenate([k * L + grids[k][:-1] for k in range(K + 1)])
        del grids
        self._P = np.concatenate(Ps)
        del Ps
        self._Q = np.concatenate(Qs)
        del Qs
        self._dP = np.concatenate(dPs)
        del dPs
        self._dQ = np.concatenate(dQs)
        del dQs
        self._sP = np.concatenate(sPs)
        del sPs
        self._sQ = np.concatenate(sQs)
        del sQs
        self._delta = np.array(deltas)
        self._K = K
        self._lut: NDArray[np.integer] | None = None  # see _lookup_table
        # every block the base grid (no kinks, nothing inserted): cells are found
        # without the lookup table (`_table`)
        self._uniform = bool(np.all(sizes == self.cells_per_length + 1))
        self._sparse: tuple[FloatArray, NDArray[np.int64], NDArray[np.int64]] | None = None
        self._sparse_made = False  # see _sparse_table

    # ------------------------------------------------------------------ helpers
    def _times(self, t: ArrayLike) -> FloatArray:
        return checked_interval("t", t, self.T, f"the stored interval [0, T={self.T!r}]")

    def _points(self, x: ArrayLike, t: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """x and t checked (in the bar, in [0, T]) and clipped, not yet broadcast."""
        return checked_interval("x", x, self.L, f"the bar [0, L={self.L!r}]"), self._times(t)

    def _lookup_table(self) -> NDArray[np.integer]:
        """Per uniform bin of width ds, the last cell starting at or before the bin's
        left end (`_cell_of`'s first guess: no binary search per point)."""
        if self._lut is None:
            nb = int(math.ceil(float(self._s0[-1]) / self.ds)) + 2
            lut = np.searchsorted(self._s0, np.arange(nb) * self.ds, side="right") - 1
            self._lut = np.maximum(lut, 0).astype(np.int32 if lut[-1] < 2**31 else np.int64)
        return self._lut

    def _sparse_table(self) -> tuple[FloatArray, NDArray[np.int64], NDArray[np.int64]] | None:
        """What `_sparse_kernel` guesses cells from (xz, xs, cend): per block b, its nodes
        off the base grid (the kinks of the data, the inserted nodes) xz[xs[b]:xs[b + 1]]
        and its last cell cend[b]; None (the pointwise kernel then) when a block has more
        than _SPARSE_EXTRA of them, or when they are not told apart from the base nodes
        (a node closer to a base node than the round-off of r n / L). Made once, in one
        pass over the blocks from the first that has such nodes (on the fine grid of a
        smooth scene: the impacts' inserted nodes, a few per block)."""
        if not self._sparse_made:
            n = self.cells_per_length
            extra = self._sizes - (n + 1)  # nodes off the base grid, per block
            table = None
            if int(np.max(extra)) <= _SPARSE_EXTRA:
                xs = np.concatenate(([0], np.cumsum(extra))).astype(np.int64)
                xz = np.empty(0)
                tol = max(1e-10, 64.0 * np.finfo(float).eps * n)
                found = np.zeros_like(extra)
                if xs[-1] > 0:  # base nodes: R = i L / n (np.linspace), r n / L = i + O(eps n)
                    lo = int(self._node0[int(np.argmax(extra > 0))])
                    g = self._r[lo:] * (n / self.L)
                    at = lo + np.flatnonzero(np.abs(g - np.rint(g)) > tol)
                    xz = self._r[at]
                    found = np.bincount(np.searchsorted(self._node0, at, side="right") - 1,
                                        minlength=extra.size)
                if np.array_equal(found, extra):
                    table = (xz, xs, (self._cell0 + self._sizes - 2).astype(np.int64))
            self._sparse, self._sparse_made = table, True
        return self._sparse

    def _table(self) -> NDArray[np.integer]:
        """What `_locate` guesses cells from: the lookup table, or on a uniform grid none
        (the bin is the cell but for round-off; the cells found are the same)."""
        return _NO_TABLE if self._uniform else self._lookup_table()

    def _fields(self, x: FloatArray, tau: FloatArray, value: bool, slopes: bool
                ) -> tuple[FloatArray | None, FloatArray | None, FloatArray | None]:
        """u, and p'(x + tau) + a/2, -(q'(x - tau) + a/2) (limits from the future), from
        one search of the cells of each family (`_fields_kernel`)."""
        xf, tf, shape = flat_points(x, tau)
        u = np.empty(xf.size) if value else np.empty(0)
        dp = np.empty(xf.size) if slopes else np.empty(0)
        dq = np.empty(xf.size) if slopes else np.empty(0)
        _fields_kernel(xf, tf, self._stored(), self._table(), u, dp, dq)
        return ((u.reshape(shape) if value else None), (dp.reshape(shape) if slopes else None),
                (dq.reshape(shape) if slopes else None))

    def _u(self, x: FloatArray, tau: FloatArray) -> FloatArray:
        return self._fields(x, tau, True, False)[0]

    def _slopes(self, x: FloatArray, tau: FloatArray) -> tuple[FloatArray, FloatArray]:
        """p'(x + tau) + a/2 and -(q'(x - tau) + a/2), limits from the future."""
        _, dp, dq = self._fields(x, tau, False, True)
        return dp, dq

    # ------------------------------------------------------------------ public API
    @property
    def nbytes(self) -> int:
        """Memory held by the stored representation, in bytes."""
        arrays = (self._r, self._s0, self._P, self._Q, self._dP, self._dQ, self._sP,
                  self._sQ, self._sizes, self._node0, self._cell0, self._delta)
        tables = (() if self._lut is None else (self._lut,)) + (self._sparse or ())
        return sum(a.nbytes for a in arrays + tables)

    def u(self, x: ArrayLike, t: ArrayLike) -> FloatArray:
        """Displacement u(x, t)."""
        x, t = self._points(x, t)
        return self._u(x, self.c * t)

    def ut(self, x: ArrayLike, t: ArrayLike) -> FloatArray:
        """Velocity u_t = c (p'(x + tau) - q'(x - tau)) (limit t -> t+ on kinks)."""
        x, t = self._points(x, t)
        dp, dq = self._slopes(x, self.c * t)
        return self.c * (dp + dq)

    def ux(self, x: ArrayLike, t: ArrayLike) -> FloatArray:
        """Strain u_x = p'(x + tau) + q'(x - tau) + u_p'(x) (limit t -> t+ on kinks)."""
        x, t = self._points(x, t)
        dp, dq = self._slopes(x, self.c * t)
        return dp - dq + self.gam * x

    def fields(self, x: ArrayLike, t: ArrayLike, velocity: bool = True
               ) -> tuple[FloatArray, FloatArray, FloatArray | None]:
        """(u, u_x, u_t) at once, equal to `u`, `ux` and `ut` (u_t None unless
        `velocity`); the cells are searched once for the three (what the error norms
        use)."""
        x, t = self._points(x, t)
        u, dp, dq = self._fields(x, self.c * t, True, True)
        ux = dp - dq + self.gam * x
        return u, ux, (self.c * (dp + dq) if velocity else None)

    def fields_into(self, x: ArrayLike, t: ArrayLike, u: FloatArray, ux: FloatArray,
                    ut: FloatArray | None = None) -> None:
        """`fields` at the points (x[m], t[k]) written into u[k, m], ux[k, m] and ut[k, m]
        (x, t 1-D; the outputs C-contiguous float arrays of shape (t.size, x.size))
        without temporaries: what the error norms use. For sorted x dense in the cells,
        by runs of points per cell, equal to `fields` up to round-off (module docstring,
        "Evaluation on a grid"); otherwise point by point, the very values of `fields`
        (sorted x: 8 points at a time, `_evaluation`)."""
        x, t = grid_points(x, t, u, ux, ut)
        # the checks and clipping of `_points`, from one pass over each array
        xlo, xhi, ordered = scan_range(x)
        tlo, thi, _ = scan_range(t)
        sx, st = _T_SLACK * self.L, _T_SLACK * self.T
        if not (xlo >= -sx and xhi <= self.L + sx and tlo >= -st and thi <= self.T + st):
            self._points(x, t)  # raises the ValueError that names the bad value
        if xlo < 0.0 or xhi > self.L:
            x = np.clip(x, 0.0, self.L)
        if tlo < 0.0 or thi > self.T:
            t = np.clip(t, 0.0, self.T)
        how = self._evaluation(x.size, ordered, xhi - xlo)
        sparse = how == "sparse"
        _fields_grid(_HOW[how], x, self.c * t, self._stored(),
                     _NO_TABLE if sparse else self._table(),
                     self._sparse_guess() if sparse else _NO_GUESS,
                     Fields(u, ux, _NO_FIELD if ut is None else ut))

    def _evaluation(self, size: int, ordered: bool, span: float) -> str:
        """How `fields_into` evaluates `size` points spanning `span`: "runs" (sorted and
        dense in the cells, `_by_runs`), "sparse" (sorted otherwise, `_sparse_kernel`, if
        the grid has its table), else "points" (`_grid_kernel`). The three give the same
        cells; "sparse" and "points" the same bits."""
        if self._by_runs(size, ordered, span):
            return "runs"
        if ordered and size > 0 and self._sparse_table() is not None:
            return "sparse"
        return "points"

    def _sparse_guess(self) -> SparseGuess:
        """`_sparse_kernel`'s data for its guesses: uniform grid or not, the last entry of
        the lookup table and s0 (`_exact_cell`), then `_sparse_table`."""
        table = self._sparse_table()
        assert table is not None
        nlut = int(math.ceil(float(self._s0[-1]) / self.ds)) + 1  # `_lookup_table`'s
        return SparseGuess(self._uniform, nlut, self._s0, *table)

    def _stored(self) -> Stored:
        """What the kernels read of the solution (`Stored`)."""
        return Stored(self.L, self.gam, self.far_end == "clamped", self.u_L, self.c, self.ds,
                      self._cell0, self._r, self._P, self._Q, self._dP, self._dQ, self._sP,
                      self._sQ, self._delta, self._ncells)

    def _by_runs(self, size: int, ordered: bool, span: float) -> bool:
        """Whether `fields_into` takes the runs of points per cell (module docstring) for
        `size` points: sorted, and on average at least _RUN_POINTS of them per cell
        over their range `span` (cells counted with the inserted nodes)."""
        if size < 2 or not ordered:
            return False
        cell = self.L * (self._K + 1) / self._ncells  # mean cell length
        return span <= 0.0 or size * cell >= _RUN_POINTS * span

    def stress(self, t: ArrayLike) -> FloatArray:
        """Contact stress E u_x(0, t) <= 0 (limit t -> t+)."""
        return self.E * self.ux(0.0, t)

    def contact_displacement(self, t: ArrayLike) -> FloatArray:
        """u(0, t) >= 0."""
        return self.u(0.0, t)

    def contact_intervals(self) -> list[tuple[float, float]]:
        """(impact, take-off) times of the contact periods in [0, T]; see module doc."""
        out: list[tuple[float, float]] = []
        for ta, tb in self._runs:
            if ta > self.T:
                break
            out.append((float(max(ta, 0.0)), float(min(tb, self.T))))
        return out

    def energy(self, t: ArrayLike, nquad: int | None = None) -> FloatArray:
        """1/2 int (rho u_t^2 + E u_x^2) dx + int rho g u dx at the times t.

        nquad=None: exact quadrature of the representation (2-point Gauss on the cells
        cut by all the characteristic-grid nodes that the two families x + tau and
        x - tau bring into [0, L]; u_p is quadratic). nquad=n: midpoint rule on n
        uniform cells.
        """
        t = self._times(t)
        if nquad is not None and (int(nquad) != nquad or nquad < 1):
            raise ValueError(f"nquad must be a positive integer, got {nquad!r}")
        out = np.empty(t.shape)
        for idx, ti in np.ndenumerate(t):
            out[idx] = self._energy_at(float(ti), nquad)
        return out

    def _energy_at(self, t: float, nquad: int | None) -> float:
        L, tau = self.L, self.c * t
        if nquad is None:
            k = int(math.floor(tau / L))
            rho = tau - k * L
            xs = [np.array([0.0, L])]
            for b in range(max(k, 0), min(k + 1, self._K) + 1):
                r = self._r[self._node0[b]:self._node0[b] + self._sizes[b]]
                xp = (b - k) * L + (r - rho)  # p family: x = s - tau
                xs.append(xp)
                xs.append(L - xp)  # q family: x = L + tau - s
            xb = np.unique(np.clip(np.concatenate(xs), 0.0, L))
            w = np.diff(xb)
            xm = 0.5 * (xb[1:] + xb[:-1])
            xq = np.concatenate([xm + 0.5 * w * z for z in _GAUSS])
            wq = np.concatenate([0.5 * w, 0.5 * w])
        else:
            xb = np.linspace(0.0, L, int(nquad) + 1)
            wq = np.diff(xb)
            xq = 0.5 * (xb[1:] + xb[:-1])
        taus = np.full_like(xq, tau)
        dp, dq = self._slopes(xq, taus)
        ut = self.c * (dp + dq)
        ux = dp - dq + self.gam * xq
        e = 0.5 * np.dot(wq, self.rho * ut**2 + self.E * ux**2)
        if self.g:
            e += self.rho * self.g * np.dot(wq, self._u(xq, taus))
        return float(e)


def coarse_solution(cells_per_length: int = 1, **kwargs: Any) -> CharacteristicsSolution:
    """`CharacteristicsSolution(**kwargs)` on a grid of `cells_per_length` cells per length
    L, for data that this grid carries exactly (module docstring, "Accuracy": u0 piecewise
    linear and v0 piecewise constant with their kinks and jumps on the grid, e.g.
    constants or tuples): then the solution is that of the default grid up to round-off,
    but built in about a millisecond and evaluated by long runs of points per cell
    (`fields_into`). Whether the data qualify is the caller's claim, to be tested against
    the default grid. If a crossing or a take-off vertex was left out at the node cap
    (`capped_nodes`: an O(ds) smearing, large on a coarse grid), the default grid is
    used instead."""
    if "ds" in kwargs:
        raise ValueError("coarse_solution sets the grid: give cells_per_length, not ds")
    sol = CharacteristicsSolution(cells_per_length=cells_per_length, **kwargs)
    return CharacteristicsSolution(**kwargs) if sol.capped_nodes else sol


# ------------------------------------------------------------------ compiled evaluation
#
# By chunks of points, in stages: the local coordinates of both families, the cell
# search, the interpolation, in the order of operations of the formulas in the
# docstrings (no fastmath: the values are the IEEE results of those expressions).


@njit(cache=True)
def _normal(k: float, r: float, L: float) -> tuple[float, float]:
    """(k, r) with 0 <= r < L (values are interpolated in local coordinates). A tiny
    negative r whose r + L rounds to L is the node k L itself: (k, 0), not (k - 1, L),
    which no cell holds (the search would take a cell of block k and extrapolate it)."""
    if r >= L:
        return k + 1.0, r - L
    if r < 0.0:
        r = r + L
        if r < L:
            return k - 1.0, r
        return k, 0.0
    return k, r


@njit(cache=True)
def _cell_of(k: float, r: float, i: int, b: int, L: float, cell0: np.ndarray, rn: np.ndarray,
             last: int) -> tuple[int, int]:
    """(cell, block) containing the point s = k L + r (cell to the right on a node), from
    a first guess: cell i, block b near it.

    The guess is corrected by comparing (k, r) with (block, local nodes)
    lexicographically, one cell per pass, so that the choice of cell does not depend on
    how k L + r rounds. The block of cell i is the last b with cell0[b] <= i (cell0[b] =
    b's first cell); it moves with i.
    """
    nb = cell0.size
    while b > 0 and cell0[b] > i:
        b -= 1
    while b + 1 < nb and cell0[b + 1] <= i:
        b += 1
    for _ in range(64):
        r0 = rn[i + b]
        r1 = rn[i + b + 1]
        up = ((b < k) or (b == k and r >= r1)) and i < last
        down = ((b > k and r < L) or (b == k and r < r0)) and i > 0
        if not (up or down):
            return i, b
        i += 1 if up else -1
        if b > 0 and cell0[b] > i:
            b -= 1
        elif b + 1 < nb and cell0[b + 1] <= i:
            b += 1
    return i, b


class Stored(NamedTuple):
    """The stored representation as the kernels read it: the bar's length L, the
    gravity term gam, the far end (clamped, at u_L), the wave speed c, the lookup bin ds;
    the cells (first cell of each block cell0, nodes rn), the values P, Q and slopes dP,
    dQ of p and q at the nodes, their second-derivative terms sP, sQ, the gauge offsets
    delta between blocks and the number of cells."""

    L: float
    gam: float
    clamped: bool
    u_L: float
    c: float
    ds: float
    cell0: np.ndarray
    rn: np.ndarray
    P: np.ndarray
    Q: np.ndarray
    dP: np.ndarray
    dQ: np.ndarray
    sP: np.ndarray
    sQ: np.ndarray
    delta: np.ndarray
    ncells: int


class SparseGuess(NamedTuple):
    """`_sparse_kernel`'s data for its guesses: uniform grid or not, the lookup table's
    last entry nlut and s0 (`_exact_cell`), the nodes off the base grid xz[xs[b]:xs[b +
    1]] of each block b and its last cell cend[b] (`_sparse_table`)."""

    uniform: bool
    nlut: int
    s0: np.ndarray
    xz: np.ndarray
    xs: np.ndarray
    cend: np.ndarray


@njit(cache=True)
def _locate(k, r, sol, lut, ii, bb):  # pragma: no cover - compiled
    """(cell, block) of the points (k[n], r[n]) of the `Stored` sol into ii, bb: a first guess
    from the table on s = k L + r (the last cell starting at or before the bin of width ds
    below s) and the block of k, checked in a loop of its own (it is right but for inserted
    nodes and round-off), and `_cell_of` from that guess where it is not. An empty table
    stands for a uniform grid (every block the base grid, nothing inserted): the guess is
    then the bin itself, within a cell of the right one."""
    L, ds, cell0, rn = sol.L, sol.ds, sol.cell0, sol.rn
    last = sol.ncells - 1
    nl = lut.size - 1
    nb1 = cell0.size - 1
    ids = 1.0 / ds  # a guess: no division needed
    if nl >= 0:
        for n in range(k.size):
            ii[n] = lut[min(max(math.floor((k[n] * L + r[n]) * ids), 0), nl)]
            bb[n] = min(max(int(k[n]), 0), nb1)
    else:
        for n in range(k.size):
            ii[n] = min(max(math.floor((k[n] * L + r[n]) * ids), 0), last)
            bb[n] = min(max(int(k[n]), 0), nb1)
    for n in range(k.size):
        i, b, kn, rr = ii[n], bb[n], k[n], r[n]
        if not (b == kn and cell0[b] <= i and (b == nb1 or i < cell0[b + 1])
                and rn[i + b] <= rr and rr < rn[i + b + 1]):
            ii[n], bb[n] = _cell_of(kn, rr, i, b, L, cell0, rn, last)


_CHUNK = 1024  # points per pass of `_fields_kernel` (its scratch stays in L1)
_NO_TABLE = np.empty(0, np.int32)  # `_locate` on a uniform grid
_NO_FIELD = np.empty((0, 0))  # `fields_into` without u_t


@njit(cache=True)
def _fields_kernel(x, tau, sol, lut, u, dp, dq):  # pragma: no cover - compiled
    """u (if u.size) and the shifted slopes dp, dq (if dp.size) at the points (x, tau) of
    the `Stored` sol (lut: `_locate`'s table).

    p(x + tau) and q(x - tau) as (block k, local r): block k of p holds p(k L + r), block
    k of q holds q((1 - k) L - r); at x = 0 and x = L both families get the very same
    local coordinate, hence matching cells. By chunks of points, in stages (coordinates,
    cells, values), each a loop without data-dependent branches in the usual case.
    """
    L, gam, clamped, u_L, c, ds, cell0, rn, P, Q, dP, dQ, sP, sQ, delta, ncells = sol
    CH = _CHUNK
    kp, rp, kq, rq = np.empty(CH), np.empty(CH), np.empty(CH), np.empty(CH)
    ip, bp = np.empty(CH, np.int64), np.empty(CH, np.int64)
    iq, bq = np.empty(CH, np.int64), np.empty(CH, np.int64)
    qa = 0.25 * gam
    ha = 0.5 * gam
    nd = delta.size - 1
    want_u = u.size > 0
    want_s = dp.size > 0
    for c0 in range(0, x.size, CH):
        nc = min(CH, x.size - c0)
        for m in range(nc):
            xn = x[c0 + m]
            tn = tau[c0 + m]
            k = math.floor(tn / L)
            rho = tn - k * L
            a = xn + rho
            low = a < L
            kp[m], rp[m] = _normal(k if low else k + 1.0, a if low else (xn - L) + rho, L)
            e = rho - xn
            pos = e >= 0.0
            kq[m], rq[m] = _normal(k + 1.0 if pos else k, e if pos else (L - xn) + rho, L)
        _locate(kp[:nc], rp[:nc], sol, lut, ip, bp)
        _locate(kq[:nc], rq[:nc], sol, lut, iq, bq)
        for m in range(nc):
            i1, b1, r1 = ip[m], bp[m], rp[m]
            i2, b2, r2 = iq[m], bq[m], rq[m]
            p0, p1 = rn[i1 + b1], rn[i1 + b1 + 1]
            q0, q1 = rn[i2 + b2], rn[i2 + b2 + 1]
            n = c0 + m
            if want_u:
                v0 = P[i1 + b1]
                pv = v0 + (r1 - p0) / (p1 - p0) * (P[i1 + b1 + 1] - v0)
                v0 = Q[i2 + b2]
                qv = v0 + (r2 - q0) / (q1 - q0) * (Q[i2 + b2 + 1] - v0)
                if gam:
                    pv = pv + qa * sP[i1] * (r1 - p0) * (r1 - p1)
                    qv = qv + qa * sQ[i2] * (r2 - q0) * (r2 - q1)
                # gauge offsets: o_bp - o_bq, neighbouring blocks only
                if b1 == b2 + 1:
                    off = delta[min(max(b2, 0), nd)]
                elif b2 == b1 + 1:
                    off = -delta[min(max(b1, 0), nd)]
                elif b1 == b2:
                    off = 0.0
                else:  # |x + tau - (x - tau')| <= L
                    raise RuntimeError("characteristics: p and q cells more than a block apart")
                xn = x[n]
                if clamped:
                    up = u_L + 0.5 * gam * (xn * xn - L * L)
                else:
                    up = gam * (0.5 * xn * xn - L * xn)
                u[n] = pv + qv + off + up
            if want_s:
                sp = dP[i1]
                sq = dQ[i2]
                if gam:
                    sp = sp + ha * sP[i1] * (r1 - 0.5 * (p0 + p1))
                    sq = sq + ha * sQ[i2] * (r2 - 0.5 * (q0 + q1))
                dp[n] = sp
                dq[n] = sq


@njit(cache=True)
def _grid_kernel(x, tau, sol, lut, out):  # pragma: no cover - compiled
    """u, u_x = dp - dq + gam x (and u_t = c (dp + dq) unless ut is empty) of the `Stored` sol
    at the points (x[m], tau[k]) into [k, m] of the `Fields` out: the expressions of
    `_fields_kernel` and `fields`, in the same stages, one sample time at a time (its block
    and offset once, u_p and gam x once per point). Written out, not through helpers taking
    arrays (numba would count references to them at every point)."""
    L, gam, clamped, u_L, c, ds, cell0, rn, P, Q, dP, dQ, sP, sQ, delta, ncells = sol
    u, ux, ut = out
    M = x.size
    kp, rp, kq, rq = np.empty(M), np.empty(M), np.empty(M), np.empty(M)
    ip, bp = np.empty(M, np.int64), np.empty(M, np.int64)
    iq, bq = np.empty(M, np.int64), np.empty(M, np.int64)
    upx = np.empty(M)
    gx = np.empty(M)
    for m in range(M):
        xn = x[m]
        if clamped:
            upx[m] = u_L + 0.5 * gam * (xn * xn - L * L)
        else:
            upx[m] = gam * (0.5 * xn * xn - L * xn)
        gx[m] = gam * xn
    qa = 0.25 * gam
    ha = 0.5 * gam
    nd = delta.size - 1
    want_v = ut.size > 0
    for n in range(tau.size):
        tn = tau[n]
        k = math.floor(tn / L)
        rho = tn - k * L
        for m in range(M):
            xn = x[m]
            a = xn + rho
            low = a < L
            kp[m], rp[m] = _normal(k if low else k + 1.0, a if low else (xn - L) + rho, L)
            e = rho - xn
            pos = e >= 0.0
            kq[m], rq[m] = _normal(k + 1.0 if pos else k, e if pos else (L - xn) + rho, L)
        _locate(kp, rp, sol, lut, ip, bp)
        _locate(kq, rq, sol, lut, iq, bq)
        for m in range(M):
            i1, b1, r1 = ip[m], bp[m], rp[m]
            i2, b2, r2 = iq[m], bq[m], rq[m]
            p0, p1 = rn[i1 + b1], rn[i1 + b1 + 1]
            q0, q1 = rn[i2 + b2], rn[i2 + b2 + 1]
            v0 = P[i1 + b1]
            pv = v0 + (r1 - p0) / (p1 - p0) * (P[i1 + b1 + 1] - v0)
            v0 = Q[i2 + b2]
            qv = v0 + (r2 - q0) / (q1 - q0) * (Q[i2 + b2 + 1] - v0)
            sp = dP[i1]
            sq = dQ[i2]
            if gam:
                pv = pv + qa * sP[i1] * (r1 - p0) * (r1 - p1)
                qv = qv + qa * sQ[i2] * (r2 - q0) * (r2 - q1)
                sp = sp + ha * sP[i1] * (r1 - 0.5 * (p0 + p1))
                sq = sq + ha * sQ[i2] * (r2 - 0.5 * (q0 + q1))
            if b1 == b2 + 1:
                off = delta[min(max(b2, 0), nd)]
            elif b2 == b1 + 1:
                off = -delta[min(max(b1, 0), nd)]
            elif b1 == b2:
                off = 0.0
            else:  # |x + tau - (x - tau')| <= L
                raise RuntimeError("characteristics: p and q cells more than a block apart")
            u[n, m] = pv + qv + off + upx[m]
            ux[n, m] = sp - sq + gx[m]
            if want_v:
                ut[n, m] = c * (sp + sq)


# ------------------------------------------------------------------ evaluation by runs
#
# `fields_into` on sorted points (module docstring, "Evaluation on a grid"). Per sample
# time: the runs of each family (consecutive points in one cell), then the pair runs (one
# cell of each family) with the coefficients of their polynomials in x - x_a, then the
# polynomials 8 points at a time. Everything per sample time is written out in the one
# kernel: helpers taking arrays would count references at every call.


@njit(cache=True)
def scan_range(a):  # pragma: no cover - compiled
    """(min, max, nondecreasing) of a 1-D array in one pass; min and max NaN if a holds
    a NaN (so that range checks fail)."""
    lo = np.inf
    hi = -np.inf
    up = True
    for i in range(a.size):
        v = a[i]
        if v != v:
            return np.nan, np.nan, False
        lo = min(lo, v)
        hi = max(hi, v)
        if i > 0 and v < a[i - 1]:
            up = False
    return lo, hi, up


@njit(cache=True)
def _local_point(fam, xn, yn, k, rho, L):  # pragma: no cover - compiled
    """(block, r, path) of the point x = xn for the family fam (0: p at x + tau, with
    yn = x - L; 1: q at x - tau, with yn = L - x) at tau = k L + rho: the coordinates of
    `_fields_kernel` (the same operations). path = 3 branch + shift, branch 0 for
    x + rho < L (p) or rho - x >= 0 (q), shift 0, 1, 2 for r + L, r, r - L (`_normal`;
    its node case r = 0 goes with shift 1, whose r it does not exceed for p nor undercut
    for q). Along increasing x the path never comes back (it is monotone in the order of
    the cases), and on one path r is a monotone function of x (nondecreasing for p,
    nonincreasing for q): a run checked at both ends holds in between."""
    if fam == 0:
        a = xn + rho
        if a < L:
            kk, rr, br = k, a, 0
        else:
            kk, rr, br = k + 1.0, yn + rho, 1
    else:
        e = rho - xn
        if e >= 0.0:
            kk, rr, br = k + 1.0, e, 0
        else:
            kk, rr, br = k, yn + rho, 1
    kn, rn_ = _normal(kk, rr, L)  # its node case (kk, 0.0) keeps the block: shift 1
    return kn, rn_, 3 * br + int(kn - kk) + 1


@njit(cache=True)
def _run_kernel(x, tau, sol, lut, out):  # pragma: no cover - compiled
    """`_grid_kernel` for sorted x (nondecreasing), by runs of points per cell.

    The cells are those of `_locate` (the same check: block k and r0 <= r < r1, from the
    next cell along the family or the table's guess, `_cell_of` otherwise); a sample time
    where a point has no such cell (none in the stored interval: past its blocks) is done
    by `_grid_kernel`. Returns the number of such sample times.
    """
    L, gam, clamped, u_L, c, ds, cell0, rn, P, Q, dP, dQ, sP, sQ, delta, ncells = sol
    u, ux, ut = out
    M = x.size
    N = tau.size
    if M == 0 or N == 0:
        return 0
    xp = np.empty(M + 8)  # x, padded for the loads of 8 past the end
    ys = np.empty((2, M))  # x - L (p), L - x (q): as `_fields_kernel` rounds them
    upx = np.empty(M)
    for m in range(M):
        xn = x[m]
        xp[m] = xn
        ys[0, m] = xn - L
        ys[1, m] = L - xn
        if clamped:
            upx[m] = u_L + 0.5 * gam * (xn * xn - L * L)
        else:
            upx[m] = gam * (0.5 * xn * xn - L * xn)
    for m in range(M, M + 8):
        xp[m] = x[M - 1]
    # bins of x (2 per point): xb[j] is the first point at or after x0 + j w
    x0 = x[0]
    nbin = 2 * M
    w = (x[M - 1] - x0) / nbin
    if w > 0.0:
        iw = 1.0 / w
        xb = np.empty(nbin + 1, np.int64)
        jj = 0
        for j in range(nbin + 1):
            lim = x0 + j * w
            while jj < M and x[jj] < lim:
                jj += 1
            xb[j] = jj
    else:
        iw = 0.0
        nbin = 0
        xb = np.zeros(1, np.int64)
    runs = np.empty((2, 3, M + 1), np.int64)  # per family: first point, cell, block
    rs = np.empty(2 * M + 1, np.int64)  # first point of each pair run (and M)
    cs = np.empty((2 * M, 8))  # its x_a and coefficients
    tmp = np.empty(24)
    uf = u.reshape(u.size)
    uxf = ux.reshape(ux.size)
    utf = ut.reshape(ut.size)
    want_v = ut.size > 0
    size = u.size
    last = ncells - 1
    nl = lut.size - 1
    nb1 = cell0.size - 1
    qa = 0.25 * gam
    ha = 0.5 * gam
    nd = delta.size - 1
    ids = 1.0 / ds
    dup0 = 0.0 if clamped else -gam * L  # u_p'(x) = gam x + dup0
    nbad = 0
    for n in range(N):
        tn = tau[n]
        k = math.floor(tn / L)
        rho = tn - k * L
        found = True
        for fam in range(2):
            step = 1 if fam == 0 else -1  # p walks up the cells, q down
            m = 0
            nr = 0
            i = -1
            b = 0
            while m < M:
                kk, rr, pa = _local_point(fam, x[m], ys[fam, m], k, rho, L)
                ok = False
                if i >= 0:  # the next cell along the family
                    i += step
                    if 0 <= i <= last:
                        if step > 0 and b < nb1 and i >= cell0[b + 1]:
                            b += 1
                        elif step < 0 and i < cell0[b]:
                            b -= 1
                        ok = b == kk and rn[i + b] <= rr and rr < rn[i + b + 1]
                if not ok:  # `_locate`
                    if nl >= 0:
                        i = lut[min(max(math.floor((kk * L + rr) * ids), 0), nl)]
                    else:
                        i = min(max(math.floor((kk * L + rr) * ids), 0), last)
                    b = min(max(int(kk), 0), nb1)
                    if not (b == kk and cell0[b] <= i and (b == nb1 or i < cell0[b + 1])
                            and rn[i + b] <= rr and rr < rn[i + b + 1]):
                        i, b = _cell_of(kk, rr, i, b, L, cell0, rn, last)
                        if not (b == kk and cell0[b] <= i and (b == nb1 or i < cell0[b + 1])
                                and rn[i + b] <= rr and rr < rn[i + b + 1]):
                            found = False
                            break
                r0 = rn[i + b]
                r1 = rn[i + b + 1]
                # the end of the run: the first point estimated out of the cell (from x),
                # then moved until the point before it is in and the point itself out
                br = pa // 3
                sh = 0.0 if pa - 3 * br == 1 else (L if pa - 3 * br == 0 else -L)
                if fam == 0:
                    xe = r1 - rho - sh + (L if br == 1 else 0.0)
                else:
                    xe = (L if br == 1 else 0.0) + rho + sh - r0
                f = (xe - x0) * iw
                j = M if f > nbin else (xb[int(f)] if f > 0.0 else 0)
                j = max(j, m + 1)
                while j < M and x[j] < xe:
                    j += 1
                while j < M:
                    k2, r2, p2 = _local_point(fam, x[j], ys[fam, j], k, rho, L)
                    if not (p2 == pa and r0 <= r2 and r2 < r1):
                        break
                    j += 1
                while j - 1 > m:
                    k2, r2, p2 = _local_point(fam, x[j - 1], ys[fam, j - 1], k, rho, L)
                    if p2 == pa and r0 <= r2 and r2 < r1:
                        break
                    j -= 1
                runs[fam, 0, nr] = m
                runs[fam, 1, nr] = i
                runs[fam, 2, nr] = b
                nr += 1
                m = j
            runs[fam, 0, nr] = M
            if not found:
                break
        if not found:
            nbad += 1
            _grid_kernel(x, tau[n:n + 1], sol, lut,
                         Fields(u[n:n + 1], ux[n:n + 1], ut[n:n + 1] if want_v else ut))
            continue
        # pair runs: u = c0 + dx (c1 + c2 dx), u_x = e0 + e1 dx, u_t = f0 + f1 dx with
        # dx = x - x_a; p moves by +dx in its local r, q by -dx; the values at x_a are
        # those of `_fields_kernel`'s formulas (up to rounding)
        jp = 0
        jq = 0
        nt = 0
        far = False
        m = 0
        while m < M:
            ep = runs[0, 0, jp + 1]
            eq = runs[1, 0, jq + 1]
            i1 = runs[0, 1, jp]
            b1 = runs[0, 2, jp]
            i2 = runs[1, 1, jq]
            b2 = runs[1, 2, jq]
            db = b1 - b2  # gauge offsets: o_bp - o_bq, neighbouring blocks only
            far |= (db > 1) | (db < -1)
            off = (delta[min(max(b2, 0), nd)] if db == 1
                   else (-delta[min(max(b1, 0), nd)] if db == -1 else 0.0))
            xa = x[m]
            n1 = i1 + b1
            n2 = i2 + b2
            p0 = rn[n1]
            hp = rn[n1 + 1] - p0
            q0 = rn[n2]
            hq = rn[n2 + 1] - q0
            vp = P[n1]
            vq = Q[n2]
            slp = (P[n1 + 1] - vp) / hp
            slq = (Q[n2 + 1] - vq) / hq
            cqp = qa * sP[i1]
            cqq = qa * sQ[i2]
            chp = ha * sP[i1]
            chq = ha * sQ[i2]
            dpa = _local_point(0, xa, ys[0, m], k, rho, L)[1] - p0
            dqa = _local_point(1, xa, ys[1, m], k, rho, L)[1] - q0
            spa = dP[i1] + chp * (dpa - 0.5 * hp)
            sqa = dQ[i2] + chq * (dqa - 0.5 * hq)
            rs[nt] = m
            cs[nt, 0] = xa
            cs[nt, 1] = (vp + dpa * (slp + cqp * (dpa - hp))) + (
                vq + dqa * (slq + cqq * (dqa - hq))) + off + upx[m]
            cs[nt, 2] = ((slp + cqp * (2.0 * dpa - hp)) - (slq + cqq * (2.0 * dqa - hq))
                         + (gam * xa + dup0))
            cs[nt, 3] = cqp + cqq + 0.5 * gam
            cs[nt, 4] = spa - sqa + gam * xa
            cs[nt, 5] = chp + chq + gam
            cs[nt, 6] = c * (spa + sqa)
            cs[nt, 7] = c * (chp - chq)
            nt += 1
            m = min(ep, eq)
            jp += ep == m
            jq += eq == m
        if far:  # |x + tau - (x - tau')| <= L
            raise RuntimeError("characteristics: p and q cells more than a block apart")
        rs[nt] = M
        # 8 points at a time; the last 8 of a run may run into the next run or the next
        # sample time, which are written after it (not past the end of the arrays)
        base = n * M
        for t in range(nt):
            e = rs[t + 1]
            Xa = vsplat(cs[t, 0])
            C0, C1, C2 = vsplat(cs[t, 1]), vsplat(cs[t, 2]), vsplat(cs[t, 3])
            E0, E1 = vsplat(cs[t, 4]), vsplat(cs[t, 5])
            F0, F1 = vsplat(cs[t, 6]), vsplat(cs[t, 7])
            stop = min(e, size - 7 - base)
            j = rs[t]
            while j < stop:
                dx = vload(xp, j) - Xa
                vstore(uf, base + j, vfma(vfma(C2, dx, C1), dx, C0))
                vstore(uxf, base + j, vfma(E1, dx, E0))
                if want_v:
                    vstore(utf, base + j, vfma(F1, dx, F0))
                j += 8
            if j < e:  # at the end of the arrays: through a scratch vector
                dx = vload(xp, j) - Xa
                vstore(tmp, 0, vfma(vfma(C2, dx, C1), dx, C0))
                vstore(tmp, 8, vfma(E1, dx, E0))
                vstore(tmp, 16, vfma(F1, dx, F0))
                for jj in range(j, e):
                    uf[base + jj] = tmp[jj - j]
                    uxf[base + jj] = tmp[8 + jj - j]
                    if want_v:
                        utf[base + jj] = tmp[16 + jj - j]
    return nbad


# ------------------------------------------------------------------ sparse sorted points
#
# `fields_into` on sorted points sparse in the cells (module docstring, "Evaluation on a
# grid"): the Gauss points of a mesh against the sample times on a fine grid, one or two
# points per cell and sample time. Each point needs its own cells, so the work per point
# is that of `_grid_kernel` (the same expressions, lane by lane: the same bits), but 8
# points at a time in 8 x double vectors (`contact_bench.core.simd`: loads, selects, division,
# floor, gathers, prefetches; below, the loads of each lane's cell), for a group of _ROWS
# sample times at once, in two passes: (1) the local coordinates of both families and a
# guess of their cells, without memory access; (2) the cells' data, the check of the
# guess, the values. The guess: in a sample time every point's blocks are k and k + 1
# (tau = k L + rho), so a lane's cell is the block's first cell + floor(r / ds) + the
# block's nodes off the base grid at or below r (its kinks and inserted nodes, a short
# list per block: `_sparse_table`). It is checked on the cell's nodes (r0 <= r < r1)
# as `_locate` checks its own guess; the lanes of a failed check (round-off at a node:
# none on the norms' grids of the scenes) take `_locate`'s own search (`_exact_cell`), so
# every lane has the pointwise kernel's cell, and the values are its values.
# Where the time goes: finding cells (a table, a search per point) is replaced by the
# guess; what is left is loading each point's cell (6 numbers from 3 arrays per family:
# no reuse from point to point) and the arithmetic. The two passes keep each loop's
# dependency chains short (the loads of pass 2 do not wait for the coordinates, nor a
# point's loads for the previous point's). The group of times keeps the cells in cache:
# the cells of point m at time n + d are those of point m' at time n for x_m' = x_m +
# c d dt, so as the 8 points move along x the group's cells slide along the nodes, and
# the lines about to be needed are asked for ahead (a prefetch per cache line, once):
# a first pass over a cold solution then waits for memory far less than point by point.
# The scratch rows are padded so that the 9 of one lane are not 4 kB apart (one cache
# set).

_ROWS = 64  # sample times per pass of `_sparse_kernel` over 8 points
_PREFETCH_MAX = 1 << 13  # at most this many elements asked for at once (a hint)
_SPARSE_EXTRA = 16  # at most this many nodes off the base grid per block for it


@intrinsic
def _vgather_cell(typingctx, rn, V, D, jn, jc, i):
    """(rn[j], rn[j + 1], V[j], V[j + 1], D[k]) lane by lane, j = jn[i + lane] (a cell's
    first node), k = jc[i + lane] (the cell): the data of a lane's cell."""
    if not (is_float_array(rn) and is_float_array(V) and is_float_array(D) and is_index_array(jn)
            and is_index_array(jc) and isinstance(i, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        nodes = gather_indices(context, builder, sig, args, 3)
        cells = gather_indices(context, builder, sig, args, 4)
        r0, r1 = gather_pairs(builder, array_data(context, builder, sig.args[0], args[0]), nodes)
        v0, v1 = gather_pairs(builder, array_data(context, builder, sig.args[1], args[1]), nodes)
        d = gather_lanes(context, builder, sig.args[2], args[2], cells)
        return context.make_tuple(builder, sig.return_type, [r0, r1, v0, v1, d])
    return types.UniTuple(f64x8, 5)(rn, V, D, jn, jc, i), codegen


@njit(cache=True)
def _prefetch_range(a, lo, hi):  # pragma: no cover - compiled
    """Ask for the cache lines of a[lo:hi] (nothing if the range is empty or larger than
    _PREFETCH_MAX: a hint)."""
    lo = max(lo, 0)
    hi = min(hi, a.size)
    if hi - lo <= _PREFETCH_MAX:
        step = max(64 // a.itemsize, 1)
        for i in range(lo - lo % step, hi, step):
            vprefetch(a, i)


@njit(cache=True)
def _first_guess(kn, rr, L, ds, uniform, nlut, s0, last):  # pragma: no cover - compiled
    """`_locate`'s first guess of the cell of (kn, rr): on a uniform grid the bin of width
    ds, otherwise the lookup table's entry (`_lookup_table`), found by the search that
    makes the table, so that the table is not needed."""
    g = math.floor((kn * L + rr) * (1.0 / ds))
    if uniform:
        return min(max(g, 0), last)
    key = min(max(g, 0), nlut) * ds  # np.searchsorted(s0, key, side="right") - 1, >= 0
    lo = 0
    hi = s0.size
    while lo < hi:
        mid = (lo + hi) >> 1
        if s0[mid] <= key:
            lo = mid + 1
        else:
            hi = mid
    return max(lo - 1, 0)


@njit(cache=True)
def _exact_cell(kn, rr, L, ds, guess, cell0, rn, last):  # pragma: no cover
    """(cell, block) of the point (kn, rr) as `_locate` finds it: its first guess (from
    the `SparseGuess` guess), its check, and `_cell_of` from the guess."""
    uniform, nlut, s0 = guess.uniform, guess.nlut, guess.s0
    nb1 = cell0.size - 1
    i = _first_guess(kn, rr, L, ds, uniform, nlut, s0, last)
    b = min(max(int(kn), 0), nb1)
    if not (b == kn and cell0[b] <= i and (b == nb1 or i < cell0[b + 1])
            and rn[i + b] <= rr and rr < rn[i + b + 1]):
        i, b = _cell_of(kn, rr, i, b, L, cell0, rn, last)
    return i, b


@njit(cache=True)
def _normal8(k0, r0, Lv, zero, one):  # pragma: no cover - compiled
    """`_normal` lane by lane: (k, r) with 0 <= r < L."""
    T = r0 + Lv
    kk = vselect_lt(r0, zero, vselect_lt(T, Lv, k0 - one, k0), k0)
    rr = vselect_lt(r0, zero, vselect_lt(T, Lv, T, zero), r0)
    return vselect_ge(r0, Lv, k0 + one, kk), vselect_ge(r0, Lv, r0 - Lv, rr)


@njit(cache=True)
def _sparse_kernel(x, tau, sol, guess, out):  # pragma: no cover - compiled
    """`_grid_kernel` (its values, bit for bit) 8 points at a time, for points sparse in
    the cells (see the comment above), of the `Stored` sol into the `Fields` out. guess:
    the `SparseGuess` (xz[xs[b]:xs[b + 1]]: the nodes of block b off the base grid,
    cend[b]: its last cell; uniform, nlut, s0: `_locate`'s guess, `_exact_cell`).
    Returns the number of (8 points, sample time) whose cells were not all guessed."""
    L, gam, clamped, u_L, c, ds, cell0, rn, P, Q, dP, dQ, sP, sQ, delta, ncells = sol
    uniform, nlut, s0, xz, xs, cend = guess
    u, ux, ut = out
    M = x.size
    N = tau.size
    if M == 0 or N == 0:
        return 0
    R = _ROWS
    xp = np.empty(M + 8)  # x, u_p(x), gam x, padded with the last point
    upx = np.empty(M + 8)
    gx = np.empty(M + 8)
    for m in range(M + 8):
        xn = x[min(m, M - 1)]
        xp[m] = xn
        if clamped:
            upx[m] = u_L + 0.5 * gam * (xn * xn - L * L)
        else:
            upx[m] = gam * (0.5 * xn * xn - L * xn)
        gx[m] = gam * xn
    uf = u.reshape(u.size)
    uxf = ux.reshape(ux.size)
    utf = ut.reshape(ut.size)
    want_v = ut.size > 0
    last = ncells - 1
    nd = delta.size - 1
    nb1 = cell0.size - 1
    # per sample time of a group: k, rho; for the blocks k and k + 1: stored or not,
    # first cell, last cell
    row = np.empty((R, 8))
    fs = np.empty((5, R * 8 + 8))  # per lane: k, r of p, of q; to `_exact_cell`
    ix = np.empty((4, R * 8 + 24), np.int64)  # per lane: first node and cell of p, of q
    tmp = np.empty((3, 8))
    zero = vsplat(0.0)
    one = vsplat(1.0)
    mone = vsplat(-1.0)
    Lv = vsplat(L)
    ids = vsplat(1.0 / ds)
    half = vsplat(0.5)
    qa = vsplat(0.25 * gam)
    ha = vsplat(0.5 * gam)
    cv = vsplat(c)
    guessed = 0
    ahead = np.zeros(4, np.int64)  # the ends of what was asked for (p: up to, q: from)
    for n0 in range(0, N, R):
        nr = min(R, N - n0)
        for r in range(nr):
            tn = tau[n0 + r]
            k = math.floor(tn / L)
            row[r, 0] = k
            row[r, 1] = tn - k * L
            for h in range(2):
                bb = k + h
                ok = 0 <= bb <= nb1
                row[r, 2 + h] = 1.0 if ok else 0.0
                row[r, 4 + h] = cell0[bb] if ok else 0.0
                row[r, 6 + h] = cend[bb] if ok else 0.0
        for m0 in range(0, M, 8):
            X = vload(xp, m0)
            XmL = X - Lv  # x - L (p) and L - x (q), rounded as `_grid_kernel` rounds them
            LmX = Lv - X
            # ---- pass 1: coordinates, guesses
            for r in range(nr):
                kf = row[r, 0]
                ik = int(kf)
                K0 = vsplat(kf)
                K1 = vsplat(kf + 1.0)
                RHO = vsplat(row[r, 1])
                C0 = vsplat(row[r, 4])
                C1 = vsplat(row[r, 5])
                E0 = vsplat(row[r, 6])
                E1 = vsplat(row[r, 7])
                both = row[r, 2] == 1.0 and row[r, 3] == 1.0
                o = r * 8
                bad = zero
                for fam in range(2):
                    if fam == 0:  # p at x + tau: (k, x + rho) or (k + 1, (x - L) + rho)
                        A = X + RHO
                        k0 = vselect_lt(A, Lv, K0, K1)
                        r0 = vselect_lt(A, Lv, A, XmL + RHO)
                    else:  # q at x - tau: (k + 1, rho - x) or (k, (L - x) + rho)
                        A = RHO - X
                        k0 = vselect_ge(A, zero, K1, K0)
                        r0 = vselect_ge(A, zero, A, LmX + RHO)
                    plain = both and not vany(
                        vselect_lt(r0, zero, one, vselect_ge(r0, Lv, one, zero)))
                    if plain:  # 0 <= r < L in every lane (`_normal` keeps it), blocks kept
                        kk, rr = k0, r0
                        okv = one
                    else:
                        kk, rr = _normal8(k0, r0, Lv, zero, one)
                        okv = vselect_eq(kk, K0, vsplat(row[r, 2]),
                                         vselect_eq(kk, K1, vsplat(row[r, 3]), zero))
                    G = vfloor(rr * ids)
                    if 0 <= ik and ik + 1 <= nb1 and xs[ik + 2] > xs[ik]:
                        below0 = zero  # nodes off the base grid at or below r
                        for q in range(xs[ik], xs[ik + 1]):
                            below0 = below0 + vselect_le(vsplat(xz[q]), rr, one, zero)
                        below1 = zero
                        for q in range(xs[ik + 1], xs[ik + 2]):
                            below1 = below1 + vselect_le(vsplat(xz[q]), rr, one, zero)
                        G = G + vselect_eq(kk, K1, below1, below0)
                    c0 = vselect_eq(kk, K1, C1, C0)
                    cell = c0 + G
                    cell = vselect_lt(cell, c0, c0, cell)
                    ce = vselect_eq(kk, K1, E1, E0)
                    cell = vselect_lt(ce, cell, ce, cell)
                    if not plain:  # lanes of other blocks: to `_exact_cell`
                        cell = vselect_eq(okv, one, cell, zero)
                        bad = vselect_eq(okv, one, bad, one)
                    vstore(fs[2 * fam], o, kk)
                    vstore(fs[2 * fam + 1], o, rr)
                    vstore_index(ix[2 * fam], o, vselect_eq(okv, one, cell + kk, zero))
                    vstore_index(ix[2 * fam + 1], o, cell)
                vstore(fs[4], o, bad)
            # ---- ask for the cells' lines not asked for yet: the 8 points' cells over
            # the group's times, from the first time's first point to the last time's
            # last one for p (sorted x and t), the other way for q; with x the range
            # slides up the nodes for p, down for q (first 8 points: the whole range)
            e = (nr - 1) * 8
            for fam in range(2):
                V = P if fam == 0 else Q
                D = dP if fam == 0 else dQ
                S = sP if fam == 0 else sQ
                lo = ix[2 * fam, 0] if fam == 0 else ix[2 * fam, 7]
                hi = (ix[2 * fam, e + 7] if fam == 0 else ix[2 * fam, e]) + 2
                lc = ix[2 * fam + 1, 0] if fam == 0 else ix[2 * fam + 1, 7]
                hc = (ix[2 * fam + 1, e + 7] if fam == 0 else ix[2 * fam + 1, e]) + 1
                if m0 > 0 and fam == 0:
                    lo, lc = max(lo, ahead[0]), max(lc, ahead[1])
                elif m0 > 0:
                    hi, hc = min(hi, ahead[2]), min(hc, ahead[3])
                for a in (rn, V):
                    _prefetch_range(a, lo, hi)
                _prefetch_range(D, lc, hc)
                if gam:
                    _prefetch_range(S, lc, hc)
                if fam == 0:
                    ahead[0], ahead[1] = hi, hc
                else:
                    ahead[2], ahead[3] = lo, lc
            # ---- pass 2: the cells' data, the checks, the values
            UP = vload(upx, m0)
            GX = vload(gx, m0)
            for r in range(nr):
                o = r * 8
                rp = vload(fs[1], o)
                rq = vload(fs[3], o)
                p0, p1, P0, P1, sp = _vgather_cell(rn, P, dP, ix[0], ix[1], o)
                q0, q1, Q0, Q1, sq = _vgather_cell(rn, Q, dQ, ix[2], ix[3], o)
                bad = vload(fs[4], o)
                bad = vselect_le(p0, rp, bad, one)
                bad = vselect_lt(rp, p1, bad, one)
                bad = vselect_le(q0, rq, bad, one)
                bad = vselect_lt(rq, q1, bad, one)
                redo = vany(bad)
                if redo:  # every lane's cells as `_locate` finds them, and the offsets
                    guessed += 1
                    for fam in range(2):
                        for lane in range(o, o + 8):
                            i, b = _exact_cell(fs[2 * fam, lane], fs[2 * fam + 1, lane], L,
                                               ds, guess, cell0, rn, last)
                            ix[2 * fam, lane] = i + b
                            ix[2 * fam + 1, lane] = i
                    for lane in range(8):
                        b1 = ix[0, o + lane] - ix[1, o + lane]
                        b2 = ix[2, o + lane] - ix[3, o + lane]
                        if b1 == b2 + 1:
                            tmp[0, lane] = delta[min(max(b2, 0), nd)]
                        elif b2 == b1 + 1:
                            tmp[0, lane] = -delta[min(max(b1, 0), nd)]
                        elif b1 == b2:
                            tmp[0, lane] = 0.0
                        else:  # |x + tau - (x - tau')| <= L
                            raise RuntimeError(
                                "characteristics: p and q cells more than a block apart")
                    off = vload(tmp[0], 0)
                    p0, p1, P0, P1, sp = _vgather_cell(rn, P, dP, ix[0], ix[1], o)
                    q0, q1, Q0, Q1, sq = _vgather_cell(rn, Q, dQ, ix[2], ix[3], o)
                else:  # blocks k and k + 1: offset +-delta[k] where they differ
                    db = vload(fs[0], o) - vload(fs[2], o)
                    D = vsplat(delta[min(max(int(row[r, 0]), 0), nd)])
                    off = vselect_eq(db, one, D, vselect_eq(db, mone, mone * D, zero))
                pv = P0 + vdiv(rp - p0, p1 - p0) * (P1 - P0)
                qv = Q0 + vdiv(rq - q0, q1 - q0) * (Q1 - Q0)
                if gam:
                    gp = vgather(sP, ix[1], o)
                    gq = vgather(sQ, ix[3], o)
                    pv = pv + qa * gp * (rp - p0) * (rp - p1)
                    qv = qv + qa * gq * (rq - q0) * (rq - q1)
                    sp = sp + ha * gp * (rp - half * (p0 + p1))
                    sq = sq + ha * gq * (rq - half * (q0 + q1))
                U = pv + qv + off + UP
                UX = sp - sq + GX
                at = (n0 + r) * M + m0
                if m0 + 8 <= M:
                    vstore(uf, at, U)
                    vstore(uxf, at, UX)
                    if want_v:
                        vstore(utf, at, cv * (sp + sq))
                else:  # the last points: the lanes past M are not written
                    vstore(tmp[0], 0, U)
                    vstore(tmp[1], 0, UX)
                    vstore(tmp[2], 0, cv * (sp + sq))
                    for lane in range(M - m0):
                        uf[at + lane] = tmp[0, lane]
                        uxf[at + lane] = tmp[1, lane]
                        if want_v:
                            utf[at + lane] = tmp[2, lane]
    return guessed


_HOW = {"points": 0, "runs": 1, "sparse": 2}  # `_evaluation` -> `_fields_grid`
_NO_GUESS = SparseGuess(False, 0, np.empty(0), np.empty(0), np.zeros(1, np.int64),
                        np.zeros(1, np.int64))  # `_sparse_kernel`'s guess data, unused


@njit(cache=True)
def _fields_grid(how, x, tau, sol, lut, guess, out):  # pragma: no cover - compiled
    """`fields_into`'s kernel `how` (0: `_grid_kernel`, 1: `_run_kernel`, 2:
    `_sparse_kernel`, `_HOW`) behind one entry: the three are loaded from numba's cache
    at once, by the first call in a process (a warm-up), whichever kernel later points
    need (so that no timed call pays a load)."""
    if how == 1:
        return _run_kernel(x, tau, sol, lut, out)
    if how == 2:
        return _sparse_kernel(x, tau, sol, guess, out)
    _grid_kernel(x, tau, sol, lut, out)
    return 0
