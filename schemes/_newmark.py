"""Newmark(beta, gamma) with the contact enforced exactly at t_{n+1}.

Shared by `standard` (consistent mass) and `redistributed` (massless contact node).

Implicit (beta > 0), displacement form: S U^{n+1} = M U~ + beta dt^2 (F + lambda e0)
with S = M + beta dt^2 K factored once (`schemes._spike`, on LAPACK dpttrf) and the
predictor U~ = U^n + dt V^n + (1/2 - beta) dt^2 A^n. The response to a unit contact
force, w = S^{-1} e0, is known from the factors: when the contact-free solution U_f
penetrates, U^{n+1} = U_f + mu w with mu = -U_f[0] / w[0], folded into the solve's
spike correction, so an active contact costs no second solve. The obstacle's force is
lambda = mu / (beta dt^2) >= 0 and the contact stress is -lambda (E u_x(0) <= 0 in
compression).

Explicit (beta = 0), only with a massless contact node (the seed's P_U^mod): the
other nodes are advanced by central differences, then
u0 = max(0, (F0 - K01 u1) / K00) and lambda = K00 u0 + K01 u1 - F0.

A massless node has no inertia, so its Newmark acceleration is meaningless: its
velocity is taken as the backward difference (u0^{n+1} - u0^n) / dt.
"""

from __future__ import annotations

import numpy as np
from numba import njit, uint64

