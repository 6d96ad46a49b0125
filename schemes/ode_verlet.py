"""The redistributed problem as the seed's Lipschitz ODE (P_U^mod), Stormer-Verlet steps.

With a massless contact node the semi-discrete problem is the ODE of the seed (Dabaghi,
Petrov, Pousin, Renard 2014, section 4) in the other nodes U_bar:

    M_bar U_bar'' + K_bar U_bar = F_bar - C u0(U_bar),  u0 = max(0, (F0 - K01 u1) / K00),

a Lipschitz right-hand side, so any ODE integrator applies (Hairer, Lubich, Wanner,
Geometric Numerical Integration, for Stormer-Verlet). Here: velocity Verlet with a
fixed step, V += dt/2 A(U); U += dt V; V += dt/2 A(U), one solve with M_bar per step
(factored once). The contact node is not a state: u0 = u0(u1) at every step, and its
velocity is the exact derivative of that function, v0 = -(K01 / K00) v1 while u0 > 0,
else 0. The initial state is the ODE's: u0 is set to u0(u1) at t = 0 (the interpolant's
first element is relaxed: on clamped_bar E(0) = 1/8 - h/8, see `redistributed`).

This is algebraically the same update as `redistributed[beta=0]` (explicit Newmark is
velocity Verlet), written from the ODE; tests/test_schemes_extra.py checks that both
agree and converge to the exact solution. `variant` picks the redistributed mass as in
`redistributed` (seed, getfem, conservative).

Declared: explicit; stability limit of the central difference with a consistent-type
mass, h / (c sqrt 3); contact exact (u0 >= 0 by construction); energy "conserved": the
ODE conserves it (seed, Lemma 4.2) and Verlet is symplectic, but the force has a kink
at contact switches, so the discrete energy moves by O(dt^2) there: declared drift
bound 2 (c dt / h)^2 (measured 2.1e-3 on clamped_bar at nx = 80, dt = 0.005, where the
bound is 0.32, and 8.9e-4 on dropped_bar at nx = 100, dt = 0.0017). Order 2 (checked
against DOP853 in tests/test_schemes_extra.py).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bench.params import Param
from bench.plugin import Scheme, Semidiscrete, Traits, Trajectory
from schemes._common import (
    allocate,
    blown_up,
    eliminate_contact_node,
    energy_of,
    factor_pt,
    is_sample,
    pt_solve,
    record_sample,
    trajectory,
    tri_matvec,
)
from schemes._newmark import newmark_limit


@njit(cache=True)
def ode_acceleration(Kd, Ke, F, Sd, Se, U, A, KU):
    """u0 <- u0(u1); A[1:] = M_bar^{-1} (F - K U)[1:], A[0] = 0; returns lambda."""
    lam = eliminate_contact_node(Kd, Ke, F, U)
    tri_matvec(Kd, Ke, U, KU)
    for i in range(U.size):
        A[i] = F[i] - KU[i]
    pt_solve(Sd, Se, A[1:])
    A[0] = 0.0
    return lam


@njit(cache=True)
def contact_node_velocity(Kd, Ke, U, V):
    V[0] = -(Ke[0] / Kd[0]) * V[1] if U[0] > 0.0 else 0.0


@njit(cache=True)
def verlet_kernel(Md, Me, Kd, Ke, F, Sd, Se, U, V, dt, nsteps, stride, offset,
                  t_out, U_out, V_out, cu_out, s_out, E_out):
    """Velocity Verlet on (P_U^mod); returns (samples, steps, min u0, blow-up step)."""
    n = U.size
    A = np.empty(n)
    KU = np.empty(n)
    lam = ode_acceleration(Kd, Ke, F, Sd, Se, U, A, KU)
    contact_node_velocity(Kd, Ke, U, V)
    min_u0 = U[0]
    E0 = energy_of(Md, Me, Kd, Ke, F, U, V, offset)
    t_out[0] = 0.0
    U_out[0, :] = U
    V_out[0, :] = V
    cu_out[0] = U[0]
    s_out[0] = -lam
    E_out[0] = E0
    k = 1
    for step in range(1, nsteps + 1):
        for i in range(1, n):
            V[i] += 0.5 * dt * A[i]
            U[i] += dt * V[i]
        lam = ode_acceleration(Kd, Ke, F, Sd, Se, U, A, KU)
        for i in range(1, n):
            V[i] += 0.5 * dt * A[i]
        contact_node_velocity(Kd, Ke, U, V)
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


class OdeVerlet(Scheme):
    name = "ode_verlet"
    summary = "the seed's Lipschitz ODE (P_U^mod) by Stormer-Verlet, fixed step"
    params = {
        "variant": Param("seed", "where the first element's mass goes",
                         choices=("seed", "getfem", "conservative")),
    }

    def mass_kind(self) -> str:
        return self.variant

    def traits(self) -> Traits:
        return Traits(implicit=False, massless_contact_node=True, contact="exact",
                      energy="conserved", order=2)

    def stability_limit(self, h: float, c: float) -> float | None:
        return newmark_limit(0.0, 0.5, h, c, lumped=False)

    def energy_drift_bound(self, semi: Semidiscrete, dt: float) -> float | None:
        return 2.0 * (semi.c_max * dt / semi.hmin) ** 2

    def integrate(self, semi: Semidiscrete, dt: float, nsteps: int, stride: int) -> Trajectory:
        M, K = semi.M, semi.K
        Sd, Se = factor_pt(M.diag[1:], M.off[1:])
        U, V = semi.U0.copy(), semi.V0.copy()
        out = allocate(semi, nsteps, stride)
        k, done, min_u0, blow = verlet_kernel(
            M.diag, M.off, K.diag, K.off, semi.F, Sd, Se, U, V, float(dt), int(nsteps),
            int(stride), semi.energy_offset,
            out["t"], out["U"], out["V"], out["cu"], out["s"], out["E"],
        )
        return trajectory(out, k, done, min_u0, blow, dt)
