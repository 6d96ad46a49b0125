"""Sampling, discrete energy and the blow-up rule, shared by every stepping kernel.

A kernel keeps a sample every `stride` steps and at the last step (`is_sample`), writes
it with `record_sample`, and stops at the first step whose energy is not finite or
exceeds `BLOWUP_FACTOR` times |E(0)| (`blown_up`; `blown_up_rows` is the same rule over
an array of sampled energies, for the code that checks a finished trajectory).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, uint64

from contact_bench.core.simd import vhsum, vload, vsplat
from contact_bench.core.tridiag import QUAD_BLOCK, snap_row_sum

BLOWUP_FACTOR = 1e3  # energy above this multiple of E(0) counts as a blow-up


class Samples(NamedTuple):
    """A bar's run's sample buffers, entry (row) k = sample k: times, nodal U and V,
    u(0, t), contact stress, energy; written by `record_sample` (and
    `contact_bench.core.spike.record_lane_sample`)."""

    t: np.ndarray
    U: np.ndarray
    V: np.ndarray
    cu: np.ndarray
    stress: np.ndarray
    energy: np.ndarray


class Run(NamedTuple):
    """How a bar's kernel steps and samples: step size dt, steps, a sample every
    `stride` steps (and the last), and the energy's constant `offset`."""

    dt: float
    nsteps: int
    stride: int
    offset: float


class EnergyRows(NamedTuple):
    """The energy's coefficients as `energy_rows` takes them: the `row_sums` rM, rK of M
    and K, their off-diagonals Me, Ke, the load F and the constant offset."""

    rM: np.ndarray
    Me: np.ndarray
    rK: np.ndarray
    Ke: np.ndarray
    F: np.ndarray
    offset: float


@njit(cache=True)
def row_sums(d, e):
    """The row sums r_i = d_i + e_{i-1} + e_i of the symmetric tridiagonal (d, e), each
    taken as 0 at the rounding level of its row (|r_i| <= ROWSUM_RTOL (|d_i| + |e_{i-1}| +
    |e_i|)), as `contact_bench.core.tridiag.tri_quad` takes them: the coefficients of x_i^2
    in `energy_rows`. They depend on the matrix only, so a kernel computes them once per
    run, before its step loop."""
    n = d.size
    r = np.empty(n)
    if n == 1:
        r[0] = snap_row_sum(d[0], abs(d[0]))
    if n < 2:
        return r
    r[0] = snap_row_sum(d[0] + e[0], abs(d[0]) + abs(e[0]))
    for i in range(1, n - 1):
        r[i] = snap_row_sum((d[i] + e[i - 1]) + e[i], (abs(d[i]) + abs(e[i - 1])) + abs(e[i]))
    r[n - 1] = snap_row_sum(d[n - 1] + e[n - 2], abs(d[n - 1]) + abs(e[n - 2]))
    return r


