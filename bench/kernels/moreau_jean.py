"""The compiled step of `moreau_jean` (theta-method, Newton impact law on velocities) on
a tridiagonal M and K: the scheme and its equations are in
`contact_bench.schemes.moreau_jean`."""

from __future__ import annotations

import numpy as np
from numba import njit

from contact_bench.core.sampling import blown_up, energy_rows, is_sample, record_sample, row_sums
from contact_bench.core.tridiag import pt_backward, tri_row


@njit(cache=True)
def moreau_jean_kernel(bar, S, U, V, theta, e, run, out):
    """Advance (U, V) in place (bar: the `Bar`, S: the `Implicit` system M + theta^2 dt^2 K,
    run: the `Run`, out: the `Samples`); returns (samples, steps, min u0, blow-up step).

    Three passes over the nodes per step (up: right-hand side and forward sweep; down:
    backward sweep; up: impulse and update), with the operations of the plain algorithm
    (`tri_matvec`, `pt_solve`, then the impulse added to every node) in the same order:
    the same bits."""
    Md, Me, Kd, Ke, F = bar
    Sd, Se, w = S
    dt, nsteps, stride, offset = run
    n = U.size
    rhs = np.empty(n)
    min_u0 = U[0]
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    E0 = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
    record_sample(0, 0.0, U, V, 0.0, E0, out)
    k = 1
    c = theta * (1.0 - theta) * dt * dt
    for step in range(1, nsteps + 1):
        # up: M V + dt (F - K U) - c K V row by row and the forward sweep of `pt_solve`
        y = 0.0
        for i in range(n):
            r = tri_row(Md, Me, V, i, n)
            r += dt * (F[i] - tri_row(Kd, Ke, U, i, n)) - c * tri_row(Kd, Ke, V, i, n)
            y = r if i == 0 else r - Se[i - 1] * y
            rhs[i] = y / Sd[i]
        # down: the backward sweep
        pt_backward(Se, rhs)
        P = 0.0
        active = False
        if U[0] + 0.5 * dt * V[0] <= 0.0:  # contact predicted: Newton law on velocities
            g = rhs[0] + e * V[0]
            if g < 0.0:
                P = -g / w[0]
                active = True
        # up: the impulse and the update
        for i in range(n):
            v1 = rhs[i] + P * w[i] if active else rhs[i]
            if i == 0 and active:
                v1 = -e * V[0]
            U[i] += dt * (theta * v1 + (1.0 - theta) * V[i])
            V[i] = v1
        if U[0] < min_u0:
            min_u0 = U[0]
        if is_sample(step, nsteps, stride):
            energy = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
            record_sample(k, step * dt, U, V, -P / dt, energy, out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1
