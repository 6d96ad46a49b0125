"""Serial Newmark kernels for small systems: a plain Thomas sweep, the recurrence in a register.

The same steps as the vector kernels of `contact_bench.kernels.newmark_vec` (state (X, Q),
see that module's docstring), in node order, for systems below `newmark.SERIAL_BELOW`
unknowns and short runs (`newmark.kernel_form`): there the 16 interleaved SPIKE blocks
of one or two rows each cost more (the reduced system, the spike corrections, the padded
rows, the set-up) than the latency of one serial forward-backward sweep. Per step, two
passes over the nodes:

- backward sweep (rows n-1 .. 0) of the LDL^T factors, the recurrence in a register;
- one ascending pass that finishes row i + 1 (contact correction mu w, Newmark update)
  and starts row i of the next step (right-hand side G + T X, forward-sweep step).

Sample steps take an unfused path that also forms V and writes the sample with the shared
`record_sample` and `energy_rows` of `contact_bench.core.sampling`. Needs n >= 3.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from contact_bench.core.config import FASTMATH
from contact_bench.core.sampling import blown_up, energy_rows, record_sample, row_sums
from contact_bench.core.tridiag import eliminate_contact_node


class XQState(NamedTuple):
    """The (X, Q) form's state, advanced in place: the predictor X and Q (module
    docstring), the solve's z and the sample velocity Vs; node order for the serial
    kernels, interleaved for the vector ones."""

    X: np.ndarray
    Q: np.ndarray
    z: np.ndarray
    Vs: np.ndarray


class XQCoef(NamedTuple):
    """The (X, Q) update's numbers: u0 the contact node's initial displacement, k1, k2, kv
    (implicit: (gamma + 1/2 - beta) / beta, 1 / beta, gamma / (beta dt); explicit: gamma +
    1/2, 1, gamma / dt), sscale the contact stress per mu (implicit: 1 / (beta dt^2)), and
    whether the contact node is massless (the explicit kernels always take it so)."""

    u0: float
    k1: float
    k2: float
    kv: float
    sscale: float
    massless: bool


class ThomasImplicit(NamedTuple):
    """The serial implicit solve: G = beta dt^2 F, S = M + beta dt^2 K's factors (ef: L's
    band, invd = 1 / D), its response w = S^-1 e0 and w0 = w[0]."""

    G: np.ndarray
    ef: np.ndarray
    invd: np.ndarray
    w: np.ndarray
    w0: float


class ThomasExplicit(NamedTuple):
    """The serial explicit solve M_r z = G + T X: T = -dt^2 K (Td, Te), G = dt^2 F, M's
    factors with node 0 decoupled (ef, invd = 1 / D)."""

    Td: np.ndarray
    Te: np.ndarray
    G: np.ndarray
    ef: np.ndarray
    invd: np.ndarray


@njit(cache=True, fastmath=FASTMATH)
def _forward(Td, Te, G, X, ef, invd, z, first):  # pragma: no cover - compiled
    """z <- D^-1 L^-1 (G + T X) on rows first .. n-1 (first 0 or 1; row 0 of first = 1
    is set to 0), each row summed as the fused passes of the kernels sum it, so that a
    step after a sample step gives the same bits. T X is summed before G is added: a
    rigid translation X makes T X small by cancellation, and a small load added first
    would lose its low bits in the large partial sums."""
    n = X.size
    if first == 0:
        y = G[0] + (Td[0] * X[0] + Te[0] * X[1])
        z[0] = y * invd[0]
    else:
        z[0] = 0.0
        y = 0.0
    for i in range(1, n - 1):
        r = G[i] + ((Td[i] * X[i] + Te[i - 1] * X[i - 1]) + Te[i] * X[i + 1])
        y = r - ef[i - 1] * y
        z[i] = y * invd[i]
    r = G[n - 1] + (Td[n - 1] * X[n - 1] + Te[n - 2] * X[n - 2])
    y = r - ef[n - 2] * y
    z[n - 1] = y * invd[n - 1]


@njit(cache=True, fastmath=FASTMATH)
def _backward(ef, z):  # pragma: no cover - compiled
    """z[i] -= ef[i] z[i+1] from row n-2 up, the running value in a register."""
    n = z.size
    x = z[n - 1]
    for i in range(n - 2, -1, -1):
        x = z[i] - ef[i] * x
        z[i] = x


@njit(cache=True, fastmath=FASTMATH)
def serial_implicit(bar, solve, state, upd, run, out):
    """Implicit Newmark, state (X, Q): z = S^-1 (G + M X), contact mu w if z[0] < 0, then
    d = z - X, X <- z + Q + k1 d, Q <- Q + k2 d (V = Q / dt + kv d on sample steps).
    k1, k2, kv = (gamma + 1/2 - beta) / beta, 1 / beta, gamma / (beta dt); the contact
    stress is -mu sscale, sscale = 1 / (beta dt^2). Returns (samples, steps, min u0,
    blow-up step or -1). bar: the `Bar`; solve: the `ThomasImplicit`; state: the
    `XQState`; upd: the `XQCoef`; run: the `Run`; out: the `Samples` (sample 0 written)."""
    Md, Me, Kd, Ke, F = bar
    G, ef, invd, w, w0 = solve
    X, Q, z, Vs = state
    u0, k1, k2, kv, sscale, massless = upd
    dt, nsteps, stride, offset = run
    E_out = out.energy
    n = X.size
    idt = 1.0 / dt
    min_u0 = u0
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    E0 = E_out[0]
    k = 1
    _forward(Md, Me, G, X, ef, invd, z, 0)
    for step in range(1, nsteps + 1):
        _backward(ef, z)
        x0 = z[0]
        mu = -x0 / w0 if x0 < 0.0 else 0.0
        u1 = 0.0 if mu != 0.0 else x0
        if step % stride == 0 or step == nsteps:
            for i in range(n):
                zi = z[i] + mu * w[i]
                if i == 0:
                    zi = u1
                q = Q[i]
                d = zi - X[i]
                Vs[i] = kv * d + q * idt
                X[i] = zi + q + k1 * d
                Q[i] = q + k2 * d
                z[i] = zi
            if massless:
                X[0] = 2.0 * u1 - u0
                Q[0] = u1 - u0
                Vs[0] = (u1 - u0) * idt
            energy = energy_rows(rM, Me, rK, Ke, F, z, Vs, offset)
            record_sample(k, step * dt, z, Vs, -mu * sscale, energy,
                          out)
            k += 1
            if u1 < min_u0:
                min_u0 = u1
            if blown_up(energy, E0):
                return k, step, min_u0, step
            u0 = u1
            if step < nsteps:
                _forward(Md, Me, G, X, ef, invd, z, 0)
            continue
        # row 0, row 1: final values and update
        q = Q[0]
        d = u1 - X[0]
        xc = u1 + q + k1 * d
        Q[0] = q + k2 * d
        if massless:
            xc = 2.0 * u1 - u0
            Q[0] = u1 - u0
        X[0] = xc
        zi = z[1] + mu * w[1]
        q = Q[1]
        d = zi - X[1]
        xp = zi + q + k1 * d
        Q[1] = q + k2 * d
        X[1] = xp
        y = G[0] + (Md[0] * xc + Me[0] * xp)
        z[0] = y * invd[0]
        xm = xc
        xc = xp
        for i in range(1, n - 1):
            zi = z[i + 1] + mu * w[i + 1]
            q = Q[i + 1]
            d = zi - X[i + 1]
            xp = zi + q + k1 * d
            Q[i + 1] = q + k2 * d
            X[i + 1] = xp
            r = G[i] + ((Md[i] * xc + Me[i - 1] * xm) + Me[i] * xp)
            y = r - ef[i - 1] * y
            z[i] = y * invd[i]
            xm = xc
            xc = xp
        r = G[n - 1] + (Md[n - 1] * xc + Me[n - 2] * xm)
        y = r - ef[n - 2] * y
        z[n - 1] = y * invd[n - 1]
        if u1 < min_u0:
            min_u0 = u1
        u0 = u1
    return k, nsteps, min_u0, -1


@njit(cache=True, fastmath=FASTMATH)
def serial_explicit(bar, solve, state, upd, run, out):
    """Central differences with a massless contact node, state (X, Q): node 0 eliminated
    from node 1 (u0 = max(0, ...)), z = dt^2 A1 = M_r^-1 (G + T X) on nodes 1.. (T = -dt^2
    K, G = dt^2 F; ef, invd: factors of M with node 0 decoupled), X <- X + Q + k1 z,
    Q <- Q + k2 z. k1, k2, kv = gamma + 1/2, 1, gamma / dt. bar: the `Bar`; solve: the
    `ThomasExplicit`; state: the `XQState`; upd: the `XQCoef` (sscale, massless unused);
    run: the `Run`; out: the `Samples` (sample 0 written)."""
    Md, Me, Kd, Ke, F = bar
    Td, Te, G, ef, invd = solve
    X, Q, z, Vs = state
    u0, k1, k2, kv = upd.u0, upd.k1, upd.k2, upd.kv
    dt, nsteps, stride, offset = run
    E_out = out.energy
    n = X.size
    idt = 1.0 / dt
    min_u0 = u0
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    E0 = E_out[0]
    k = 1
    lam = eliminate_contact_node(Kd, Ke, F, X, 1)
    _forward(Td, Te, G, X, ef, invd, z, 1)
    for step in range(1, nsteps + 1):
        _backward(ef, z)
        z[0] = 0.0
        u1 = X[0]
        v0 = u1 - u0
        if u1 < min_u0:
            min_u0 = u1
        if step % stride == 0 or step == nsteps:
            for i in range(n):
                Vs[i] = kv * z[i] + Q[i] * idt
            Vs[0] = v0 * idt
            energy = energy_rows(rM, Me, rK, Ke, F, X, Vs, offset)
            record_sample(k, step * dt, X, Vs, -lam, energy,
                          out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
            for i in range(n):
                zi = z[i]
                q = Q[i]
                X[i] = X[i] + q + k1 * zi
                Q[i] = q + k2 * zi
            Q[0] = v0
            u0 = u1
            if step < nsteps:
                lam = eliminate_contact_node(Kd, Ke, F, X, 1)
                _forward(Td, Te, G, X, ef, invd, z, 1)
            continue
        # row 1 updated, node 0 eliminated from it, then rows 1 .. n-1 of the next solve
        Q[0] = v0
        zi = z[1]
        q = Q[1]
        xc = X[1] + q + k1 * zi
        Q[1] = q + k2 * zi
        X[1] = xc
        lam = eliminate_contact_node(Kd, Ke, F, X, 1)
        xm = X[0]
        z[0] = 0.0
        y = 0.0
        for i in range(1, n - 1):
            zi = z[i + 1]
            q = Q[i + 1]
            xp = X[i + 1] + q + k1 * zi
            Q[i + 1] = q + k2 * zi
            X[i + 1] = xp
            r = G[i] + ((Td[i] * xc + Te[i - 1] * xm) + Te[i] * xp)
            y = r - ef[i - 1] * y
            z[i] = y * invd[i]
            xm = xc
            xc = xp
        r = G[n - 1] + (Td[n - 1] * xc + Te[n - 2] * xm)
        y = r - ef[n - 2] * y
        z[n - 1] = y * invd[n - 1]
        u0 = u1
    return k, nsteps, min_u0, -1
