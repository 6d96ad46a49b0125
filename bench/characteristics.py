"""Exact solution of the bar with a Signorini end, by characteristics (any data).

Problem (notes, section 1)::

    rho u_tt - E u_xx = -rho g            on (0, L) x (0, T),  g >= 0
    0 <= u(0,t)  _|_  E u_x(0,t) <= 0     Signorini at the obstacle x = 0
    far end: u(L,t) = u_L (clamped)  or  u_x(L,t) = 0 (free)
    u(x,0) = u0(x),  u_t(x,0) = v0(x),    u0 in H1, v0 in L2, u0(0) >= 0

Method (notes, section 2a; the seed's section 2). With c = sqrt(E/rho), tau = c t and
gam = g/c^2 the solution is u = p(x + tau) + q(x - tau) - gam tau^2/2, where on [0, L]
p = u0/2 + V/(2c), q = u0/2 - V/(2c), V(x) = int_0^x v0. At the obstacle
w(tau) = p(tau) + q(-tau) = u(0,t) + gam tau^2/2 must stay above the barrier
phi(tau) = gam tau^2/2 and is stress free while above it: the one-sided Skorokhod problem

    G(tau) = w(0) + 2 (p(tau) - p(0)),  d = phi - G,
    w(tau) = G(tau) + max(0, max_{s <= tau} d(s)),   q(-tau) = w(tau) - p(tau).

The far end reflects: clamped p(L + s) = u_L + gam s^2/2 - q(L - s) (so that
u(L,t) = u_L with the gravity term); free p(L + s) = q(L - s) + p(L) - q(L).

Discretisation. One grid R in a local coordinate r in [0, L] carries a block of length L
of both p and q: block k holds P_k(r) = p(kL + r) and Q_k(r) = q((1 - k)L - r). The far
end gives P_k from Q_{k-1} and the obstacle gives Q_k from P_{k-1}, both node by node on
the same local grid, so blocks are marched one after the other, each fully vectorised
(np.maximum.accumulate for the running max, carried from block to block). Values are
copied, never accumulated: no error growth with T; memory and cost are linear in T:
about 70 bytes per node, (L + c T) / ds nodes (plus the inserted ones below), so choose
ds for long runs (e.g. cells_per_length=20 is exact for the clamped bar).
The base grid is uniform, ds = L / cells_per_length (default 20000 cells per length L);
the kinks of tuple (piecewise linear) data are added to it, and so are the instants
where the running max is overtaken inside a cell (an impact, or a re-impact), found by
solving phi(s) - G(s) = level in that cell with G linear. Without these inserted nodes
an impact between two grid nodes would be smeared over one cell (an O(ds) error in u_t,
u_x and in the energy). Inserted nodes are kept in all later blocks (the kink they mark
travels on; each adds one node per later block) and a crossing closer than 1e-9 cells to
a node is snapped to that node. The attribute inserted_nodes counts them.

Data: u0 is sampled at the grid nodes; int_0^x v0 uses the midpoint rule per cell (exact
at the nodes for piecewise linear v0, and for v0 with jumps at nodes: tuple data may
repeat an abscissa to describe a jump). Evaluation: p and q are interpolated linearly
between nodes; derivatives are cell slopes, propagated through the reflections as
slopes (not recomputed from differences of values, which would amplify round-off by
1/ds), so they are copied exactly like the values.

Convention on nodes (where the derivative jumps): u_t, u_x and the contact stress are the
limits from the future, t -> t+ at fixed x (for p' the cell to the right of x + tau, for
q' the cell to the left of x - tau). So stress(t_impact) is already the contact value and
stress(t_take_off) is 0. At x = 0 the two cells are matched in local block coordinates,
so that round-off in c t cannot pair cells of different times.

Accuracy. For g = 0 the stored p, q are the exact solution for the data (nodal
interpolant of u0, cell averages of v0). Hence for piecewise linear u0 and piecewise
constant v0 whose kinks and jumps lie on the grid (tuple data: always; callables: at
multiples of ds) u, u_t, u_x, the stress, the contact times and the energy are exact to
round-off (~1e-15 relative for moderate T; the round-off of tau = c t grows like
eps * c T). A piecewise linear but non-constant v0 makes p, q quadratic inside cells:
values exact at nodes, error O(ds^2 |v0'| / c) in u between them, O(ds |v0'|) in u_t,
and the energy is that of the averaged data (conserved exactly, off by O(ds^2) from the
energy of the true data). With gravity the solution has quadratic pieces (w = phi in
contact, the clamped reflection): the error on u is O(gam ds^2), on u_t / c and u_x
O(gam ds) (stress: E gam ds = rho g ds), impact times O(ds^2) when an impact falls inside
a cell. Lower ds to tighten. Callable data with kinks or jumps off the grid give O(ds)
local errors.

contact_intervals() uses the max construction exactly: node j is in contact iff
d_j >= 0 and d_j >= max_{i<j} d_i (float comparison, no tolerance); inserted crossing
nodes are in contact; runs of contact nodes give (impact, take-off) times; a run of a
single node is a grazing touch (zero-length interval).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["CharacteristicsSolution"]

FloatArray = NDArray[np.float64]
Fn = Callable[[FloatArray], FloatArray]
Data = Callable[[FloatArray], ArrayLike] | tuple[ArrayLike, ArrayLike] | float

DEFAULT_CELLS_PER_LENGTH = 20000
_SNAP = 1e-9  # a crossing closer than this (in cells) to a node is put on the node
_T_SLACK = 1e-12  # relative slack on t in [0, T] and x in [0, L]


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


def _check_positive(name: str, value: float) -> float:
    value = float(value)
    if not (value > 0.0 and math.isfinite(value)):
        raise ValueError(f"{name} must be positive and finite, got {value!r}")
    return value


class CharacteristicsSolution:
    """Exact solution by characteristics; see the module docstring.

    u0, v0: vectorised callables of x, numbers (constants), or tuples (x_samples, values)
    read as piecewise linear. ds: grid step (L/ds must be an integer), or
    cells_per_length: the number of cells per length L (default 20000). The solution is
    stored for t in [0, T]; evaluating outside raises ValueError.
    """

    def __init__(self, *, L: float, E: float, rho: float, g: float = 0.0,
                 far_end: str = "clamped", u_L: float = 0.0,
                 u0: Data, v0: Data, T: float, ds: float | None = None,
                 cells_per_length: int | None = None) -> None:
        self.L = L = _check_positive("L", L)
        self.E = E = _check_positive("E", E)
        self.rho = rho = _check_positive("rho", rho)
        self.T = T = _check_positive("T", T)
        g = float(g)
        if not (g >= 0.0 and math.isfinite(g)):
            raise ValueError(f"g must be >= 0 and finite, got {g!r}")
        self.g = g
        if far_end not in ("clamped", "free"):
            raise ValueError(f"far_end must be 'clamped' or 'free', got {far_end!r}")
        self.far_end = far_end
        u_L = float(u_L)
        if not math.isfinite(u_L):
            raise ValueError(f"u_L must be finite, got {u_L!r}")
        self.u_L = u_L

        if ds is not None and cells_per_length is not None:
            raise ValueError("give ds or cells_per_length, not both")
        if ds is not None:
            ds = _check_positive("ds", ds)
            n = round(L / ds)
            if n < 1 or abs(n * ds - L) > 1e-9 * L:
                raise ValueError(f"L/ds must be an integer, got L/ds = {L / ds!r}")
        elif cells_per_length is not None:
            n = int(cells_per_length)
            if n != cells_per_length or n < 1:
                raise ValueError(f"cells_per_length must be a positive integer, got "
                                 f"{cells_per_length!r}")
        else:
            n = DEFAULT_CELLS_PER_LENGTH
        self.cells_per_length = n
        self.ds = L / n

        self.c = c = math.sqrt(E / rho)
        self.gam = gam = g / c**2
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
        if far_end == "clamped":
            scale = max(float(np.max(np.abs(U))), abs(u_L))
            if abs(U[-1] - u_L) > 1e-9 * scale:
                raise ValueError(f"clamped end: u0(L) = {U[-1]!r} must equal u_L = {u_L!r}")
        du0 = np.diff(U) / h if slope_u0 is None else slope_u0(mid)
        p_data, dp_data = 0.5 * U + V / (2.0 * c), 0.5 * du0 + v_mid / (2.0 * c)
        q_data, dq_data = 0.5 * U - V / (2.0 * c), 0.5 * du0 - v_mid / (2.0 * c)
        P0, dP0 = p_data, dp_data
        Q0 = np.interp(L - R, R, q_data)  # Q_0(r) = q(L - r), dQ_0/dr = -q'(L - r)
        Q0[0], Q0[-1] = q_data[-1], q_data[0]
        dQ0 = -dq_data[np.clip(np.searchsorted(R, L - mid) - 1, 0, h.size - 1)]
        self._w0 = w0 = float(U[0])
        p00 = float(P0[0])
        free_const = float(P0[-1] - Q0[0])  # p(L) - q(L)

        # ---- march: blocks k = 1..K cover s = kL + r up to (K + 1) L >= L + c T + margin.
        # Node values and cell slopes are both propagated (slopes are copied, not
        # differenced, so derivatives carry no round-off amplification by 1/ds).
        tau_max = c * T * (1.0 + 1e-9) + 3.0 * self.ds
        K = max(1, math.ceil(tau_max / L))
        grids, Ps, Qs, dPs, dQs = [R], [P0], [Q0], [dP0], [dQ0]
        contacts = [np.zeros(R.size, dtype=bool)]
        carry = 0.0  # running max of d, including the 0 of max(0, ...)
        inserted = 0
        for k in range(1, K + 1):
            R, Pprev, Qprev, dPprev, dQprev = grids[-1], Ps[-1], Qs[-1], dPs[-1], dQs[-1]
            # obstacle: Q_k(r) = q(-tau), tau = (k-1)L + r, from P_{k-1}
            tau = (k - 1) * L + R
            tau[-1] = k * L
            G = w0 + 2.0 * (Pprev - p00)
            d = 0.5 * gam * tau**2 - G
            run = np.maximum(np.maximum.accumulate(d), carry)  # max(0, max_{i<=j} d_i)
            before = np.empty_like(run)  # max(0, max_{i<j} d_i)
            before[0] = carry
            before[1:] = run[:-1]
            contact = d >= before
            carry = float(run[-1])
            # running max overtaken inside cell (j, j+1): insert the crossing node
            j = np.flatnonzero((d[:-1] < before[1:]) & (d[1:] > before[1:]))
            if j.size:
                level = before[j + 1]
                width = R[j + 1] - R[j]
                b = gam * tau[j] - (G[j + 1] - G[j]) / width
                c0 = d[j] - level  # < 0
                theta = np.clip(-2.0 * c0 / (b + np.sqrt(b * b - 2.0 * gam * c0)) / width,
                                0.0, 1.0)
                contact[j[theta <= _SNAP]] = True  # crossing on the left node
                inner = (theta > _SNAP) & (theta < 1.0 - _SNAP)
                j, theta, level = j[inner], theta[inner], level[inner]
            if j.size:
                new_r = R[j] + theta * (R[j + 1] - R[j])
                pos = j + 1
                Pprev = np.insert(Pprev, pos, Pprev[j] + theta * (Pprev[j + 1] - Pprev[j]))
                Qprev = np.insert(Qprev, pos, Qprev[j] + theta * (Qprev[j + 1] - Qprev[j]))
                dPprev = np.insert(dPprev, pos, dPprev[j])  # cell j split in two
                dQprev = np.insert(dQprev, pos, dQprev[j])
                tau = np.insert(tau, pos, (k - 1) * L + new_r)
                G = w0 + 2.0 * (Pprev - p00)
                d = np.insert(d, pos, level)
                run = np.insert(run, pos, level)
                contact = np.insert(contact, pos, True)
                R = np.insert(R, pos, new_r)
                inserted += new_r.size
            Qk = G + run - Pprev
            # slopes of Q_k: q'(-tau) = p'(tau) - w'(tau), w = G + eta; in a contact cell
            # w' is the chord slope of phi, elsewhere eta' = 0 (or its tiny increase)
            full = contact[:-1] & (d[1:] >= run[:-1])
            chord_phi = 0.5 * gam * (tau[1:] + tau[:-1])
            deta = np.diff(run) / np.diff(R)
            dQk = np.where(full, chord_phi - dPprev, dPprev + deta)  # dQ_k/dr = -q'
            # far end: P_k(r) = p(L + s), s = (k-1)L + r, from Q_{k-1}
            if far_end == "clamped":
                s = (k - 1) * L + R
                s[-1] = k * L
                Pk = u_L + 0.5 * gam * s**2 - Qprev
                dPk = 0.5 * gam * (s[1:] + s[:-1]) - dQprev
            else:
                Pk = Qprev + free_const
                dPk = dQprev.copy()
            Pk[0] = Ps[-1][-1]  # same point as the previous block's end
            grids.append(R)
            Ps.append(Pk)
            Qs.append(Qk)
            dPs.append(dPk)
            dQs.append(dQk)
            contacts.append(contact)

        # ---- global arrays on s = kL + r (block k >= 1 drops its first node)
        sg = [grids[0].copy()]
        for k in range(1, K + 1):
            sk = k * L + grids[k][1:]
            sk[-1] = (k + 1) * L
            sg.append(sk)
        self._s = np.concatenate(sg)
        self._P = np.concatenate([Ps[0]] + [a[1:] for a in Ps[1:]])
        self._Q = np.concatenate([Qs[0]] + [a[1:] for a in Qs[1:]])
        self._dP = np.concatenate(dPs)
        self._dQ = np.concatenate(dQs)
        self._contact = np.concatenate([contacts[0]] + [a[1:] for a in contacts[1:]])
        self._contact[grids[0].size - 1] = contacts[1][0]  # t = 0 (block 0 has no flags)
        if np.any(np.diff(self._s) <= 0):  # pragma: no cover - guarded by the snapping
            raise RuntimeError("characteristics grid is not increasing")
        self._cell_block = np.concatenate([np.full(grids[k].size - 1, k, dtype=np.int32)
                                           for k in range(K + 1)])
        self._cell_r0 = np.concatenate([grids[k][:-1] for k in range(K + 1)])
        self._cell_r1 = np.concatenate([grids[k][1:] for k in range(K + 1)])
        self.inserted_nodes = inserted

    # ------------------------------------------------------------------ helpers
    def _times(self, t: ArrayLike) -> FloatArray:
        t = np.asarray(t, dtype=float)
        slack = _T_SLACK * self.T
        if np.any(~np.isfinite(t)) or np.any(t < -slack) or np.any(t > self.T + slack):
            bad = t[~((t >= -slack) & (t <= self.T + slack))].ravel()[0]
            raise ValueError(f"t = {bad!r} outside the stored interval [0, T={self.T!r}]")
        return np.clip(t, 0.0, self.T)

    def _points(self, x: ArrayLike, t: ArrayLike) -> tuple[FloatArray, FloatArray]:
        x = np.asarray(x, dtype=float)
        slack = _T_SLACK * self.L
        if np.any(~np.isfinite(x)) or np.any(x < -slack) or np.any(x > self.L + slack):
            bad = x[~((x >= -slack) & (x <= self.L + slack))].ravel()[0]
            raise ValueError(f"x = {bad!r} outside the bar [0, L={self.L!r}]")
        x = np.clip(x, 0.0, self.L)
        x, t = np.broadcast_arrays(x, self._times(t))
        return x, t

    def _cell(self, s: FloatArray, k: FloatArray, r: FloatArray) -> NDArray[np.intp]:
        """Index of the cell containing the point (cell to the right on a node).

        The point is s = k L + r; the global search on s is corrected by comparing the
        local coordinate r with the local nodes of block k, so that the choice of cell
        does not depend on how k L + r rounds.
        """
        last = self._s.size - 2
        i = np.clip(np.searchsorted(self._s, s, side="right") - 1, 0, last)
        b = self._cell_block[i]
        up = (b < k) | ((b == k) & (r >= self._cell_r1[i]))
        down = ((b > k) & (r < self.L)) | ((b == k) & (r < self._cell_r0[i]))
        return np.clip(i + up.astype(np.intp) - down.astype(np.intp), 0, last)

    def _coords(self, x: FloatArray, tau: FloatArray) -> tuple[tuple[FloatArray, ...],
                                                                   tuple[FloatArray, ...]]:
        """(s, k, r) of p(x + tau) and of q(x - tau), with s = k L + r the grid coordinate.

        The local r is computed without forming k L + r, so that at x = 0 (and x = L) the
        two families get the very same local coordinate and hence matching cells.
        """
        L = self.L
        k = np.floor(tau / L)
        rho = tau - k * L
        a = x + rho
        low = a < L
        kp = np.where(low, k, k + 1.0)
        rp = np.where(low, a, (x - L) + rho)
        e = rho - x
        pos = e >= 0.0
        kq = np.where(pos, k + 1.0, k)
        rq = np.where(pos, e, (L - x) + rho)
        return (kp * L + rp, kp, rp), (kq * L + rq, kq, rq)

    def _u(self, x: FloatArray, tau: FloatArray) -> FloatArray:
        (sp, _, _), (sq, _, _) = self._coords(x, tau)
        return (np.interp(sp, self._s, self._P) + np.interp(sq, self._s, self._Q)
                - 0.5 * self.gam * tau**2)

    def _slopes(self, x: FloatArray, tau: FloatArray) -> tuple[FloatArray, FloatArray]:
        """p'(x + tau) and q'(x - tau), limits from the future."""
        cp, cq = self._coords(x, tau)
        return self._dP[self._cell(*cp)], -self._dQ[self._cell(*cq)]

    # ------------------------------------------------------------------ public API
    def u(self, x: ArrayLike, t: ArrayLike) -> FloatArray:
        """Displacement u(x, t)."""
        x, t = self._points(x, t)
        return self._u(x, self.c * t)

    def ut(self, x: ArrayLike, t: ArrayLike) -> FloatArray:
        """Velocity u_t = c (p'(x + tau) - q'(x - tau)) - g t (limit t -> t+ on kinks)."""
        x, t = self._points(x, t)
        dp, dq = self._slopes(x, self.c * t)
        return self.c * (dp - dq) - self.g * t

    def ux(self, x: ArrayLike, t: ArrayLike) -> FloatArray:
        """Strain u_x = p'(x + tau) + q'(x - tau) (limit t -> t+ on kinks)."""
        x, t = self._points(x, t)
        dp, dq = self._slopes(x, self.c * t)
        return dp + dq

    def stress(self, t: ArrayLike) -> FloatArray:
        """Contact stress E u_x(0, t) <= 0 (limit t -> t+)."""
        return self.E * self.ux(0.0, t)

    def contact_displacement(self, t: ArrayLike) -> FloatArray:
        """u(0, t) >= 0."""
        return self.u(0.0, t)

    def contact_intervals(self) -> list[tuple[float, float]]:
        """(impact, take-off) times of the contact periods in [0, T]; see module doc."""
        on = self._contact.astype(np.int8)
        edges = np.diff(np.concatenate(([0], on, [0])))
        starts = np.flatnonzero(edges == 1)
        ends = np.flatnonzero(edges == -1) - 1
        out: list[tuple[float, float]] = []
        for a, b in zip(starts, ends, strict=True):
            ta = (self._s[a] - self.L) / self.c
            tb = (self._s[b] - self.L) / self.c
            if ta > self.T:
                break
            out.append((float(max(ta, 0.0)), float(min(tb, self.T))))
        return out

    def energy(self, t: ArrayLike, nquad: int | None = None) -> FloatArray:
        """1/2 int (rho u_t^2 + E u_x^2) dx + int rho g u dx at the times t.

        nquad=None: exact quadrature of the piecewise linear representation (midpoints
        of the cells cut by all the characteristic-grid nodes that the two families
        x + tau and x - tau bring into [0, L]). nquad=n: midpoint rule on n uniform cells.
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
            i0 = np.searchsorted(self._s, tau, side="right")
            i1 = np.searchsorted(self._s, tau + L, side="left")
            nodes = self._s[i0:i1]
            xb = np.unique(np.clip(np.concatenate(([0.0, L], nodes - tau, (L + tau) - nodes)),
                                   0.0, L))
        else:
            xb = np.linspace(0.0, L, int(nquad) + 1)
        w = np.diff(xb)
        xm = 0.5 * (xb[1:] + xb[:-1])
        taus = np.full_like(xm, tau)
        dp, dq = self._slopes(xm, taus)
        ut = self.c * (dp - dq) - self.g * t
        ux = dp + dq
        e = 0.5 * np.dot(w, self.rho * ut**2 + self.E * ux**2)
        if self.g:
            e += self.rho * self.g * np.dot(w, self._u(xm, taus))
        return float(e)
