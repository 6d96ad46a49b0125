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
    is_sample,
    pt_solve,
    trajectory,
    tri_matvec,
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


@njit(cache=True)
def newmark_kernel(Md, Me, Kd, Ke, F, Sd, Se, w, U, V, A, dt, beta, gamma, massless,
                   nsteps, stride, offset, t_out, U_out, V_out, cu_out, s_out, E_out):
    """Advance (U, V, A) in place over nsteps; returns (samples, steps, min u0, blow-up step)."""
    n = U.size
    Ut = np.empty(n)
    rhs = np.empty(n)
    U1 = np.empty(n)
    A1 = np.empty(n)
    bdt2 = beta * dt * dt
    lam = 0.0
    min_u0 = U[0]
    E0 = energy_of(Md, Me, Kd, Ke, F, U, V, offset)
    k = 0
    t_out[0] = 0.0
    U_out[0, :] = U
    V_out[0, :] = V
    cu_out[0] = U[0]
    s_out[0] = 0.0
    E_out[0] = E0
    k = 1
    for step in range(1, nsteps + 1):
        if beta > 0.0:
            for i in range(n):
                Ut[i] = U[i] + dt * V[i] + (0.5 - beta) * dt * dt * A[i]
            tri_matvec(Md, Me, Ut, rhs)
            for i in range(n):
                rhs[i] += bdt2 * F[i]
            pt_solve(Sd, Se, rhs)
            mu = 0.0
            if rhs[0] < 0.0:
                mu = -rhs[0] / w[0]
            for i in range(n):
                U1[i] = rhs[i] + mu * w[i]
            if mu != 0.0:
                U1[0] = 0.0
            lam = mu / bdt2
            for i in range(n):
                A1[i] = (U1[i] - Ut[i]) / bdt2
        else:
            for i in range(1, n):
                U1[i] = U[i] + dt * V[i] + 0.5 * dt * dt * A[i]
            u0 = (F[0] - Ke[0] * U1[1]) / Kd[0]
            U1[0] = u0 if u0 > 0.0 else 0.0
            lam = Kd[0] * U1[0] + Ke[0] * U1[1] - F[0]
            # M_r A1 = F - K U1 on nodes 1..n-1
            tri_matvec(Kd, Ke, U1, rhs)
            for i in range(n):
                A1[i] = F[i] - rhs[i]
            pt_solve(Sd, Se, A1[1:])
            A1[0] = 0.0
        for i in range(n):
            V[i] = V[i] + dt * ((1.0 - gamma) * A[i] + gamma * A1[i])
        if massless:
            V[0] = (U1[0] - U[0]) / dt
            A1[0] = 0.0
        for i in range(n):
            U[i] = U1[i]
            A[i] = A1[i]
        if U[0] < min_u0:
            min_u0 = U[0]
        if is_sample(step, nsteps, stride):
            energy = energy_of(Md, Me, Kd, Ke, F, U, V, offset)
            t_out[k] = step * dt
            U_out[k, :] = U
            V_out[k, :] = V
            cu_out[k] = U[0]
            s_out[k] = -lam
            E_out[k] = energy
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1


def run_newmark(semi: Semidiscrete, dt: float, nsteps: int, stride: int,
                beta: float, gamma: float) -> Trajectory:
    """Factor outside the loop, then call the kernel."""
    M, K = semi.M, semi.K
    if beta > 0.0:
        Sd, Se = factor_pt(M.diag + beta * dt * dt * K.diag, M.off + beta * dt * dt * K.off)
        w = np.zeros(semi.nfree)
        w[0] = 1.0
        pt_solve(Sd, Se, w)
    else:
        if not semi.massless:
            raise ValueError("explicit Newmark (beta = 0) here needs a massless contact node")
        Sd, Se = factor_pt(M.diag[1:], M.off[1:])
        w = np.zeros(1)
    U, V = semi.U0.copy(), semi.V0.copy()
    A = initial_acceleration(semi)
    out = allocate(semi, nsteps, stride)
    k, done, min_u0, blow = newmark_kernel(
        M.diag, M.off, K.diag, K.off, semi.F, Sd, Se, w, U, V, A, float(dt), float(beta),
        float(gamma), bool(semi.massless), int(nsteps), int(stride), semi.energy_offset,
        out["t"], out["U"], out["V"], out["cu"], out["s"], out["E"],
    )
    return trajectory(out, k, done, min_u0, blow, dt)
