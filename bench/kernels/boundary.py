"""Newmark(beta, gamma) with a piecewise-linear contact force on the first element.

Shared by `penalty` and `nitsche`. The internal force is K' U + c min(0, p.U) q with
K' = K + (a symmetric change of the first element's 2 x 2 block), and p, q supported
on nodes 0 and 1:

- penalty:  K' = K, c = kappa, p = q = e0            (force kappa min(0, u0) on node 0)
- Nitsche:  K' = K - (theta / gam) s s^T, c = 1 / gam, p = gam e0 + s, q = gam e0 + theta s,
            with s.U = E (u1 - u0) / h = E u_x(0) and gam = gamma0 E / h.

Implicit (beta > 0): S U1 + beta dt^2 c min(0, p.U1) q = M U~ + beta dt^2 F with
S = M + beta dt^2 K' factored once. The step is piecewise linear in the scalar p.U1,
so it is solved exactly: U_f = S^-1 (M U~ + beta dt^2 F); if p.U_f < 0 then
p.U1 = p.U_f / (1 + beta dt^2 c p.w) and U1 = U_f - beta dt^2 c (p.U1) w with the
precomputed w = S^-1 q (Sherman-Morrison; no second factorisation, no second solve).

Explicit (beta = 0): A1 = M^-1 (F - K' U1 - c min(0, p.U1) q) with M factored once
(lumped: diagonal). With a massless contact node, u0 solves its own row exactly
(two linear branches, one node), the other nodes are advanced explicitly.

Sampled energy: 1/2 V.M.V + 1/2 U.K'.U - F.U + offset + ew c/2 min(0, p.U)^2 (ew = 1
for the penalty; for Nitsche ew = theta, Chouly-Hild-Renard's E_theta). Sampled
stress: sc min(0, p.U) (penalty: sc = kappa; Nitsche: sc = 1, the Nitsche stress).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit

from contact_bench.api.plugin import Semidiscrete, Trajectory
from contact_bench.core.sampling import blown_up, energy_rows, is_sample, record_sample, row_sums
from contact_bench.core.tridiag import (
    Bar,
    BarState,
    Implicit,
    NewmarkCoef,
    factor_pt,
    newmark_update,
    pt_backward,
    pt_solve,
    tri_matvec,
    tri_row,
)
from contact_bench.kernels.common import allocate, run_spec, trajectory
from contact_bench.kernels.sparse import ContactLaw


class BoundaryLaw(NamedTuple):
    """A boundary force on the bar's first element: y = p0 u0 + p1 u1, the force -c min(0,
    y) (q0, q1) on nodes 0 and 1; its energy 1/2 ew c min(0, y)^2, its stress sc min(0, y)."""

    c: float
    p0: float
    p1: float
    q0: float
    q1: float
    ew: float
    sc: float


@njit(cache=True)
def boundary_kernel(bar, S, law, state, coef, run, out):
    """Advance the `BarState` (U, V, A) in place; returns (samples, steps, min u0, blow-up
    step). bar: the `Bar` (K with the law's change of the first block); S: the `Implicit`
    system M + beta dt^2 K with w = S^-1 (q0, q1, 0, ...) (beta = 0: M's factors, on nodes
    1.. if the contact node is massless); law: the `BoundaryLaw`; coef: the `NewmarkCoef`;
    run: the `Run`; out: the `Samples`.

    Implicit: three passes over the nodes per step (up: predictor, right-hand side and
    forward sweep; down: backward sweep; up: contact force and update), with the
    operations of the plain algorithm (`tri_matvec`, `pt_solve`) in the same order:
    the same bits."""
    Md, Me, Kd, Ke, F = bar
    Sd, Se, w = S
    c, p0, p1, q0, q1, ew, sc = law
    U, V, A = state
    beta, gamma, massless = coef
    dt, nsteps, stride, offset = run
    n = U.size
    Ut = np.empty(n)
    rhs = np.empty(n)
    U1 = np.empty(n)
    A1 = np.empty(n)
    bdt2 = beta * dt * dt
    P = p0 * U[0] + p1 * U[1]
    neg = min(P, 0.0)
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    E0 = energy_rows(rM, Me, rK, Ke, F, U, V, offset) + 0.5 * ew * c * neg * neg
    min_u0 = U[0]
    record_sample(0, 0.0, U, V, sc * neg, E0, out)
    k = 1
    pw = p0 * w[0] + p1 * w[1] if beta > 0.0 else 0.0
    c2 = (0.5 - beta) * dt * dt
    for step in range(1, nsteps + 1):
        if beta > 0.0:
            # up: predictor, M U~ + beta dt^2 F row by row, forward sweep of `pt_solve`
            Ut[0] = U[0] + dt * V[0] + c2 * A[0]
            y = 0.0
            for i in range(n):
                if i + 1 < n:
                    Ut[i + 1] = U[i + 1] + dt * V[i + 1] + c2 * A[i + 1]
                r = tri_row(Md, Me, Ut, i, n) + bdt2 * F[i]
                y = r if i == 0 else r - Se[i - 1] * y
                rhs[i] = y / Sd[i]
            # down: backward sweep
            pt_backward(Se, rhs)
            P = p0 * rhs[0] + p1 * rhs[1]
            mu = 0.0
            if P < 0.0:
                denom = 1.0 + bdt2 * c * pw
                if denom <= 0.0:  # the step equation is not monotone: give up
                    return k, step, min_u0, step
                P = P / denom
                mu = -bdt2 * c * P
            # up: contact force and Newmark update
            newmark_update(rhs, mu, w, False, Ut, state, dt, coef)
        else:
            for i in range(n):
                U1[i] = U[i] + dt * V[i] + 0.5 * dt * dt * A[i]
            if massless:  # row 0: Kd0 u0 + Ke0 u1 + c min(0, p0 u0 + p1 u1) q0 = F0
                u0 = (F[0] - Ke[0] * U1[1]) / Kd[0]
                if p0 * u0 + p1 * U1[1] < 0.0:
                    u0 = (F[0] - (Ke[0] + c * q0 * p1) * U1[1]) / (Kd[0] + c * q0 * p0)
                U1[0] = u0
            P = p0 * U1[0] + p1 * U1[1]
            neg = min(P, 0.0)
            tri_matvec(Kd, Ke, U1, rhs)
            for i in range(n):
                A1[i] = F[i] - rhs[i]
            A1[0] -= c * neg * q0
            A1[1] -= c * neg * q1
            if massless:
                pt_solve(Sd, Se, A1[1:])
            else:
                pt_solve(Sd, Se, A1)
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
            neg = min(p0 * U[0] + p1 * U[1], 0.0)
            energy = energy_rows(rM, Me, rK, Ke, F, U, V, offset) + 0.5 * ew * c * neg * neg
            record_sample(k, step * dt, U, V, sc * neg, energy,
                          out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1


def run_boundary(semi: Semidiscrete, dt: float, nsteps: int, stride: int, beta: float,
                 gamma: float, dK: np.ndarray, c: float, p: tuple[float, float],
                 q: tuple[float, float], ew: float, sc: float) -> Trajectory:
    """Factor outside the loop, then call the kernel. dK: change of K's first 2 x 2 block."""
    if semi.nfree < 2:
        raise ValueError("a boundary force on the first element needs at least two free nodes")
    M = semi.M
    Kd, Ke = semi.K.diag.copy(), semi.K.off.copy()
    Kd[0] += dK[0, 0]
    Kd[1] += dK[1, 1]
    Ke[0] += dK[0, 1]
    dt, beta, gamma = float(dt), float(beta), float(gamma)
    U, V = semi.U0.copy(), semi.V0.copy()
    # initial acceleration from the full force (the contact force too, if active)
    r = semi.F.copy()
    r -= Kd * U
    r[:-1] -= Ke * U[1:]
    r[1:] -= Ke * U[:-1]
    neg = min(p[0] * U[0] + p[1] * U[1], 0.0)
    r[0] -= c * neg * q[0]
    r[1] -= c * neg * q[1]
    first = 1 if semi.massless else 0
    Md_f, Me_f = factor_pt(M.diag[first:], M.off[first:])
    A = np.zeros(semi.nfree)
    b = r[first:].copy()
    pt_solve(Md_f, Me_f, b)
    A[first:] = b
    if beta > 0.0:
        bdt2 = beta * dt * dt
        Sd, Se = factor_pt(M.diag + bdt2 * Kd, M.off + bdt2 * Ke)
        w = np.zeros(semi.nfree)
        w[0], w[1] = q
        pt_solve(Sd, Se, w)
    else:
        Sd, Se = Md_f, Me_f
        w = np.zeros(2)
    out = allocate(semi, nsteps, stride)
    law = BoundaryLaw(float(c), float(p[0]), float(p[1]), float(q[0]), float(q[1]), float(ew),
                      float(sc))
    k, done, min_u0, blow = boundary_kernel(
        Bar(M.diag, M.off, Kd, Ke, semi.F), Implicit(Sd, Se, w), law, BarState(U, V, A),
        NewmarkCoef(beta, gamma, bool(semi.massless)), run_spec(semi, dt, nsteps, stride), out)
    return trajectory(out, k, done, min_u0, blow, dt)


def element_limit(beta: float, gamma: float, h: float, c: float, mass: str,
                  extra: np.ndarray) -> float | None:
    """Stable dt of undamped Newmark (2 beta < gamma) when the first element's stiffness
    (in units of rho c^2 / h) is [[1, -1], [-1, 1]] + extra.

    omega_max^2 <= max over elements of the local generalized eigenvalues (the Rayleigh
    quotient of the assembled pair is a weighted mean of the elements' quotients), so
    with the first element's local pair (K1 + extra, M1) and the interior ones:
    dt <= 1 / (sqrt(gamma/2 - beta) omega_max). A massless contact node is eliminated
    statically: its spring in series with the element is softer than the element, and
    the limit is the interior one, h / (c sqrt 3) (consistent-type mass on node 1).
    """
    if 2.0 * beta >= gamma:
        return None
    lumped = mass == "lumped"
    m1 = np.eye(2) / 2.0 if lumped else np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0
    k1 = np.array([[1.0, -1.0], [-1.0, 1.0]])
    interior = float(np.max(np.linalg.eigvals(np.linalg.solve(m1, k1)).real))
    if mass in ("consistent", "lumped"):
        first = float(np.max(np.linalg.eigvals(np.linalg.solve(m1, k1 + extra)).real))
    else:
        first = 12.0  # massless node: see above
    omega_max = np.sqrt(max(interior, first)) * c / h
    return float(1.0 / (np.sqrt(gamma / 2.0 - beta) * omega_max))


def energy_budget(semi: Semidiscrete) -> tuple[float, float]:
    """(2 |E(0)|, g m): twice the initial energy and the weight of the bar (|sum F|).

    Used by the penetration bounds: with the discrete energy at most 2 |E(0)| and the
    gravity potential g m u >= -g m d when the bar penetrates by at most d.
    """
    U0, V0 = semi.U0, semi.V0
    e0 = 0.5 * semi.M.quad(V0) + 0.5 * semi.K.quad(U0) - semi.F @ U0 + semi.energy_offset
    return 2.0 * abs(float(e0)), abs(float(np.sum(semi.F)))


def bar_law(n: int, dK: np.ndarray, c: float, p: tuple[float, float], q: tuple[float, float],
            ew: float, sc: float, fscale: float = 1.0) -> ContactLaw:
    """A boundary force on the bar's first element as the general `ContactLaw` (the
    same object the sparse kernels take): y = p0 u0 + p1 u1, the force -c min(0, y)
    (q0, q1) on nodes 0 and 1, K's first 2 x 2 block changed by dK."""
    cols = [0, 1]
    P = sp.csr_matrix((list(p), ([0, 0], cols)), shape=(1, n))
    Q = sp.csr_matrix((list(q), ([0, 0], cols)), shape=(1, n))
    K_extra = sp.csr_matrix((np.asarray(dK, float).ravel(), ([0, 0, 1, 1], [0, 1, 0, 1])),
                            shape=(n, n))
    return ContactLaw(P=P, Q=Q, y0=np.zeros(1), c=np.array([float(c)]), ew=float(ew),
                      sc=np.array([float(sc)]), K_extra=K_extra, fscale=float(fscale))


def run_boundary_law(semi: Semidiscrete, dt: float, nsteps: int, stride: int, beta: float,
                     gamma: float, law: ContactLaw) -> Trajectory:
    """`run_boundary` with the force given as a `ContactLaw` on the bar's first element
    (`bar_law`); ValueError when the law reaches beyond nodes 0 and 1."""
    K_extra = sp.csr_matrix(law.K_extra) if law.K_extra is not None else None
    for name, A in (("P", law.P), ("Q", law.Q), ("K_extra", K_extra)):
        if A is not None and sp.csr_matrix(A)[:, 2:].nnz:
            raise ValueError(f"the bar's boundary kernel takes laws on nodes 0 and 1; {name} "
                             "reaches further")
    P, Q = sp.csr_matrix(law.P), sp.csr_matrix(law.Q)
    dK = np.zeros((2, 2)) if K_extra is None else K_extra[:2, :2].toarray()
    return run_boundary(semi, dt, nsteps, stride, beta, gamma, dK, float(law.c[0]),
                        (float(P[0, 0]), float(P[0, 1])), (float(Q[0, 0]), float(Q[0, 1])),
                        float(law.ew), float(law.sc[0]))
