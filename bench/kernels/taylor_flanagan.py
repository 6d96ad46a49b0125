"""The compiled steps of `taylor_flanagan` (explicit central difference, a contact force
that stops the contact node) on a tridiagonal M: `taylor_flanagan_kernel` in natural
order, the reference, and `tf_spike_kernel` on the SPIKE factors of
`contact_bench.core.spike`. The scheme and its equations are in
`contact_bench.schemes.taylor_flanagan`; the lumped-mass path is
`contact_bench.kernels.lumped.tf_lumped_kernel`."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, uint64

from contact_bench.core.config import FASTMATH
from contact_bench.core.sampling import (
    EnergyRows,
    blown_up,
    energy_rows,
    is_sample,
    record_sample,
    row_sums,
)
from contact_bench.core.spike import L, record_lane_sample, stencil_solve
from contact_bench.core.tridiag import pt_solve, tri_matvec


@njit(cache=True)
def taylor_flanagan_kernel(bar, S, state, run, out):
    """Advance the `BarState` (U, V, A) in place; returns (samples, steps, min u0, blow-up
    step). bar: the `Bar`; S: the `Implicit` factors of M and w = M^-1 e0; run: the `Run`;
    out: the `Samples`."""
    Md, Me, Kd, Ke, F = bar
    Sd, Se, w = S
    U, V, A = state
    dt, nsteps, stride, offset = run
    n = U.size
    KU = np.empty(n)
    min_u0 = U[0]
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    E0 = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
    record_sample(0, 0.0, U, V, 0.0, E0, out)
    k = 1
    for step in range(1, nsteps + 1):
        for i in range(n):
            U[i] += dt * V[i] + 0.5 * dt * dt * A[i]
            V[i] += 0.5 * dt * A[i]
        lam = 0.0
        if U[0] < 0.0:
            lam = -V[0] / (dt * w[0])
            if lam < 0.0:
                lam = 0.0
            for i in range(n):
                U[i] += dt * dt * lam * w[i]
                V[i] += dt * lam * w[i]
        tri_matvec(Kd, Ke, U, KU)
        for i in range(n):
            A[i] = F[i] - KU[i]
        pt_solve(Sd, Se, A)
        for i in range(n):
            V[i] += 0.5 * dt * A[i]
        if U[0] < min_u0:
            min_u0 = U[0]
        if is_sample(step, nsteps, stride):
            energy = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
            record_sample(k, step * dt, U, V, -lam, energy, out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1


class SparseResponse(NamedTuple):
    """w = M^-1 e0 kept sparse: the positions wpos and values wval of its entries above
    `SPIKE_CUTOFF` x w0 (interleaved layout), and w0 = w[0]."""

    wpos: np.ndarray
    wval: np.ndarray
    w0: float


@njit(cache=True, fastmath=FASTMATH)
def tf_spike_kernel(bar, lanes, spike_w, state, z, coef, run, out):
    """`taylor_flanagan_kernel` in the lane-interleaved layout of `contact_bench.core.spike` (U, V,
    A, z interleaved: the `BarState` state and scratch z; lanes: the `LaneStiffness` with
    fac = `Spike.factors()` of M). Same update, samples, stress, min u0 and blow-up step.

    w = M^-1 e0 enters as its entries above `SPIKE_CUTOFF` x w0 (spike_w, the
    `SparseResponse`: positions wpos, values wval and w0; w decays by 2 - sqrt 3 per node,
    a few dozen entries). Between samples the closing half kick of a step and the next
    step's drift and half kick are one pass (the same operations, in the same order, as
    the reference kernel's loops).
    """
    Md, Me, Kd, Ke, F = bar
    U, V, A = state
    wpos, wval, w0 = spike_w
    dt, nsteps, stride, offset = run
    Kdl, Klo, Fl, fac = lanes
    m, nodes = fac.m, fac.nodes
    N = L * m
    h = 0.5 * dt
    h2 = 0.5 * dt * dt
    dt2 = dt * dt
    min_u0 = U[0]
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    en = EnergyRows(rM, Me, rK, Ke, F, offset)
    E0 = record_lane_sample(0, 0.0, nodes, U, V, 0.0, en, out)
    k = 1
    drifted = False  # U, V already hold this step's drift and half kick
    for step in range(1, nsteps + 1):
        if not drifted:
            for p in range(N):
                pu = uint64(p)
                U[pu] = U[pu] + (dt * V[pu] + h2 * A[pu])
                V[pu] = V[pu] + h * A[pu]
        lam = 0.0
        if U[0] < 0.0:
            lam = -V[0] / (dt * w0)
            if lam < 0.0:
                lam = 0.0
            cu = dt2 * lam
            cv = dt * lam
            for q in range(wpos.size):
                p = wpos[q]
                U[p] += cu * wval[q]
                V[p] += cv * wval[q]
        # A^{n+1} = M^-1 (F - K U^{n+1})
        stencil_solve(Kdl, Klo, U, Fl, -1.0, fac, z, coef)
        A, z = z, A  # the old A is the next solve's scratch
        u0 = U[0]
        if u0 < min_u0:
            min_u0 = u0
        sample = step % stride == 0 or step == nsteps
        if sample:
            for p in range(N):
                pu = uint64(p)
                V[pu] = V[pu] + h * A[pu]
        else:  # closing half kick, next drift and half kick
            for p in range(N):
                pu = uint64(p)
                a = A[pu]
                v = V[pu] + h * a
                U[pu] = U[pu] + (dt * v + h2 * a)
                V[pu] = v + h * a
        drifted = not sample
        if sample:
            energy = record_lane_sample(k, step * dt, nodes, U, V, -lam, en, out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1
