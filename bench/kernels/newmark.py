"""Newmark(beta, gamma) with the contact enforced exactly at t_{n+1}.

Shared by `standard` (consistent mass) and `redistributed` (massless contact node).

Implicit (beta > 0), displacement form: S U^{n+1} = M U~ + beta dt^2 (F + lambda e0)
with S = M + beta dt^2 K factored once (`contact_bench.core.spike`, on LAPACK dpttrf) and the
predictor U~ = U^n + dt V^n + (1/2 - beta) dt^2 A^n. The response to a unit contact
force, w = S^{-1} e0, is known from the factors: when the contact-free solution U_f
penetrates, U^{n+1} = U_f + mu w with mu = -U_f[0] / w[0], folded into the solve's
spike correction, so an active contact costs no second solve. The obstacle's force is
lambda = mu / (beta dt^2) >= 0 and the contact stress is -lambda (E u_x(0) <= 0 in
compression).

Explicit (beta = 0), only with a massless contact node (the seed's P_U^mod): the
other nodes are advanced by central differences, then
u0 = max(0, (F0 - K01 u1) / K00) and lambda = K00 u0 + K01 u1 - F0.

A massless node has no inertia, so its Newmark acceleration is meaningless: its
velocity is taken as the backward difference (u0^{n+1} - u0^n) / dt.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from contact_bench.api.params import Param
from contact_bench.api.plugin import Semidiscrete, Trajectory
from contact_bench.core.errors import BenchError
from contact_bench.core.sampling import energy_of
from contact_bench.core.spike import L, Spike, lane_zeros, spike_factor, stencil_solve
from contact_bench.core.tridiag import eliminate_contact_node
from contact_bench.kernels.common import allocate, initial_acceleration, trajectory
from contact_bench.kernels.newmark_vec import explicit_kernel, implicit_kernel

BETA = Param(0.25, "Newmark beta (0: explicit central difference)", low=0.0, high=0.5)
GAMMA = Param(0.5, "Newmark gamma", low=0.5, high=1.0)


def newmark_limit(beta: float, gamma: float, h: float, c: float, lumped: bool) -> float | None:
    """Largest stable dt of undamped Newmark on P1 elements (None: unconditionally stable).

    Stable iff omega_max dt <= 1 / sqrt(gamma/2 - beta) when 2 beta < gamma, with
    omega_max = 2 c / h (lumped mass) or 2 sqrt(3) c / h (consistent or redistributed):
    the central difference limits h / c and h / (c sqrt 3).
    """
    if 2.0 * beta >= gamma:
        return None
    omega_max = (2.0 if lumped else 2.0 * np.sqrt(3.0)) * c / h
    return float(1.0 / (np.sqrt(gamma / 2.0 - beta) * omega_max))


# ---------------------------------------------------------------------------- kernels
#
# The stepping kernels are generated (`contact_bench.kernels.newmark_codegen` writes
# `contact_bench.kernels.newmark_vec`): they work in the lane-interleaved layout of
# `contact_bench.core.spike`
# (node i = c m + j at position j L + c, L = LANES = 16), solving the system by 16
# blocks at once, one row of all blocks per pair of `<8 x double>` vector operations
# (`contact_bench.core.simd`), with the sweep recurrences carried in registers. The state is
# (X, Q): X the next solve's predictor, Q = dt V + dt^2 (1 - gamma) A; V is formed on
# sample steps only. Each step is two passes over the state: the backward sweep, then
# one pass that finishes row j + 1 (spike correction, Newmark update) and starts row j
# of the next step (right-hand side, forward sweep). `contract` lets LLVM fuse a*b+c
# into one FMA (deterministic: results are bit-identical from run to run).
_FM = {"contract"}
#: rows per lane block the vector kernels need (smaller systems are padded)
MIN_ROWS = 3


@njit(cache=True, fastmath=_FM)
def massless_acceleration(Kd, Ke, F, Kdl, Klo, Fl, fac, p1, U, z, coef):
    """The seed's (P_U^mod) in the interleaved layout: U[0] <- u0(u1) (node 1 at position
    p1), z <- A = M_r^-1 (F - K U) on nodes 1.. and A[0] = 0; returns lambda.

    fac = `Spike.factors()` of M_r with node 0 decoupled (an identity row, lo = 0 at
    node 1), so the right-hand side of node 0 only reaches z[0], which is set to 0.
    """
    lam = eliminate_contact_node(Kd, Ke, F, U, p1)
    stencil_solve(Kdl, Klo, U, Fl, -1.0, fac, z, coef)
    z[0] = 0.0
    return lam


def _load_to_lanes(sp: Spike, F: np.ndarray, scale: float) -> np.ndarray:
    """scale * F in the interleaved layout; a zero load is np.zeros, whose pages the
    kernel only reads, so it costs no resident memory at large n."""
    return sp.to_lanes(scale * F) if np.any(F) else sp.zeros()


def h_diagonals(sp: Spike) -> tuple[np.ndarray, ...]:
    """The reduced-system map H of `sp` as vector diagonals, for the vector kernels.

    Rows 0..L-1 of H give A, rows L..2L-1 give B; its columns are the interface values
    s (row 0 of every lane) and t (row m-1), which the kernels keep at ibuf[L:2L] and
    ibuf[2L:3L] between zeros. The entries coupling lane c of (A or B) to lane c + d of
    (s or t) form one diagonal: Dg[k] (L values), read against ibuf[Dsrc[k]:Dsrc[k]+L]
    into A (Ddst[k] = 0) or B (1). Row 2L (the free x[0]) stays as (X0pos, X0val) pairs.
    """
    m = sp.m
    cols = np.where(sp.Hpos < L, sp.Hpos, sp.Hpos - (m - 1) * L + L)  # 0..2L-1: (s, t)
    diags: dict[tuple[int, int, int], np.ndarray] = {}
    x0pos, x0val = [], []
    for r, c, v in zip(sp.Hrow, cols, sp.Hval, strict=True):
        if r == 2 * L:
            x0pos.append(L + c)
            x0val.append(v)
            continue
        dst, lane = divmod(int(r), L)
        src, col_lane = divmod(int(c), L)
        key = (dst, src, col_lane - lane)
        diags.setdefault(key, np.zeros(L))[lane] = v
    keys = sorted(diags)
    Dg = lane_zeros(L * len(keys))
    if keys:
        Dg[:] = np.concatenate([diags[k] for k in keys])
    Dsrc = np.array([L + L * src + d for (_, src, d) in keys], np.int64)
    Ddst = np.array([dst for (dst, _, _) in keys], np.int64)
    return Dg, Dsrc, Ddst, np.array(x0pos, np.int64), np.array(x0val, float)


def run_newmark(semi: Semidiscrete, dt: float, nsteps: int, stride: int,
                beta: float, gamma: float) -> Trajectory:
    """Factor outside the loop (interleaved SPIKE factors), then call the vector kernel.

    The kernel's state lives only in the interleaved layout; nothing in node order is
    kept alive while it steps beyond the problem itself and the sample buffers.
    """
    M, K, F = semi.M, semi.K, semi.F
    n = semi.nfree
    dt, beta, gamma = float(dt), float(beta), float(gamma)
    U, V = semi.U0, semi.V0
    if beta == 0.0:
        if not semi.massless:
            raise ValueError("explicit Newmark (beta = 0) here needs a massless contact node")
        if n < 2:
            raise ValueError("explicit Newmark needs at least one node besides the contact node")
    out = allocate(semi, nsteps, stride)
    out["U"][0], out["V"][0], out["cu"][0] = U, V, U[0]
    out["E"][0] = energy_of(M.diag, M.off, K.diag, K.off, F, U, V, semi.energy_offset)
    bufs = (out["t"], out["U"], out["V"], out["cu"], out["s"], out["E"])
    A = initial_acceleration(semi)
    dt2 = dt * dt
    if beta > 0.0:
        bdt2 = beta * dt2
        if not (bdt2 > 0.0 and math.isfinite(1.0 / bdt2)):
            raise BenchError(f"Newmark beta = {beta!r} with dt = {dt!r}: 1 / (beta dt^2) "
                             "overflows; allowed: a larger beta or dt")
        sp = spike_factor(M.diag + bdt2 * K.diag, M.off + bdt2 * K.off, MIN_ROWS)
        # S X + G = M U~ + beta dt^2 F; X = U~ = U + dt V + (1/2 - beta) dt^2 A
        Sd, Slo, G = sp.to_lanes(M.diag), sp.lower_to_lanes(M.off), _load_to_lanes(sp, F, bdt2)
        X = sp.to_lanes(U + dt * V + (0.5 - beta) * dt2 * A)
        k1, k2, kv = (gamma + 0.5 - beta) / beta, 1.0 / beta, gamma / (beta * dt)
        kernel = implicit_kernel
    else:
        d, e = M.diag.copy(), M.off.copy()
        d[0], e[0] = 1.0, 0.0  # node 0 decoupled: M_r on nodes 1.. plus an identity row
        sp = spike_factor(d, e, MIN_ROWS)
        del d, e
        # S X + G = dt^2 (F - K X); X = U + dt V + dt^2 / 2 A (node 0 set by the kernel)
        Sd, Slo = sp.to_lanes(-dt2 * K.diag), sp.lower_to_lanes(-dt2 * K.off)
        G = _load_to_lanes(sp, F, dt2)
        X = sp.to_lanes(U + dt * V + 0.5 * dt2 * A)
        k1, k2, kv = gamma + 0.5, 1.0, gamma / dt
        kernel = explicit_kernel
    Q = sp.to_lanes(dt * V + dt2 * (1.0 - gamma) * A)
    del A
    SloN = lane_zeros(L)  # S[i, i-1] of row 0's next lane, for row m-1
    SloN[: L - 1] = Slo[1:L]
    Dg, Dsrc, Ddst, X0pos, X0val = h_diagonals(sp)
    hw = lane_zeros(2 * L)
    hw[:] = sp.hw
    k, done, min_u0, blow = kernel(
        M.diag, M.off, K.diag, K.off, F, Sd, Slo, SloN, G, bool(np.any(F)), sp.factors(),
        Dg, Dsrc, Ddst, X0pos, X0val, hw, sp.w0, X, Q, sp.zeros(), sp.zeros(),
        np.zeros(2 * L), lane_zeros(4 * L), float(U[0]), k1, k2, kv,
        1.0 / (beta * dt2) if beta > 0.0 else 0.0, dt, bool(semi.massless), int(nsteps),
        int(stride), semi.energy_offset, *bufs)
    return trajectory(out, k, done, min_u0, blow, dt)
