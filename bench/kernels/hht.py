"""The compiled step of `hht` (HHT-alpha, exact contact at t_{n+1}) on a tridiagonal
M and K: the scheme and its equations are in `contact_bench.schemes.hht`."""

from __future__ import annotations

import numpy as np
from numba import njit

from contact_bench.core.sampling import blown_up, energy_rows, is_sample, record_sample, row_sums
from contact_bench.core.tridiag import newmark_update, pt_backward


@njit(cache=True)
def hht_kernel(bar, S, state, alpha, coef, run, out):
    """Advance the `BarState` (U, V, A) in place; returns (samples, steps, min u0, blow-up
    step). bar: the `Bar`; S: the `Implicit` system M + (1 + alpha) beta dt^2 K; coef: the
    `NewmarkCoef`; run: the `Run`; out: the `Samples`.

    Three passes over the nodes per step, with the operations of the plain algorithm
    (module docstring; `tri_matvec`, `pt_solve`) in the same order, so the same bits:
    up, the predictor, the right-hand side and the forward sweep; down, the backward
    sweep; up, the contact and the Newmark update. The first and last rows are written
    apart rather than by `tri_row` in one loop (the layouts compared, with their
    timings: docs/performance.md)."""
    Md, Me, Kd, Ke, F = bar
    Sd, Se, w = S
    U, V, A = state
    beta, gamma, massless = coef
    dt, nsteps, stride, offset = run
    n = U.size
    Ut = np.empty(n)
    rhs = np.empty(n)
    bdt2 = beta * dt * dt
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    E0 = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
    min_u0 = U[0]
    record_sample(0, 0.0, U, V, 0.0, E0, out)
    k = 1
    c2 = (0.5 - beta) * dt * dt
    for step in range(1, nsteps + 1):
        # pass 1 (up): predictor, right-hand side M Ut + bdt2 (F + alpha K U) (rows as
        # in `tri_matvec`) and the forward sweep of `pt_solve`, the same operations
        cur = U[0] + dt * V[0] + c2 * A[0]
        Ut[0] = cur
        if n == 1:
            y = Md[0] * cur + bdt2 * (F[0] + alpha * (Kd[0] * U[0]))
            rhs[0] = y / Sd[0]
        else:
            nxt = U[1] + dt * V[1] + c2 * A[1]
            r = Md[0] * cur + Me[0] * nxt
            r += bdt2 * (F[0] + alpha * (Kd[0] * U[0] + Ke[0] * U[1]))
            y = r
            rhs[0] = y / Sd[0]
            for i in range(1, n - 1):
                prev, cur = cur, nxt
                Ut[i] = cur
                nxt = U[i + 1] + dt * V[i + 1] + c2 * A[i + 1]
                r = (Md[i] * cur + Me[i - 1] * prev) + Me[i] * nxt
                ku = (Kd[i] * U[i] + Ke[i - 1] * U[i - 1]) + Ke[i] * U[i + 1]
                r += bdt2 * (F[i] + alpha * ku)
                y = r - Se[i - 1] * y
                rhs[i] = y / Sd[i]
            j = n - 1
            Ut[j] = nxt
            r = Md[j] * nxt + Me[j - 1] * cur
            r += bdt2 * (F[j] + alpha * (Kd[j] * U[j] + Ke[j - 1] * U[j - 1]))
            y = r - Se[j - 1] * y
            rhs[j] = y / Sd[j]
        # pass 2 (down): the backward sweep
        pt_backward(Se, rhs)
        # pass 3 (up): contact, Newmark update
        mu = 0.0
        if rhs[0] < 0.0:
            mu = -rhs[0] / w[0]
        lam = mu / bdt2
        newmark_update(rhs, mu, w, mu != 0.0, Ut, state, dt, coef)
        if U[0] < min_u0:
            min_u0 = U[0]
        if is_sample(step, nsteps, stride):
            energy = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
            record_sample(k, step * dt, U, V, -lam, energy, out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1
