"""A partitioned ("SPIKE") solver for the constant tridiagonal systems of the stepping loops.

A forward-backward tridiagonal solve is a chain of dependent fused multiply-adds, so
it runs at one entry per FMA latency, however wide the vector units are. Here the n
unknowns are cut into `lanes` blocks of m = ceil(n / lanes) consecutive nodes, and
every block is solved at once, one row of all blocks per vector instruction:

- The vectors live in a *lane-interleaved* layout: node i = c m + j (block c, row j)
  is stored at position j * lanes + c. Row j of all blocks is one contiguous slice,
  so the sweeps over j are plain vector loops. Nodes n .. lanes m - 1 are padding
  with an identity row (decoupled, always 0).
- S = D + C, where D is block diagonal (the couplings between blocks removed) and
  C holds the P - 1 removed couplings e_c = S[c m + m - 1, c m + m]. D = L diag(d) L^T
  is factored once (LAPACK dpttrf, outside the loop) and applied lane-parallel.
- With y = D^-1 r, the solution is x = y - A_c a - B_c b in block c, where the spikes
  a = D^-1 (first unit vector of every block) and b = D^-1 (last unit vector) are
  precomputed, A_c = e_{c-1} x[first of c-1 ... last], B_c = e_c x[first of c+1].
  The 2 lanes interface values follow from a small reduced system, inverted once:
  `H` maps the interface values of y to (A, B) and to x[0] (the contact node).
- The spikes decay geometrically away from their block end (by (2 - sqrt 3) per node
  for a mass matrix, faster for M + beta dt^2 K at moderate CFL); rows where every
  lane is below `SPIKE_CUTOFF` of its largest entry are dropped, so the correction
  touches a few rows per block, not all of them.

The numba helpers index with unsigned integers on purpose: numba's wraparound of
negative signed indices hides the access pattern from LLVM's loop vectoriser.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit, uint64

from contact_bench.core.config import FASTMATH
from contact_bench.core.sampling import energy_rows
from contact_bench.core.tridiag import factor_pt, pt_solve

#: vector lanes (blocks); 16 doubles are two AVX-512 registers: latency of the
#: recurrence hidden, reduced system (2 x 16 unknowns) still negligible at n >= 1e3
LANES = 16
#: spike entries below this fraction of their lane's largest are dropped (a change of
#: < 1e-20 relative to the solution, far below round-off)
SPIKE_CUTOFF = 1e-20
#: entries of the reduced-system map below this fraction of their row's largest are dropped
H_CUTOFF = 1e-20
#: bytes; lane arrays start on a cache line, so that a row of LANES doubles (two zmm
#: loads) never straddles two lines (what that saves: docs/performance.md)
ALIGN = 64


def lane_zeros(N: int) -> np.ndarray:
    """N zeros, the first on an ALIGN-byte boundary (np.zeros: pages never written cost
    no memory)."""
    buf = np.zeros(N + ALIGN // 8)
    off = (-buf.ctypes.data % ALIGN) // 8
    return buf[off:off + N]


def _aligned(x: np.ndarray) -> np.ndarray:
    out = lane_zeros(x.size)
    out[:] = x.ravel()
    return out


class SpikeFactors(NamedTuple):
    """What the numba kernels take of a `Spike` (`Spike.factors()`): the sweeps' lo,
    invd, the spikes' kept rows a, b, the reduced-system map H (Hrow, Hpos, Hval), the
    kept rows ja, jb, the rows per block m and the unknowns `nodes`."""

    lo: np.ndarray
    invd: np.ndarray
    a: np.ndarray
    b: np.ndarray
    Hrow: np.ndarray
    Hpos: np.ndarray
    Hval: np.ndarray
    ja: int
    jb: int
    m: int
    nodes: int


@dataclass(frozen=True)
class Spike:
    """Factors of a symmetric tridiagonal S in the lane-interleaved layout."""

    n: int  # unknowns
    lanes: int
    m: int  # rows per block
    lo: np.ndarray  # L[i, i-1] at node i's position (0 in row 0)
    invd: np.ndarray  # 1 / d[i]
    a: np.ndarray  # first `ja` rows of the spike a (ja x lanes, flattened)
    b: np.ndarray  # last `jb` rows of the spike b
    ja: int
    jb: int
    Hrow: np.ndarray  # H: (2 lanes + 1) x (2 lanes), y interface -> (A, B, x[0]), as
    Hpos: np.ndarray  # (row, position in z of the column's interface value, value)
    Hval: np.ndarray  # triplets of its entries, column by column
    w0: float  # (S^-1)[0, 0]: response of x[0] to a unit force on node 0
    hw: np.ndarray  # (2 lanes) (A, B) of the solution of S w = e0

    @property
    def pos(self) -> np.ndarray:
        """Position of each node 0 .. n-1 in the interleaved layout (`lane_position`),
        made when asked: the kernels compute it (an n-sized index array, 8 MB at
        n = 1e6, is not held while they step)."""
        i = np.arange(self.n)
        return (i % self.m) * self.lanes + i // self.m

    def factors(self) -> SpikeFactors:
        """What the numba kernels take (nodes = n)."""
        return SpikeFactors(self.lo, self.invd, self.a, self.b, self.Hrow, self.Hpos,
                            self.Hval, int(self.ja), int(self.jb), int(self.m), int(self.n))

    def to_lanes(self, x: np.ndarray, pad: float = 0.0) -> np.ndarray:
        """A natural-order vector (length n) in the interleaved layout (padding = pad)."""
        out = self.zeros()
        if pad:
            out[:] = pad
        out[self.pos] = x
        return out

    def zeros(self) -> np.ndarray:
        """A zero vector in the interleaved layout (aligned: `lane_zeros`)."""
        return lane_zeros(self.lanes * self.m)

    def lower_to_lanes(self, off: np.ndarray) -> np.ndarray:
        """The lower band S[i, i-1] of a tridiagonal (off = its n-1 off-diagonal entries) at
        node i's position, 0 for node 0 and the padding: the `Slo` of `stencil_forward`."""
        lower = np.zeros(self.n)
        lower[1:] = off
        return self.to_lanes(lower)

    def to_natural(self, y: np.ndarray) -> np.ndarray:
        return y[self.pos]