@njit(cache=True)
def energy_rows(rM, Me, rK, Ke, F, U, V, offset):
    """1/2 V.M.V + 1/2 U.K.U - F.U + offset from the row sums rM, rK (`row_sums` of M and
    K) and the off-diagonals Me, Ke, without cancellation.

    Each quadratic form as `contact_bench.core.tridiag.tri_quad` writes it, sum_i r_i x_i^2
    - sum_i e_i (x_{i+1} - x_i)^2: the strain energy from element differences, whose
    digits do not fade as the mesh grows (docs/energy-summation.md). Both forms and F.U
    are fused into one term per node, twice node i's share (r^M_i v_i^2 - e^M_i (v_{i+1}
    - v_i)^2) + (r^K_i u_i^2 - e^K_i (u_{i+1} - u_i)^2) - 2 F_i u_i, summed in one pass:
    rows 1 .. n-2 eight at a time in explicit 8 x double vectors (`contact_bench.core.simd`,
    no branch in the loop), one vector sum per block of QUAD_BLOCK rows added into the
    total by `vhsum`, the remaining rows one by one, rows 0 and n-1 first. The order is
    fixed by the code (no reassociation by the compiler): the same bits on every machine.
    """
    n = U.size
    if n == 0:
        return offset
    if n == 1:
        return 0.5 * (rM[0] * V[0] * V[0] + rK[0] * U[0] * U[0]) - F[0] * U[0] + offset
    v, u = V[0], U[0]
    dv, du = V[1] - v, U[1] - u
    total = ((rM[0] * v * v - Me[0] * dv * dv) + (rK[0] * u * u - Ke[0] * du * du)
             - 2.0 * F[0] * u)
    last = uint64(n - 1)
    v, u = V[last], U[last]
    total += (rM[last] * v * v + rK[last] * u * u) - 2.0 * F[last] * u
    two = vsplat(2.0)
    i = uint64(1)
    while i + uint64(8) <= last:
        end = min(i + uint64(QUAD_BLOCK), last)
        acc = vsplat(0.0)
        while i + uint64(8) <= end:
            vv, uu = vload(V, i), vload(U, i)
            dv8, du8 = vload(V, i + uint64(1)) - vv, vload(U, i + uint64(1)) - uu
            acc = acc + (((vload(rM, i) * vv * vv - vload(Me, i) * dv8 * dv8)
                          + (vload(rK, i) * uu * uu - vload(Ke, i) * du8 * du8))
                         - two * vload(F, i) * uu)
            i += uint64(8)
        total += vhsum(acc)
    while i < last:
        v, u = V[i], U[i]
        dv, du = V[i + uint64(1)] - v, U[i + uint64(1)] - u
        total += (((rM[i] * v * v - Me[i] * dv * dv) + (rK[i] * u * u - Ke[i] * du * du))
                  - 2.0 * F[i] * u)
        i += uint64(1)
    return 0.5 * total + offset


@njit(cache=True)
def energy_of(Md, Me, Kd, Ke, F, U, V, offset):
    """1/2 V.M.V + 1/2 U.K.U - F.U + offset for M = (Md, Me), K = (Kd, Ke): `energy_rows`
    of their `row_sums` (the same bits). For one energy; a step loop computes the row
    sums once and calls `energy_rows`."""
    return energy_rows(row_sums(Md, Me), Me, row_sums(Kd, Ke), Ke, F, U, V, offset)


@njit(cache=True, inline="always")
def record_sample(k, t, U, V, stress, energy, out):
    """Write sample k of the `Samples` out: time, nodal U and V, u(0, t), contact stress,
    energy.

    U and V are copied by an explicit loop over the row's nodes: numba's slice assignment
    (`U_out[k, :] = U`) goes through its generic broadcasting copy, several times slower
    on the short rows of small grids. Inlined into its callers: a call passing six arrays
    costs as much as copying a small grid's row."""
    t_out, U_out, V_out, cu_out, s_out, E_out = out
    t_out[k] = t
    for i in range(U.size):
        U_out[k, i] = U[i]
        V_out[k, i] = V[i]
    cu_out[k] = U[0]
    s_out[k] = stress
    E_out[k] = energy


@njit(cache=True)
def is_sample(step, nsteps, stride):
    return step % stride == 0 or step == nsteps


@njit(cache=True)
def blown_up(energy, energy0):
    if not np.isfinite(energy):
        return True
    return abs(energy) > BLOWUP_FACTOR * max(abs(energy0), 1e-300)


def blown_up_rows(energy: np.ndarray, energy0: float) -> np.ndarray:
    """`blown_up` of every entry of `energy`: True where it is not finite or exceeds
    `BLOWUP_FACTOR` |energy0|."""
    energy = np.asarray(energy, dtype=float)
    finite = np.isfinite(energy)
    big = np.abs(np.where(finite, energy, 0.0)) > BLOWUP_FACTOR * max(abs(energy0), 1e-300)
    return ~finite | big


def n_samples(nsteps: int, stride: int) -> int:
    return nsteps // stride + 1 + (1 if nsteps % stride else 0)