from bench.params import Param
from bench.plugin import Semidiscrete, Trajectory
from schemes._common import (
    allocate,
    blown_up,
    eliminate_contact_node,
    energy_of,
    initial_acceleration,
    trajectory,
)
from schemes._spike import (
    L,
    Spike,
    backward_rows,
    correct,
    record_lane_sample,
    reduced,
    spike_factor,
    stencil_forward,
    stencil_solve,
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
# The kernels work in the lane-interleaved layout of `schemes._spike` (node i = c m + j
# at position j L + c, L = LANES): the system matrix is solved by L blocks at once, one
# row of all blocks per vector instruction. Each step makes three vector passes over
# the state: (1) right-hand side and forward sweep, (2) backward sweep, then the reduced
# interface system and the spike correction on a few rows per block, (3) the Newmark
# update (the explicit kernel fuses it with the next step's predictor). Only the rows
# at block ends (j = 0 and m - 1) see neighbours in other lanes; they are done by
# scalar code. Samples are scattered back to node order, on sample steps
# only. `contract` lets LLVM fuse a*b+c into one FMA (deterministic: results are
# bit-identical from run to run).
_FM = {"contract"}


@njit(cache=True, fastmath=_FM)
def _implicit_kernel(Md, Me, Kd, Ke, F, Mdl, Mlo, bF, fac, hw, w0, Ut, V, A, z, coef, u0,
                     dt, beta, gamma, massless, nsteps, stride, offset,
                     t_out, U_out, V_out, cu_out, s_out, E_out):
    """Implicit Newmark; the state is the predictor Ut and (V, A) (interleaved); u0 = U[0].

    fac = `Spike.factors()` of S; (hw, w0) its response to a unit force on node 0.
    """
    lo, invd, sa, sb, Hrow, Hpos, Hval, ja, jb, m, pos = fac
    N = L * m
    ibdt2 = 1.0 / (beta * dt * dt)
    c2 = (0.5 - beta) * dt * dt
    dg = dt * gamma
    dg1 = dt * (1.0 - gamma)
    idt = 1.0 / dt
    min_u0 = u0
    E0 = E_out[0]
    k = 1
    for step in range(1, nsteps + 1):
        # (1), (2): z = S^-1 (M Ut + beta dt^2 F), contact-free
        stencil_forward(Mdl, Mlo, Ut, bF, 1.0, lo, m, z)
        backward_rows(z, lo, invd, L * m)
        x0 = reduced(z, Hrow, Hpos, Hval, coef)
        # contact: U1 = U_f + mu w, w = S^-1 e0, through the spike coefficients
        mu = -x0 / w0 if x0 < 0.0 else 0.0
        if mu != 0.0:
            for r in range(2 * L):
                coef[r] += mu * hw[r]
            coef[0] -= mu
        correct(z, sa, sb, coef, m, ja, jb)
        if mu != 0.0:
            z[0] = 0.0
        # (3) Newmark update, all nodes; the massless contact node is redone below
        for p in range(N):
            pu = uint64(p)
            a1 = (z[pu] - Ut[pu]) * ibdt2
            v1 = V[pu] + dg1 * A[pu] + dg * a1
            Ut[pu] = z[pu] + dt * v1 + c2 * a1
            V[pu] = v1
            A[pu] = a1
        u1 = z[0]
        if massless:
            v1 = (u1 - u0) * idt
            V[0] = v1
            A[0] = 0.0
            Ut[0] = u1 + dt * v1
        u0 = u1
        if u1 < min_u0:
            min_u0 = u1
        if step % stride == 0 or step == nsteps:
            energy = record_lane_sample(k, step * dt, pos, z, V, -mu * ibdt2, Md, Me, Kd, Ke,
                                        F, offset, t_out, U_out, V_out, cu_out, s_out, E_out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1


@njit(cache=True, fastmath=_FM)
def massless_acceleration(Kd, Ke, F, Kdl, Klo, Fl, fac, p1, U, z, coef):
    """The seed's (P_U^mod) in the interleaved layout: U[0] <- u0(u1) (node 1 at position
    p1), z <- A = M_r^-1 (F - K U) on nodes 1.. and A[0] = 0; returns lambda.

    fac = `Spike.factors()` of M_r with node 0 decoupled (an identity row, lo = 0 at
    node 1), so the right-hand side of node 0 only reaches z[0], which is set to 0.
    """
    lam = eliminate_contact_node(Kd, Ke, F, U, p1)
    stencil_solve(Kdl, Klo, U, Fl, -1.0, fac, z, coef)
    z[0] = 0.0
    return lam


@njit(cache=True, fastmath=_FM)
def _explicit_kernel(Md, Me, Kd, Ke, F, Kdl, Klo, Fl, fac, U, V, A, z, coef, dt, gamma,
                     nsteps, stride, offset, t_out, U_out, V_out, cu_out, s_out, E_out):
    """Central differences (beta = 0) with a massless contact node (interleaved layout).

    fac = `Spike.factors()` of M_r with node 0 decoupled (`massless_acceleration`).
    """
    m, pos = fac[9], fac[10]
    N = L * m
    h2 = 0.5 * dt * dt
    dg = dt * gamma
    dg1 = dt * (1.0 - gamma)
    idt = 1.0 / dt
    p1 = pos[1]  # node 1's position
    u0 = U[0]
    min_u0 = u0
    E0 = E_out[0]
    k = 1
    predicted = False  # U already holds the predictor (fused into the last update)
    for step in range(1, nsteps + 1):
        if not predicted:
            for p in range(N):
                pu = uint64(p)
                U[pu] = U[pu] + dt * V[pu] + h2 * A[pu]
        lam = massless_acceleration(Kd, Ke, F, Kdl, Klo, Fl, fac, p1, U, z, coef)
        ucon = U[0]
        sample = step % stride == 0 or step == nsteps
        if sample:  # V^{n+1} only: U^{n+1} is sampled below
            for p in range(N):
                pu = uint64(p)
                V[pu] = V[pu] + dg1 * A[pu] + dg * z[pu]
        else:  # V^{n+1} and the next step's predictor in one pass
            for p in range(N):
                pu = uint64(p)
                v1 = V[pu] + dg1 * A[pu] + dg * z[pu]
                V[pu] = v1
                U[pu] = U[pu] + dt * v1 + h2 * z[pu]
        predicted = not sample
        A, z = z, A  # A^{n+1} is the solution; the old A is the next solve's scratch
        V[0] = (ucon - u0) * idt
        u0 = ucon
        if ucon < min_u0:
            min_u0 = ucon
        if sample:
            energy = record_lane_sample(k, step * dt, pos, U, V, -lam, Md, Me, Kd, Ke, F,
                                        offset, t_out, U_out, V_out, cu_out, s_out, E_out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1


def _load_to_lanes(sp: Spike, F: np.ndarray, scale: float) -> np.ndarray:
    """scale * F in the interleaved layout; a zero load is np.zeros, whose pages the
    kernel only reads, so it costs no resident memory at large n."""
    return sp.to_lanes(scale * F) if np.any(F) else sp.zeros()


def run_newmark(semi: Semidiscrete, dt: float, nsteps: int, stride: int,
                beta: float, gamma: float) -> Trajectory:
    """Factor outside the loop (interleaved SPIKE factors), then call the kernel.

    The kernel's state lives only in the interleaved layout; nothing in node order is
    kept alive while it steps beyond the problem itself and the sample buffers.
    """
    M, K = semi.M, semi.K
    n = semi.nfree
    dt, beta, gamma = float(dt), float(beta), float(gamma)
    U, V = semi.U0, semi.V0
    out = allocate(semi, nsteps, stride)
    out["U"][0], out["V"][0], out["cu"][0] = U, V, U[0]
    out["E"][0] = energy_of(M.diag, M.off, K.diag, K.off, semi.F, U, V, semi.energy_offset)
    bufs = (out["t"], out["U"], out["V"], out["cu"], out["s"], out["E"])
    if beta > 0.0:
        bdt2 = beta * dt * dt
        sp = spike_factor(M.diag + bdt2 * K.diag, M.off + bdt2 * K.off)
        A = initial_acceleration(semi)
        Ut = sp.to_lanes(U + dt * V + (0.5 - beta) * dt * dt * A)
        Al = sp.to_lanes(A)
        del A
        k, done, min_u0, blow = _implicit_kernel(
            M.diag, M.off, K.diag, K.off, semi.F, sp.to_lanes(M.diag), sp.lower_to_lanes(M.off),
            _load_to_lanes(sp, semi.F, bdt2), sp.factors(), sp.hw, sp.w0, Ut, sp.to_lanes(V),
            Al, sp.zeros(), np.zeros(2 * sp.lanes + 1), float(U[0]), dt, beta,
            gamma, bool(semi.massless), int(nsteps), int(stride), semi.energy_offset, *bufs)
    else:
        if not semi.massless:
            raise ValueError("explicit Newmark (beta = 0) here needs a massless contact node")
        if n < 2:
            raise ValueError("explicit Newmark needs at least one node besides the contact node")
        d, e = M.diag.copy(), M.off.copy()
        d[0], e[0] = 1.0, 0.0  # node 0 decoupled: M_r on nodes 1.. plus an identity row
        sp = spike_factor(d, e)
        del d, e
        Al = sp.to_lanes(initial_acceleration(semi))
        k, done, min_u0, blow = _explicit_kernel(
            M.diag, M.off, K.diag, K.off, semi.F, sp.to_lanes(K.diag), sp.lower_to_lanes(K.off),
            _load_to_lanes(sp, semi.F, 1.0), sp.factors(), sp.to_lanes(U), sp.to_lanes(V), Al,
            sp.zeros(), np.zeros(2 * sp.lanes + 1), dt, gamma, int(nsteps),
            int(stride), semi.energy_offset, *bufs)
    return trajectory(out, k, done, min_u0, blow, dt)
