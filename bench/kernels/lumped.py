"""Fused stepping kernels of the explicit central difference with a diagonal (lumped) mass.

With a diagonal mass M (and no stiffness in the system matrix), one step of the
central difference needs no solve: it is one pass of the 3-point stencil of K. The
kernels here do that pass as one branch-free loop over the nodes that LLVM
vectorises (AVX2 / AVX-512): the stencil rolls through loop-carried scalars (each
U[i + 1] is loaded once), the new level is written to a separate buffer and the
buffers are rotated by swapping references, and the contact at node 0, the samples,
the energy and the blow-up check are handled outside the loop. They are the fast
paths of `restitution` (lumped, beta = 0) and `taylor_flanagan` (lumped); the generic
kernels of `contact_bench.kernels.paoli_schatzman` and `.taylor_flanagan`, which take
any tridiagonal M, are the reference they are tested against
(tests/test_lumped_fastpath.py: agreement to round-off). They compile with
`contact_bench.core.config.FASTMATH` (FMA contraction only).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from contact_bench.core.config import FASTMATH
from contact_bench.core.sampling import blown_up, energy_rows, is_sample, record_sample, row_sums
from contact_bench.core.tridiag import tri_matvec


@njit(cache=True, fastmath=FASTMATH)
def cd_stencil(c, F, Kd, Ke, Um, U, Up):
    """Up = 2 U - Um + c (F - K U), K = (Kd, Ke), c = dt^2 / diag(M); Up must not alias U, Um."""
    n = U.size
    u_prev = 0.0
    k_prev = 0.0
    u_cur = U[0]
    for i in range(n - 1):
        u_next = U[i + 1]
        k = Ke[i]
        Up[i] = 2.0 * u_cur - Um[i] + c[i] * (F[i] - Kd[i] * u_cur - k_prev * u_prev
                                              - k * u_next)
        u_prev = u_cur
        u_cur = u_next
        k_prev = k
    i = n - 1
    Up[i] = 2.0 * u_cur - Um[i] + c[i] * (F[i] - Kd[i] * u_cur - k_prev * u_prev)


@njit(cache=True, fastmath=FASTMATH)
def kick_drift(c, F, Kd, Ke, U, Vh, Un, dt):
    """Vh += c (F - K U), Un = U + dt Vh; c = dt / diag(M); Un must not alias U, Vh."""
    n = U.size
    u_prev = 0.0
    k_prev = 0.0
    u_cur = U[0]
    for i in range(n - 1):
        u_next = U[i + 1]
        k = Ke[i]
        v = Vh[i] + c[i] * (F[i] - Kd[i] * u_cur - k_prev * u_prev - k * u_next)
        Vh[i] = v
        Un[i] = u_cur + dt * v
        u_prev = u_cur
        u_cur = u_next
        k_prev = k
    i = n - 1
    v = Vh[i] + c[i] * (F[i] - Kd[i] * u_cur - k_prev * u_prev)
    Vh[i] = v
    Un[i] = u_cur + dt * v


@njit(cache=True, fastmath=FASTMATH)
def ps_lumped_kernel(bar, w0, Um, U, V0, e, run, out):
    """`paoli_schatzman.ps_kernel` for S = M diagonal (beta = 0): w = S^{-1} e0 = w0 e0.

    Same samples, stress, min u0 and blow-up step as the generic kernel; Um and U are
    used as buffers. bar: the `Bar`; run: the `Run`; out: the `Samples`.
    """
    Md, Me, Kd, Ke, F = bar
    dt, nsteps, stride, offset = run
    n = U.size
    dt2 = dt * dt
    c = np.empty(n)
    for i in range(n):
        c[i] = dt2 / Md[i]
    Up = np.empty(n)
    tmp = np.empty(n)
    min_u0 = U[0]
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    E0 = energy_rows(rM, Me, rK, Ke, F, U, V0, offset)
    record_sample(0, 0.0, U, V0, out.stress[0], E0, out)
    k = 1
    for step in range(1, nsteps + 2):
        cd_stencil(c, F, Kd, Ke, Um, U, Up)
        r = 0.0
        gap = Up[0] + e * Um[0]
        if gap < 0.0:
            r = -gap / (dt2 * w0)
            Up[0] = -e * Um[0]  # w is zero off node 0
        lvl = step - 1
        if lvl == 0:
            out.stress[0] = -r
        elif is_sample(lvl, nsteps, stride):
            for i in range(n):
                tmp[i] = (Up[i] - Um[i]) / (2.0 * dt)
            energy = energy_rows(rM, Me, rK, Ke, F, U, tmp, offset)
            record_sample(k, lvl * dt, U, tmp, -r, energy, out)
            k += 1
            if blown_up(energy, E0):
                return k, lvl, min_u0, lvl
        if step == nsteps + 1:
            break
        Um, U, Up = U, Up, Um
        if U[0] < min_u0:
            min_u0 = U[0]
    return k, nsteps, min_u0, -1


@njit(cache=True, fastmath=FASTMATH)
def tf_lumped_kernel(bar, w0, state, run, out):
    """`taylor_flanagan.taylor_flanagan_kernel` for a diagonal M: w = M^{-1} e0 = w0 e0.

    Carries (U^n, V^{n-1/2}) (kick-drift form; V^n = V^{n-1/2} + dt/2 A^n is formed
    only at the samples). Same samples, stress, min u0 and blow-up step as the
    generic kernel; the `BarState` (U, V, A) is used as buffers. bar: the `Bar`; run: the
    `Run`; out: the `Samples`.
    """
    Md, Me, Kd, Ke, F = bar
    U, V, A = state
    dt, nsteps, stride, offset = run
    n = U.size
    c = np.empty(n)
    for i in range(n):
        c[i] = dt / Md[i]
    Un = np.empty(n)
    tmp = np.empty(n)
    min_u0 = U[0]
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    E0 = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
    record_sample(0, 0.0, U, V, 0.0, E0, out)
    k = 1
    Vh = V
    for i in range(n):
        Vh[i] += 0.5 * dt * A[i]  # V^{1/2}
    for step in range(1, nsteps + 1):
        if step == 1:
            for i in range(n):
                Un[i] = U[i] + dt * Vh[i]
        else:
            kick_drift(c, F, Kd, Ke, U, Vh, Un, dt)
        lam = 0.0
        if Un[0] < 0.0:
            lam = -Vh[0] / (dt * w0)
            if lam < 0.0:
                lam = 0.0
            Un[0] += dt * dt * lam * w0
            Vh[0] += dt * lam * w0
        U, Un = Un, U
        if U[0] < min_u0:
            min_u0 = U[0]
        if is_sample(step, nsteps, stride):
            tri_matvec(Kd, Ke, U, tmp)
            for i in range(n):
                tmp[i] = Vh[i] + 0.5 * dt * ((F[i] - tmp[i]) / Md[i])
            energy = energy_rows(rM, Me, rK, Ke, F, U, tmp, offset)
            record_sample(k, step * dt, U, tmp, -lam, energy, out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1
