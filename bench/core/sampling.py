"""Sampling, discrete energy and the blow-up rule, shared by every stepping kernel.

A kernel keeps a sample every `stride` steps and at the last step (`is_sample`), writes
it with `record_sample`, and stops at the first step whose energy is not finite or
exceeds `BLOWUP_FACTOR` times |E(0)| (`blown_up`).
"""

from __future__ import annotations

import numpy as np
from numba import njit, uint64

from contact_bench.core.simd import vabs, vhsum, vload, vselect_le, vsplat
from contact_bench.core.tridiag import QUAD_BLOCK, ROWSUM_RTOL, _snap

BLOWUP_FACTOR = 1e3  # energy above this multiple of E(0) counts as a blow-up


@njit(cache=True, inline="always")
def _row_sum(d, e, i):  # pragma: no cover - compiled
    """Row i's sum d_i + e_{i-1} + e_i of the tridiagonal (d, e), 0 < i < n - 1, or 0 at
    the rounding level of the row (as `contact_bench.core.tridiag.tri_quad` takes it)."""
    r = (d[i] + e[i - uint64(1)]) + e[i]
    a = (abs(d[i]) + abs(e[i - uint64(1)])) + abs(e[i])
    return r if abs(r) > ROWSUM_RTOL * a else 0.0


@njit(cache=True, inline="always")
def _vrow_sum(d, e, i):  # pragma: no cover - compiled
    """`_row_sum` of the rows i .. i + 7, lane by lane."""
    dd, el, er = vload(d, i), vload(e, i - uint64(1)), vload(e, i)
    r = (dd + el) + er
    a = (vabs(dd) + vabs(el)) + vabs(er)
    return vselect_le(vabs(r), vsplat(ROWSUM_RTOL) * a, vsplat(0.0), r)


@njit(cache=True, inline="always")
def _node_term(Md, Me, Kd, Ke, F, U, V, i):  # pragma: no cover - compiled
    """Twice node i's share of the energy, 0 < i < n - 1: (r^M_i v_i^2 - e^M_i (v_{i+1} -
    v_i)^2) + (r^K_i u_i^2 - e^K_i (u_{i+1} - u_i)^2) - 2 F_i u_i."""
    v, u = V[i], U[i]
    dv, du = V[i + uint64(1)] - v, U[i + uint64(1)] - u
    return (((_row_sum(Md, Me, i) * v * v - Me[i] * dv * dv)
             + (_row_sum(Kd, Ke, i) * u * u - Ke[i] * du * du)) - 2.0 * F[i] * u)


@njit(cache=True)
def energy_of(Md, Me, Kd, Ke, F, U, V, offset):
    """1/2 V.M.V + 1/2 U.K.U - F.U + offset, without cancellation.

    Each quadratic form as `contact_bench.core.tridiag.tri_quad` writes it, sum_i r_i x_i^2
    - sum_i e_i (x_{i+1} - x_i)^2 with the row sums r_i (rounding-level ones taken as 0):
    the strain energy from element differences, whose digits do not fade as the mesh
    grows (docs/energy-summation.md). The two forms and F.U are fused into one term per
    node (`_node_term`) and summed in one pass: rows 1 .. n-2 eight at a time in explicit
    8 x double vectors (`contact_bench.core.simd`), one vector sum per block of
    QUAD_BLOCK rows added into the total by `vhsum`, the rest one by one. The order is
    fixed by the code (no reassociation by the compiler): the same bits on every machine.
    """
    n = U.size
    if n == 0:
        return offset
    if n == 1:
        return (0.5 * (_snap(Md[0], abs(Md[0])) * V[0] * V[0]
                       + _snap(Kd[0], abs(Kd[0])) * U[0] * U[0]) - F[0] * U[0] + offset)
    v, u = V[0], U[0]
    dv, du = V[1] - v, U[1] - u
    total = (((_snap(Md[0] + Me[0], abs(Md[0]) + abs(Me[0])) * v * v - Me[0] * dv * dv)
              + (_snap(Kd[0] + Ke[0], abs(Kd[0]) + abs(Ke[0])) * u * u - Ke[0] * du * du))
             - 2.0 * F[0] * u)
    last = uint64(n - 1)
    v, u = V[last], U[last]
    total += (((_snap(Md[last] + Me[last - uint64(1)],
                      abs(Md[last]) + abs(Me[last - uint64(1)])) * v * v)
               + (_snap(Kd[last] + Ke[last - uint64(1)],
                        abs(Kd[last]) + abs(Ke[last - uint64(1)])) * u * u))
              - 2.0 * F[last] * u)
    two = vsplat(2.0)
    i = uint64(1)
    while i + uint64(8) <= last:
        end = min(i + uint64(QUAD_BLOCK), last)
        acc = vsplat(0.0)
        while i + uint64(8) <= end:
            vv, uu = vload(V, i), vload(U, i)
            dv8, du8 = vload(V, i + uint64(1)) - vv, vload(U, i + uint64(1)) - uu
            acc = acc + (((_vrow_sum(Md, Me, i) * vv * vv - vload(Me, i) * dv8 * dv8)
                          + (_vrow_sum(Kd, Ke, i) * uu * uu - vload(Ke, i) * du8 * du8))
                         - two * vload(F, i) * uu)
            i += uint64(8)
        total += vhsum(acc)
    while i < last:
        total += _node_term(Md, Me, Kd, Ke, F, U, V, i)
        i += uint64(1)
    return 0.5 * total + offset


@njit(cache=True)
def record_sample(k, t, U, V, stress, energy, t_out, U_out, V_out, cu_out, s_out, E_out):
    """Write sample k: time, nodal U and V, u(0, t), contact stress, energy."""
    t_out[k] = t
    U_out[k, :] = U
    V_out[k, :] = V
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


def n_samples(nsteps: int, stride: int) -> int:
    return nsteps // stride + 1 + (1 if nsteps % stride else 0)