def spike_factor(d: np.ndarray, e: np.ndarray, min_rows: int = 1) -> Spike:
    """Factor S = tridiag(e, d, e) (symmetric positive definite) for `spike_solve`.

    m = max(min_rows, ceil(n / lanes)) rows per block (the vector Newmark kernels need
    3; the extra rows of a small system are padding).
    """
    d = np.asarray(d, float)
    e = np.asarray(e, float)
    n = d.size
    lanes = LANES
    m = max(int(min_rows), -(-n // lanes))
    N = lanes * m
    dp = np.ones(N)
    dp[:n] = d
    ep = np.zeros(N - 1)
    ep[: n - 1] = e
    ends = np.arange(1, lanes) * m - 1  # last node of blocks 0 .. lanes-2
    ec = ep[ends].copy()  # couplings removed: S[end_c, end_c + 1]
    ep[ends] = 0.0
    df, ef = factor_pt(dp, ep) if N > 1 else (dp.copy(), ep)
    first = np.zeros(N)
    first[np.arange(lanes) * m] = 1.0
    last = np.zeros(N)
    last[np.arange(lanes) * m + m - 1] = 1.0
    a_nat, b_nat = first, last
    pt_solve(df, ef, a_nat)
    pt_solve(df, ef, b_nat)
    # interleave: node c m + j -> row j, lane c (views; only the kept rows are copied)
    def rows(x: np.ndarray) -> np.ndarray:
        return x.reshape(lanes, m).T

    lo = np.empty(N)
    lo[0] = 0.0
    lo[1:] = ef
    lo = np.ascontiguousarray(rows(lo))
    lo[0, :] = 0.0
    np.divide(1.0, df, out=df)
    invd = np.ascontiguousarray(rows(df))
    del df, ef
    a, b = rows(a_nat), rows(b_nat)
    # reduced system for s_c = x[0, c], t_c = x[m-1, c]:
    #   x = y - A_c a - B_c b,  A_c = e_{c-1} t_{c-1},  B_c = e_c s_{c+1}
    P = lanes
    G = np.eye(2 * P)  # unknowns (s_0..s_{P-1}, t_0..t_{P-1})
    for c in range(P):
        if c > 0:
            G[c, P + c - 1] += ec[c - 1] * a[0, c]
            G[P + c, P + c - 1] += ec[c - 1] * a[m - 1, c]
        if c < P - 1:
            G[c, c + 1] += ec[c] * b[0, c]
            G[P + c, c + 1] += ec[c] * b[m - 1, c]
    Ginv = np.linalg.inv(G)  # 2 lanes x 2 lanes: independent of n
    AB = np.zeros((2 * P, 2 * P))  # (s, t) -> (A, B)
    for c in range(P):
        if c > 0:
            AB[c, P + c - 1] = ec[c - 1]
        if c < P - 1:
            AB[P + c, c + 1] = ec[c]
    H = np.vstack((AB @ Ginv, Ginv[:1]))
    # entries below H_CUTOFF of their row's largest cannot change the result beyond
    # round-off; far-apart blocks only see each other through them
    keep = np.abs(H) > H_CUTOFF * np.abs(H).max(axis=1, keepdims=True)
    cols, rows_ = np.nonzero(keep.T)  # column by column
    Hrow = rows_.astype(np.int64)
    Hpos = np.where(cols < P, cols, (m - 1) * P + cols - P).astype(np.int64)
    Hval = H[rows_, cols]
    # the contact response w = S^-1 e0: y_w = a in lane 0 (block 0's first spike)
    yw = np.zeros(2 * P)
    yw[0], yw[P] = a[0, 0], a[m - 1, 0]
    hw_all = H @ yw
    hw = hw_all[: 2 * P].copy()
    w0 = float(hw_all[2 * P])
    # truncate the spikes: a lives at the top of each block, b at the bottom
    big_a = np.nonzero((np.abs(a) > SPIKE_CUTOFF * np.abs(a).max(axis=0)).any(axis=1))[0]
    big_b = np.nonzero((np.abs(b) > SPIKE_CUTOFF * np.abs(b).max(axis=0)).any(axis=1))[0]
    ja = int(big_a[-1]) + 1
    jb = m - int(big_b[0])
    return Spike(n=n, lanes=P, m=m, lo=_aligned(lo), invd=_aligned(invd),
                 a=_aligned(a[:ja]), b=_aligned(b[m - jb:]),
                 ja=ja, jb=jb, Hrow=Hrow, Hpos=Hpos, Hval=np.ascontiguousarray(Hval), w0=w0, hw=hw)


# ------------------------------------------------------------------- numba building blocks
#
# All take the interleaved arrays (N = LANES * m entries). The sweeps are flat loops
# over positions with a dependence distance of LANES, a compile-time constant: LLVM
# vectorises them with one runtime alias check per loop (a loop over the lanes of each
# row instead pays that check, and its set-up, on every row).

L = LANES


@njit(cache=True, inline="always")
def lane_position(i, m):  # pragma: no cover - compiled
    """Position of node i in the interleaved layout of m rows per block."""
    return (i % m) * L + i // m


@njit(cache=True, fastmath=FASTMATH)
def forward_rows(z, lo, start, N):
    """z[p] -= lo[p] * z[p - LANES] for positions start .. N-1 (start >= LANES)."""
    for p in range(start, N):
        pu = uint64(p)
        z[pu] = z[pu] - lo[pu] * z[pu - uint64(L)]


@njit(cache=True, fastmath=FASTMATH)
def backward_rows(z, lo, invd, N):
    """z <- diag(d)^-1 L^-T z in place (all rows)."""
    for p in range(N - L, N):
        pu = uint64(p)
        z[pu] = z[pu] * invd[pu]
    for q in range(N - L):
        pu = uint64(N - L - 1 - q)
        z[pu] = z[pu] * invd[pu] - lo[pu + uint64(L)] * z[pu + uint64(L)]


@njit(cache=True, fastmath=FASTMATH)
def reduced(z, Hrow, Hpos, Hval, coef):
    """coef = H y_interface: (A, B) in coef[:2 LANES] and the free x[0] in coef[2 LANES].

    H is stored as (row, position in z of the interface value, value) triplets, column
    by column: far-apart blocks do not see each other once the spikes have decayed, so
    H is banded in practice (a few multiply-adds per lane, not (2 LANES)^2); and where
    it is dense (few rows per block), consecutive updates go to different rows, so
    they do not wait on each other.
    """
    for r in range(coef.size):
        coef[r] = 0.0
    for k in range(Hval.size):
        coef[Hrow[k]] += Hval[k] * z[Hpos[k]]
    return coef[coef.size - 1]


@njit(cache=True, fastmath=FASTMATH)
def correct(z, a, b, coef, m, ja, jb):
    """z <- z - A_c a - B_c b (the truncated spikes: first ja rows, last jb rows)."""
    P = (coef.size - 1) // 2
    for j in range(ja):
        base = uint64(j * P)
        for c in range(P):
            cu = uint64(c)
            z[base + cu] = z[base + cu] - coef[cu] * a[base + cu]
    j0 = m - jb
    for jj in range(jb):
        base = uint64((j0 + jj) * P)
        bb = uint64(jj * P)
        for c in range(P):
            cu = uint64(c)
            z[base + cu] = z[base + cu] - coef[uint64(P) + cu] * b[bb + cu]


@njit(cache=True, fastmath=FASTMATH)
def block_end_rows(Sd, Slo, X, G, sign, m, z):
    """z = G + sign * S X on rows 0 and m-1, whose neighbours are in other lanes.

    Node c m + j is at position j L + c: node c m - 1 (before row 0 of lane c) is at
    (m-1) L + c - 1, node c m + m (after row m-1 of lane c) at c + 1.
    """
    N = L * m
    for c in range(L):
        for j in (0, m - 1):
            p = j * L + c
            if j > 0:
                prev = p - L
            elif c > 0:
                prev = (m - 1) * L + c - 1
            else:
                prev = -1
            if j < m - 1:
                nxt = p + L
            elif c + 1 < L:
                nxt = c + 1
            else:
                nxt = N
            r = Sd[p] * X[p]
            if prev >= 0:
                r += Slo[p] * X[prev]
            if nxt < N:
                r += Slo[nxt] * X[nxt]
            z[p] = G[p] + sign * r


@njit(cache=True, fastmath=FASTMATH)
def stencil_forward(Sd, Slo, X, G, sign, lo, m, z):
    """z = L^-1 (G + sign * S X), S = (Sd, Slo) tridiagonal (Slo[p] = S[i, i-1] at node i's
    position), L the factor of `spike_factor`: the right-hand side of a step and the
    forward sweep in one pass."""
    N = L * m
    block_end_rows(Sd, Slo, X, G, sign, m, z)
    Lu = uint64(L)
    for p in range(L, N - L):  # rows 1 .. m-2: neighbours in the same lane
        pu = uint64(p)
        r = Sd[pu] * X[pu] + Slo[pu] * X[pu - Lu] + Slo[pu + Lu] * X[pu + Lu]
        z[pu] = G[pu] + sign * r - lo[pu] * z[pu - Lu]
    if m > 1:
        forward_rows(z, lo, N - L, N)


@njit(cache=True, fastmath=FASTMATH)
def stencil_solve(Sd, Slo, X, G, sign, fac, z, coef):
    """z = S^-1 (G + sign * T X), S factored in fac (`Spike.factors()`), T = (Sd, Slo) a
    tridiagonal in the interleaved layout; returns x[0]. The right-hand side, the
    forward sweep, the backward sweep, the reduced system and the spike correction."""
    lo, invd, sa, sb, Hrow, Hpos, Hval, ja, jb, m, nodes = fac
    stencil_forward(Sd, Slo, X, G, sign, lo, m, z)
    backward_rows(z, lo, invd, L * m)
    x0 = reduced(z, Hrow, Hpos, Hval, coef)
    correct(z, sa, sb, coef, m, ja, jb)
    return x0


@njit(cache=True, fastmath=FASTMATH)
def record_lane_sample(k, t, nodes, X, V, stress, en, out):
    """Sample k of the `Samples` out from the interleaved X, V of the nodes 0 .. nodes-1
    (node c m + j at position j L + c, `lane_position`): U, V in node order, u(0, t) =
    X[0], the stress and the energy 1/2 V.M.V + 1/2 U.K.U - F.U + offset, which is
    returned (en: the `EnergyRows`, computed once per run)."""
    rM, Me, rK, Ke, F, offset = en
    t_out, U_out, V_out, cu_out, s_out, E_out = out
    m = X.size // L
    Uk, Vk = U_out[k], V_out[k]
    Lu = uint64(L)
    for c in range(L):  # lane by lane: one sequential write stream per output row
        i0 = c * m
        cnt = min(m, nodes - i0)
        if cnt <= 0:
            break
        cu, base = uint64(c), uint64(i0)
        for j in range(uint64(cnt)):  # unsigned: no wraparound test per element
            Uk[base + j] = X[j * Lu + cu]
            Vk[base + j] = V[j * Lu + cu]
    energy = energy_rows(rM, Me, rK, Ke, F, U_out[k], V_out[k], offset)
    t_out[k] = t
    cu_out[k] = X[0]
    s_out[k] = stress
    E_out[k] = energy
    return energy


@njit(cache=True)
def spike_solve(fac, z, coef):
    """Solve S x = z in place (interleaved layout), S factored in fac (`SpikeFactors`);
    coef is scratch of length 2 LANES + 1."""
    lo, invd, a, b, Hrow, Hpos, Hval, ja, jb, m, nodes = fac
    N = L * m
    forward_rows(z, lo, L, N)
    backward_rows(z, lo, invd, N)
    reduced(z, Hrow, Hpos, Hval, coef)
    correct(z, a, b, coef, m, ja, jb)
