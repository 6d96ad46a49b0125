"""Hilber-Hughes-Taylor (HHT-alpha) with the contact enforced exactly at t_{n+1}.

    M A1 + (1 + alpha) K U1 - alpha K U0 = F + lambda e0,   U1[0] >= 0 _|_ lambda >= 0
    U1 = U0 + dt V0 + dt^2 ((1/2 - beta) A0 + beta A1),  V1 = V0 + dt ((1 - gamma) A0 + gamma A1)

with alpha in [-1/3, 0], beta = (1 - alpha)^2 / 4, gamma = 1/2 - alpha (alpha = 0 is
Crank-Nicolson, the `standard` scheme). Displacement form: S U1 = M U~ +
beta dt^2 (F + alpha K U0 + lambda e0), S = M + (1 + alpha) beta dt^2 K factored once;
the contact uses the precomputed w = S^-1 e0 as in `schemes._newmark`. The multiplier
is not alpha-weighted (a constraint force at t_{n+1}); the sampled stress is -lambda.
Unconditionally stable for the linear problem; numerical damping of the high
frequencies grows with |alpha|.

Energy (kinetic + strain + load potential, sampled): with a massless contact node it
is dissipated (alpha < 0). With a massive contact node the exact contact at t_{n+1}
is an inelastic shock of that node, as in `standard`, and the energy grows at impacts
despite the damping: declared "may grow".
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bench.fem import MASS_KINDS, MASSLESS_KINDS
from bench.params import Param
from bench.plugin import Scheme, Semidiscrete, Traits, Trajectory
from schemes._common import (
    allocate,
    blown_up,
    energy_of,
    factor_pt,
    initial_acceleration,
    is_sample,
    pt_solve,
    record_sample,
    trajectory,
    tri_matvec,
)
from schemes.redistributed import massless_drift_bound


@njit(cache=True)
def hht_kernel(Md, Me, Kd, Ke, F, Sd, Se, w, U, V, A, dt, alpha, beta, gamma, massless,
               nsteps, stride, offset, t_out, U_out, V_out, cu_out, s_out, E_out):
    """Advance (U, V, A) in place; returns (samples, steps, min u0, blow-up step)."""
    n = U.size
    Ut = np.empty(n)
    rhs = np.empty(n)
    KU = np.empty(n)
    U1 = np.empty(n)
    A1 = np.empty(n)
    bdt2 = beta * dt * dt
    E0 = energy_of(Md, Me, Kd, Ke, F, U, V, offset)
    min_u0 = U[0]
    t_out[0] = 0.0
    U_out[0, :] = U
    V_out[0, :] = V
    cu_out[0] = U[0]
    s_out[0] = 0.0
    E_out[0] = E0
    k = 1
    for step in range(1, nsteps + 1):
        for i in range(n):
            Ut[i] = U[i] + dt * V[i] + (0.5 - beta) * dt * dt * A[i]
        tri_matvec(Md, Me, Ut, rhs)
        tri_matvec(Kd, Ke, U, KU)
        for i in range(n):
            rhs[i] += bdt2 * (F[i] + alpha * KU[i])
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
            record_sample(k, step * dt, U, V, -lam, energy,
                          t_out, U_out, V_out, cu_out, s_out, E_out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1


class HHT(Scheme):
    name = "hht"
    summary = "Hilber-Hughes-Taylor alpha (dissipative Newmark family), exact contact"
    params = {
        "alpha": Param(-0.1, "HHT alpha: beta = (1-alpha)^2/4, gamma = 1/2 - alpha",
                       low=-1.0 / 3.0, high=0.0),
        "mass": Param("seed", "mass matrix (bench.fem); seed: the paper's M^mod",
                      choices=MASS_KINDS),
    }

    @property
    def beta(self) -> float:
        return (1.0 - self.alpha) ** 2 / 4.0

    @property
    def gamma(self) -> float:
        return 0.5 - self.alpha

    def mass_kind(self) -> str:
        return self.mass

    def traits(self) -> Traits:
        massless = self.mass in MASSLESS_KINDS
        return Traits(implicit=True, massless_contact_node=massless, contact="exact",
                      energy="dissipated" if massless and self.alpha < 0 else
                      ("conserved" if massless else "may grow"),
                      order=2)

    def stability_limit(self, h: float, c: float) -> float | None:
        return None

    def energy_drift_bound(self, semi: Semidiscrete, dt: float) -> float | None:
        return massless_drift_bound(semi, dt) if self.mass in MASSLESS_KINDS else None

    def integrate(self, semi: Semidiscrete, dt: float, nsteps: int, stride: int) -> Trajectory:
        M, K = semi.M, semi.K
        dt = float(dt)
        beta, gamma, alpha = self.beta, self.gamma, float(self.alpha)
        s = (1.0 + alpha) * beta * dt * dt
        Sd, Se = factor_pt(M.diag + s * K.diag, M.off + s * K.off)
        w = np.zeros(semi.nfree)
        w[0] = 1.0
        pt_solve(Sd, Se, w)
        U, V = semi.U0.copy(), semi.V0.copy()
        A = initial_acceleration(semi)
        out = allocate(semi, nsteps, stride)
        k, done, min_u0, blow = hht_kernel(
            M.diag, M.off, K.diag, K.off, semi.F, Sd, Se, w, U, V, A, dt, alpha, beta, gamma,
            bool(semi.massless), int(nsteps), int(stride), semi.energy_offset,
            out["t"], out["U"], out["V"], out["cu"], out["s"], out["E"])
        return trajectory(out, k, done, min_u0, blow, dt)
