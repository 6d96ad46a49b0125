"""A plain scipy reference of the Newmark exact-contact step (schemes declaring
`Scheme.newmark_parameters`: the built-in `standard` and `redistributed`).

The same algorithm as `contact_bench.kernels.newmark`, written the obvious way: the system matrix is
factorised once with `scipy.sparse.linalg.splu` and each step does one solve in Python.
It exists to check the numba kernels (tests/test_reference.py) and to measure their
speedup (benchmarks/). Nothing here is tuned.

Implicit (beta > 0), displacement form: S U1 = M U~ + beta dt^2 F with S = M + beta dt^2 K
and U~ = U + dt V + (1/2 - beta) dt^2 A. If U1[0] < 0 the contact adds mu w, w = S^-1 e0,
mu = -U1[0] / w[0] (the obstacle's force is mu / (beta dt^2), the stress its negative).
Explicit (beta = 0, massless contact node only): nodes 1.. by central differences, then
u0 = max(0, (F0 - K01 u1) / K00) and M_r A1 = F - K U1 on nodes 1... A massless contact
node's velocity is the backward difference (u0^{n+1} - u0^n) / dt and its acceleration 0.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as spla

from contact_bench.api.plugin import Scheme, Semidiscrete, Trajectory
from contact_bench.core.sampling import blown_up, n_samples


def _energy(semi: Semidiscrete, U: np.ndarray, V: np.ndarray) -> float:
    return float(0.5 * semi.M.quad(V) + 0.5 * semi.K.quad(U) - semi.F @ U
                 + semi.energy_offset)


def reference_newmark(semi: Semidiscrete, dt: float, nsteps: int, stride: int,
                      beta: float, gamma: float) -> Trajectory:
    """Newmark(beta, gamma) with exact contact at node 0, one sparse LU solve per step."""
    M, K, F = semi.M, semi.K, semi.F
    n = semi.nfree
    U, V = semi.U0.copy(), semi.V0.copy()
    first = 1 if semi.massless else 0
    A = np.zeros(n)
    A[first:] = spla.splu(M.to_sparse().tocsc()[first:, first:]).solve(
        (F - K.matvec(U))[first:])
    bdt2 = beta * dt * dt
    if beta > 0.0:
        lu = spla.splu((M.to_sparse() + bdt2 * K.to_sparse()).tocsc())
        e0 = np.zeros(n)
        e0[0] = 1.0
        w = lu.solve(e0)
    else:
        if not semi.massless:
            raise ValueError("explicit Newmark (beta = 0) needs a massless contact node")
        lu = spla.splu(M.to_sparse().tocsc()[1:, 1:])
    k_max = n_samples(nsteps, stride)
    t_out, cu, s_out, E_out = (np.zeros(k_max) for _ in range(4))
    U_out, V_out = np.zeros((k_max, n)), np.zeros((k_max, n))
    E0 = _energy(semi, U, V)
    U_out[0], V_out[0], cu[0], E_out[0] = U, V, U[0], E0
    k, min_u0, blowup = 1, U[0], None
    done = nsteps
    for step in range(1, nsteps + 1):
        if beta > 0.0:
            Ut = U + dt * V + (0.5 - beta) * dt * dt * A
            U1 = lu.solve(M.matvec(Ut) + bdt2 * F)
            mu = -U1[0] / w[0] if U1[0] < 0.0 else 0.0
            if mu != 0.0:
                U1 = U1 + mu * w
                U1[0] = 0.0
            lam = mu / bdt2
            A1 = (U1 - Ut) / bdt2
        else:
            U1 = U + dt * V + 0.5 * dt * dt * A
            U1[0] = max(0.0, (F[0] - K.off[0] * U1[1]) / K.diag[0])
            r = F - K.matvec(U1)
            lam = -r[0]
            A1 = np.zeros(n)
            A1[1:] = lu.solve(r[1:])
        V = V + dt * ((1.0 - gamma) * A + gamma * A1)
        if semi.massless:
            V[0] = (U1[0] - U[0]) / dt
            A1[0] = 0.0
        U, A = U1, A1
        min_u0 = min(min_u0, U[0])
        if step % stride == 0 or step == nsteps:
            energy = _energy(semi, U, V)
            t_out[k], U_out[k], V_out[k] = step * dt, U, V
            cu[k], s_out[k], E_out[k] = U[0], -lam, energy
            k += 1
            if blown_up(energy, E0):
                blowup, done = step * dt, step
                break
    return Trajectory(t=t_out[:k], U=U_out[:k], V=V_out[:k], contact_u=cu[:k],
                      stress=s_out[:k], energy=E_out[:k], min_contact_u=float(min_u0),
                      steps_done=done, blowup_time=blowup)


def reference_for(scheme: Scheme, semi: Semidiscrete, dt: float, nsteps: int,
                  stride: int) -> Trajectory:
    """The reference run of a scheme declaring `Scheme.newmark_parameters` (the plain
    Newmark method with exact contact)."""
    params = scheme.newmark_parameters()
    if params is None:
        raise ValueError(f"no scipy reference for scheme {scheme.name!r}: it declares no "
                         "newmark_parameters()")
    beta, gamma = params
    return reference_newmark(semi, dt, nsteps, stride, beta, gamma)
