"""Newmark(beta, gamma) with the contact enforced exactly at t_{n+1}.

Shared by `standard` (consistent mass) and `redistributed` (massless contact node).

Implicit (beta > 0), displacement form: S U^{n+1} = M U~ + beta dt^2 (F + lambda e0)
with S = M + beta dt^2 K factored once (LAPACK dpttrf) and the predictor
U~ = U^n + dt V^n + (1/2 - beta) dt^2 A^n. The response to a unit contact force,
w = S^{-1} e0, is computed once: when the contact-free solution U_f penetrates,
U^{n+1} = U_f + mu w with mu = -U_f[0] / w[0], so an active contact costs no second
solve. The obstacle's force is lambda = mu / (beta dt^2) >= 0 and the contact stress
is -lambda (E u_x(0) <= 0 in compression).

Explicit (beta = 0), only with a massless contact node (the seed's P_U^mod): the
other nodes are advanced by central differences, then
u0 = max(0, (F0 - K01 u1) / K00) and lambda = K00 u0 + K01 u1 - F0.

A massless node has no inertia, so its Newmark acceleration is meaningless: its
velocity is taken as the backward difference (u0^{n+1} - u0^n) / dt.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bench.params import Param
from bench.plugin import Semidiscrete, Trajectory
from schemes._common import (
    allocate,
    blown_up,
    energy_of,
    factor_pt,
    initial_acceleration,
    trajectory,
)

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
# Both kernels make two fused sweeps per step. S (or M_r) is factored "upside down",
# S = U D U^T with U unit upper bidiagonal (U[i, i+1] = g[i]), so that the first sweep
# (U z = rhs) runs from the far end down to the contact node and the second sweep
# (U^T x = D^-1 z) starts at the contact node. The contact force is then known at the
# first entry of the second sweep, and the contact correction, the Newmark update and
# the sampling are done in that same sweep: each step reads and writes every vector
# twice, with no temporaries. `contract` lets LLVM fuse a*b+c into one FMA (deterministic:
# results are bit-identical from run to run).
_FM = {"contract"}


@njit(cache=True, fastmath=_FM)
def _implicit_kernel(Md, Me, Kd, Ke, F, bF, g, invD, w, Ut, V, A, z, u0, dt, beta, gamma,
                     massless, nsteps, stride, offset, t_out, U_out, V_out, cu_out, s_out,
                     E_out):
    """Implicit Newmark; the state is the predictor Ut and (V, A); u0 = U[0]."""
    n = Ut.size
    nw = w.size
    ibdt2 = 1.0 / (beta * dt * dt)
    c2 = (0.5 - beta) * dt * dt
    dg = dt * gamma
    dg1 = dt * (1.0 - gamma)
    idt = 1.0 / dt
    min_u0 = u0
    E0 = E_out[0]
    k = 1
    for step in range(1, nsteps + 1):
        sample = step % stride == 0 or step == nsteps
        # sweep 1, far end -> contact node: z = U^-1 (M Ut + beta dt^2 F)
        if n == 1:
            z[0] = Md[0] * Ut[0] + bF[0]
        else:
            zi = Md[n - 1] * Ut[n - 1] + Me[n - 2] * Ut[n - 2] + bF[n - 1]
            z[n - 1] = zi
            for i in range(n - 2, 0, -1):
                r = Md[i] * Ut[i] + Me[i] * Ut[i + 1] + Me[i - 1] * Ut[i - 1] + bF[i]
                zi = r - g[i] * zi
                z[i] = zi
            z[0] = Md[0] * Ut[0] + Me[0] * Ut[1] + bF[0] - g[0] * zi
        # sweep 2, contact node -> far end: x = D^-1 U^-T z, U1 = x + mu w, update
        x = z[0] * invD[0]
        mu = -x / w[0] if x < 0.0 else 0.0
        u1 = 0.0 if mu != 0.0 else x
        if massless:
            a1 = 0.0
            v1 = (u1 - u0) * idt
        else:
            a1 = (u1 - Ut[0]) * ibdt2
            v1 = V[0] + dg1 * A[0] + dg * a1
        Ut[0] = u1 + dt * v1 + c2 * a1
        V[0] = v1
        A[0] = a1
        if sample:
            U_out[k, 0] = u1
            V_out[k, 0] = v1
        u0 = u1
        if u1 < min_u0:
            min_u0 = u1
        for i in range(1, n):
            x = z[i] * invD[i] - g[i - 1] * x
            u1 = x + mu * w[i] if i < nw else x
            a1 = (u1 - Ut[i]) * ibdt2
            v1 = V[i] + dg1 * A[i] + dg * a1
            Ut[i] = u1 + dt * v1 + c2 * a1
            V[i] = v1
            A[i] = a1
            if sample:
                U_out[k, i] = u1
                V_out[k, i] = v1
        if sample:
            energy = energy_of(Md, Me, Kd, Ke, F, U_out[k], V_out[k], offset)
            t_out[k] = step * dt
            cu_out[k] = u0
            s_out[k] = -mu * ibdt2
            E_out[k] = energy
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1


@njit(cache=True, fastmath=_FM)
def _explicit_kernel(Md, Me, Kd, Ke, F, g, invD, U, V, A, z, dt, gamma, nsteps, stride,
                     offset, t_out, U_out, V_out, cu_out, s_out, E_out):
    """Central differences (beta = 0) with a massless contact node; g, invD factor M_r."""
    n = U.size
    h2 = 0.5 * dt * dt
    dg = dt * gamma
    dg1 = dt * (1.0 - gamma)
    idt = 1.0 / dt
    min_u0 = U[0]
    E0 = E_out[0]
    k = 1
    for step in range(1, nsteps + 1):
        sample = step % stride == 0 or step == nsteps
        # sweep 1, far end -> contact node: predictor U1 (in place, one node ahead),
        # r = F - K U1 and z = U^-1 r on nodes 1..n-1; the contact node last.
        u0_old = U[0]
        up = U[n - 1] + dt * V[n - 1] + h2 * A[n - 1]  # U1[i+1]
        ui = U[n - 2] + dt * V[n - 2] + h2 * A[n - 2] if n > 2 else 0.0  # U1[i]
        zi = 0.0
        if n > 2:
            r = F[n - 1] - Kd[n - 1] * up - Ke[n - 2] * ui
            zi = r
            z[n - 1] = zi
            U[n - 1] = up
            for i in range(n - 2, 1, -1):
                um = U[i - 1] + dt * V[i - 1] + h2 * A[i - 1]
                r = F[i] - Kd[i] * ui - Ke[i] * up - Ke[i - 1] * um
                zi = r - g[i] * zi
                z[i] = zi
                U[i] = ui
                up = ui
                ui = um
            # now ui = U1[1], up = U1[2]
        else:  # n == 2: only nodes 0 and 1
            ui = up
            up = 0.0
        c = (F[0] - Ke[0] * ui) / Kd[0]
        ucon = c if c > 0.0 else 0.0
        lam = Kd[0] * ucon + Ke[0] * ui - F[0]
        r = F[1] - Kd[1] * ui - Ke[0] * ucon
        if n > 2:
            r -= Ke[1] * up
            zi = r - g[1] * zi
        else:
            zi = r
        z[1] = zi
        U[1] = ui
        U[0] = ucon
        # sweep 2, contact node -> far end: A1 = D^-1 U^-T z on nodes 1.., update V, A
        v0 = (ucon - u0_old) * idt
        V[0] = v0
        A[0] = 0.0
        if sample:
            U_out[k, 0] = ucon
            V_out[k, 0] = v0
        if ucon < min_u0:
            min_u0 = ucon
        a1 = 0.0
        for i in range(1, n):
            a1 = z[i] * invD[i] - g[i - 1] * a1
            v1 = V[i] + dg1 * A[i] + dg * a1
            V[i] = v1
            A[i] = a1
            if sample:
                U_out[k, i] = U[i]
                V_out[k, i] = v1
        if sample:
            energy = energy_of(Md, Me, Kd, Ke, F, U_out[k], V_out[k], offset)
            t_out[k] = step * dt
            cu_out[k] = ucon
            s_out[k] = -lam
            E_out[k] = energy
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1


def factor_reversed(d: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """S = U D U^T, U unit upper bidiagonal: returns g (U[i, i+1], g[n-1] = 0) and 1/D."""
    df, ef = factor_pt(np.ascontiguousarray(d[::-1]), np.ascontiguousarray(e[::-1]))
    g = np.zeros(d.size)
    g[:-1] = ef[::-1]
    return g, 1.0 / df[::-1]


#: the contact response w = S^-1 e0 decays geometrically away from the contact node;
#: entries below this fraction of w[0] are dropped (a change of < 1e-20 |U1[0]| per step)
W_CUTOFF = 1e-20


def run_newmark(semi: Semidiscrete, dt: float, nsteps: int, stride: int,
                beta: float, gamma: float) -> Trajectory:
    """Factor outside the loop, then call the kernel."""
    M, K = semi.M, semi.K
    n = semi.nfree
    dt, beta, gamma = float(dt), float(beta), float(gamma)
    U, V = semi.U0.copy(), semi.V0.copy()
    A = initial_acceleration(semi)
    out = allocate(semi, nsteps, stride)
    out["U"][0], out["V"][0], out["cu"][0] = U, V, U[0]
    out["E"][0] = energy_of(M.diag, M.off, K.diag, K.off, semi.F, U, V, semi.energy_offset)
    z = np.empty(n)
    if beta > 0.0:
        bdt2 = beta * dt * dt
        g, invD = factor_reversed(M.diag + bdt2 * K.diag, M.off + bdt2 * K.off)
        # w = S^-1 e0 = D0^-1 (1, -g0, g0 g1, ...): U z = e0 gives z = e0
        w = invD[0] * np.concatenate(([1.0], np.cumprod(-g[:-1])))
        keep = np.nonzero(np.abs(w) > W_CUTOFF * abs(w[0]))[0]
        w = np.ascontiguousarray(w[: keep[-1] + 1])
        Ut = U + dt * V + (0.5 - beta) * dt * dt * A
        k, done, min_u0, blow = _implicit_kernel(
            M.diag, M.off, K.diag, K.off, semi.F, bdt2 * semi.F, g, invD, w, Ut, V, A, z,
            float(U[0]), dt, beta, gamma, bool(semi.massless), int(nsteps), int(stride),
            semi.energy_offset, out["t"], out["U"], out["V"], out["cu"], out["s"], out["E"])
    else:
        if not semi.massless:
            raise ValueError("explicit Newmark (beta = 0) here needs a massless contact node")
        if n < 2:
            raise ValueError("explicit Newmark needs at least one node besides the contact node")
        g1, invD1 = factor_reversed(M.diag[1:], M.off[1:])
        g = np.concatenate(([0.0], g1))  # indexed by node: g[i] couples nodes i and i+1
        invD = np.concatenate(([0.0], invD1))
        k, done, min_u0, blow = _explicit_kernel(
            M.diag, M.off, K.diag, K.off, semi.F, g, invD, U, V, A, z, dt, gamma,
            int(nsteps), int(stride), semi.energy_offset,
            out["t"], out["U"], out["V"], out["cu"], out["s"], out["E"])
    return trajectory(out, k, done, min_u0, blow, dt)
