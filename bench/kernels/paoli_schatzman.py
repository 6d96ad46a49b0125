"""The compiled two-step Paoli-Schatzman scheme (`restitution`) on a tridiagonal M and K,
any mass and stiffness weight beta: the scheme and its equations are in
`contact_bench.schemes.restitution`; the lumped, beta = 0 path is
`contact_bench.kernels.lumped.ps_lumped_kernel`."""

from __future__ import annotations

import numpy as np
from numba import njit

from contact_bench.core.sampling import blown_up, energy_rows, is_sample, record_sample, row_sums
from contact_bench.core.tridiag import pt_solve, tri_matvec


@njit(cache=True)
def ps_kernel(bar, S, Um, U, V0, coef, run, out):
    """Two-step Paoli-Schatzman from (U^{-1}, U^0); one extra step gives the last velocity.

    bar: the `Bar`; S: the `Implicit` system M + beta dt^2 K; coef: (beta, e), the stiffness
    weight and the restitution coefficient; run: the `Run`; out: the `Samples`."""
    Md, Me, Kd, Ke, F = bar
    Sd, Se, w = S
    beta, e = coef
    dt, nsteps, stride, offset = run
    n = U.size
    rhs = np.empty(n)
    tmp = np.empty(n)
    Up = np.empty(n)
    dt2 = dt * dt
    min_u0 = U[0]
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    E0 = energy_rows(rM, Me, rK, Ke, F, U, V0, offset)
    record_sample(0, 0.0, U, V0, out.stress[0], E0, out)
    k = 1
    for step in range(1, nsteps + 2):
        # S U^{n+1} = M (2 U^n - U^{n-1}) - dt^2 K ((1 - 2 beta) U^n + beta U^{n-1}) + dt^2 F
        for i in range(n):
            tmp[i] = 2.0 * U[i] - Um[i]
        tri_matvec(Md, Me, tmp, rhs)
        for i in range(n):
            tmp[i] = (1.0 - 2.0 * beta) * U[i] + beta * Um[i]
        tri_matvec(Kd, Ke, tmp, Up)
        for i in range(n):
            rhs[i] += dt2 * (F[i] - Up[i])
        pt_solve(Sd, Se, rhs)
        r = 0.0
        gap = rhs[0] + e * Um[0]
        if gap < 0.0:
            r = -gap / (dt2 * w[0])
            for i in range(n):
                rhs[i] += dt2 * r * w[i]
            rhs[0] = -e * Um[0]
        # level n = step - 1 is complete: sample (U^n, (U^{n+1} - U^{n-1}) / 2 dt, -r^n)
        lvl = step - 1
        if lvl == 0:
            out.stress[0] = -r
        elif is_sample(lvl, nsteps, stride):
            for i in range(n):
                tmp[i] = (rhs[i] - Um[i]) / (2.0 * dt)
            energy = energy_rows(rM, Me, rK, Ke, F, U, tmp, offset)
            record_sample(k, lvl * dt, U, tmp, -r, energy, out)
            k += 1
            if blown_up(energy, E0):
                return k, lvl, min_u0, lvl
        if step == nsteps + 1:
            break
        for i in range(n):
            Um[i] = U[i]
            U[i] = rhs[i]
        if U[0] < min_u0:
            min_u0 = U[0]
    return k, nsteps, min_u0, -1
