"""The paper's Lipschitz ODE (P_U^mod), compiled: the bar with a massless contact node
eliminated, u0 = max(0, (F0 - K01 u1) / K00) (Dabaghi, Petrov, Pousin, Renard 2014,
section 4).

`ode_rhs` is its right-hand side as a first-order system (for `ode_adaptive`'s DOP853);
`verlet_kernel` (natural order) and `verlet_spike_kernel` (on the SPIKE factors of
`contact_bench.core.spike`) step it by velocity Verlet for `ode_verlet`.
"""

from __future__ import annotations

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
from contact_bench.core.spike import L, lane_position, record_lane_sample
from contact_bench.core.tridiag import eliminate_contact_node, pt_solve, tri_matvec
from contact_bench.kernels.newmark import massless_acceleration


@njit(cache=True)
def ode_rhs(y, Kd, Ke, F, Sd, Se):
    """d/dt (U_bar, V_bar) = (V_bar, M_bar^{-1} (F - K U)[1:]) with u0 = u0(u1)."""
    m = y.size // 2  # = nfree - 1
    U = np.empty(m + 1)
    U[1:] = y[:m]
    u0 = (F[0] - Ke[0] * U[1]) / Kd[0]
    U[0] = u0 if u0 > 0.0 else 0.0
    KU = np.empty(m + 1)
    tri_matvec(Kd, Ke, U, KU)
    dy = np.empty(2 * m)
    dy[:m] = y[m:]
    a = np.empty(m)
    for i in range(m):
        a[i] = F[i + 1] - KU[i + 1]
    pt_solve(Sd, Se, a)
    dy[m:] = a
    return dy


@njit(cache=True)
def ode_acceleration(Kd, Ke, F, Sd, Se, U, A, KU):
    """u0 <- u0(u1); A[1:] = M_bar^{-1} (F - K U)[1:], A[0] = 0; returns lambda."""
    lam = eliminate_contact_node(Kd, Ke, F, U)
    tri_matvec(Kd, Ke, U, KU)
    for i in range(U.size):
        A[i] = F[i] - KU[i]
    pt_solve(Sd, Se, A[1:])
    A[0] = 0.0
    return lam


@njit(cache=True)
def contact_node_velocity(Kd, Ke, U, V):
    V[0] = -(Ke[0] / Kd[0]) * V[1] if U[0] > 0.0 else 0.0


@njit(cache=True)
def verlet_kernel(bar, Sd, Se, U, V, run, out):
    """Velocity Verlet on (P_U^mod); returns (samples, steps, min u0, blow-up step). bar:
    the `Bar`; (Sd, Se): M_bar's factors; run: the `Run`; out: the `Samples`."""
    Md, Me, Kd, Ke, F = bar
    dt, nsteps, stride, offset = run
    n = U.size
    A = np.empty(n)
    KU = np.empty(n)
    lam = ode_acceleration(Kd, Ke, F, Sd, Se, U, A, KU)
    contact_node_velocity(Kd, Ke, U, V)
    min_u0 = U[0]
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    E0 = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
    record_sample(0, 0.0, U, V, -lam, E0, out)
    k = 1
    for step in range(1, nsteps + 1):
        for i in range(1, n):
            V[i] += 0.5 * dt * A[i]
            U[i] += dt * V[i]
        lam = ode_acceleration(Kd, Ke, F, Sd, Se, U, A, KU)
        for i in range(1, n):
            V[i] += 0.5 * dt * A[i]
        contact_node_velocity(Kd, Ke, U, V)
        if U[0] < min_u0:
            min_u0 = U[0]
        if is_sample(step, nsteps, stride):
            energy = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
            record_sample(k, step * dt, U, V, -lam, energy, out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1


@njit(cache=True, fastmath=FASTMATH)
def verlet_spike_kernel(bar, lanes, state, z, coef, run, out):
    """`verlet_kernel` in the lane-interleaved layout of `contact_bench.core.spike` (U, V, A, z:
    interleaved, A and z scratch; state the `BarState`, lanes the `LaneStiffness` of M_r).
    Same update, samples, stress, min u0 and blow-up step.

    Between samples V holds the half-step velocity: the closing half kick of a step, the
    next step's half kick and drift are one pass (the same operations, in the same
    order, as the reference kernel's two loops).
    """
    Md, Me, Kd, Ke, F = bar
    U, V, A = state
    dt, nsteps, stride, offset = run
    fac = lanes.fac
    m, nodes = fac.m, fac.nodes
    N = L * m
    h = 0.5 * dt
    p1 = lane_position(1, m)  # node 1's position
    r = -(Ke[0] / Kd[0])  # v0 = r v1 while the node is off the obstacle
    lam = massless_acceleration(Kd, Ke, F, lanes, p1, U, A, coef)
    V[0] = r * V[p1] if U[0] > 0.0 else 0.0
    min_u0 = U[0]
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    en = EnergyRows(rM, Me, rK, Ke, F, offset)
    E0 = record_lane_sample(0, 0.0, nodes, U, V, -lam, en, out)
    k = 1
    kicked = False  # V, U already hold this step's half kick and drift
    for step in range(1, nsteps + 1):
        if not kicked:
            for p in range(N):
                pu = uint64(p)
                v = V[pu] + h * A[pu]
                V[pu] = v
                U[pu] = U[pu] + dt * v
        # U[0] was drifted with V[0] above; it is replaced by u0(u1) here
        lam = massless_acceleration(Kd, Ke, F, lanes, p1, U, z, coef)
        A, z = z, A  # A^{n+1}; the old A is the next solve's scratch
        u0 = U[0]
        if u0 < min_u0:
            min_u0 = u0
        sample = step % stride == 0 or step == nsteps
        if sample:
            for p in range(N):
                pu = uint64(p)
                V[pu] = V[pu] + h * A[pu]
        else:  # closing half kick, next half kick and drift
            for p in range(N):
                pu = uint64(p)
                v = V[pu] + h * A[pu]
                v = v + h * A[pu]
                V[pu] = v
                U[pu] = U[pu] + dt * v
        kicked = not sample
        if sample:
            V[0] = r * V[p1] if u0 > 0.0 else 0.0
            energy = record_lane_sample(k, step * dt, nodes, U, V, -lam, en, out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1
