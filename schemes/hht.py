"""Hilber-Hughes-Taylor (HHT-alpha) with the contact enforced exactly at t_{n+1}.

    M A1 + (1 + alpha) K U1 - alpha K U0 = F + lambda e0,   U1[0] >= 0 _|_ lambda >= 0
    U1 = U0 + dt V0 + dt^2 ((1/2 - beta) A0 + beta A1),  V1 = V0 + dt ((1 - gamma) A0 + gamma A1)

with alpha in [-1/3, 0], beta = (1 - alpha)^2 / 4, gamma = 1/2 - alpha (alpha = 0 is
Crank-Nicolson, the `standard` scheme). S = M + (1 + alpha) beta dt^2 K is factored
once and the contact uses w = S^-1 e0 as in `contact_bench.kernels.newmark`; the
sampled stress is -lambda. Unconditionally stable for the linear problem, with
numerical damping of the high frequencies that grows with |alpha|.

Energy: dissipated with a massless contact node (the default mass); with a massive one
the exact contact at t_{n+1} is an inelastic shock of that node, as in `standard`, and
the energy may grow at impacts despite the damping.

On the general sparse problem the same step with exact contact on every contact dof
through the Delassus matrix (`contact_bench.kernels.sparse.newmark_sparse` with
`alpha`); the redistributed masses map to the scene's massless contact dofs.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from contact_bench.api.fem import MASS_ALIASES, MASS_KINDS, MASSLESS_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import (
    CallStepper,
    Contact,
    Energy,
    Scheme,
    Stepper,
    Traits,
    Trajectory,
)
from contact_bench.api.problem import banded
from contact_bench.core.sampling import blown_up, energy_rows, is_sample, record_sample, row_sums
from contact_bench.core.tridiag import factor_pt, newmark_update, pt_backward, pt_solve
from contact_bench.kernels.common import (
    allocate,
    initial_acceleration,
    massless_drift_bound,
    trajectory,
)
from contact_bench.kernels.sparse import newmark_sparse


class HHT(Scheme):
    name = "hht"
    summary = "Hilber-Hughes-Taylor alpha (dissipative Newmark family), exact contact"
    params = {
        "alpha": Param(-0.1, "HHT alpha: beta = (1-alpha)^2/4, gamma = 1/2 - alpha",
                       low=-1.0 / 3.0, high=0.0),
        "mass": Param("first_element_massless", "mass matrix (contact_bench.api.fem)",
                      choices=MASS_KINDS, aliases=MASS_ALIASES),
    }

    @property
    def beta(self) -> float:
        return (1.0 - self.alpha) ** 2 / 4.0

    @property
    def gamma(self) -> float:
        return 0.5 - self.alpha

    def mass_kind(self) -> str:
        return self.mass

    def traits(self, problem=None) -> Traits:
        massless = self.mass in MASSLESS_KINDS
        return Traits(implicit=True, massless_contact_node=massless, contact=Contact.EXACT,
                      energy=Energy.DISSIPATED if massless and self.alpha < 0 else
                      (Energy.CONSERVED if massless else Energy.MAY_GROW),
                      order=2)

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        semi = banded(problem)
        return (massless_drift_bound(semi, dt)
                if self.mass in MASSLESS_KINDS and semi is not None else None)

    def prepare(self, problem, dt: float) -> Stepper:
        # a body: `contact_bench.kernels.sparse.newmark_sparse` with alpha
        semi = banded(problem)
        if semi is not None:
            return CallStepper(lambda n, s: self.run_bar(semi, dt, n, s))
        return CallStepper(lambda n, s: newmark_sparse(problem, dt, n, s, self.beta, self.gamma,
                                                       alpha=float(self.alpha)))

    def run_bar(self, semi, dt: float, nsteps: int, stride: int) -> Trajectory:
        """The bar's HHT step on the tridiagonal bands (`hht_kernel`)."""
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



@njit(cache=True)
def hht_kernel(Md, Me, Kd, Ke, F, Sd, Se, w, U, V, A, dt, alpha, beta, gamma, massless,
               nsteps, stride, offset, t_out, U_out, V_out, cu_out, s_out, E_out):
    """Advance (U, V, A) in place; returns (samples, steps, min u0, blow-up step).

    Three passes over the nodes per step, with the operations of the plain algorithm
    (module docstring; `tri_matvec`, `pt_solve`) in the same order, so the same bits:
    up, the predictor, the right-hand side and the forward sweep; down, the backward
    sweep; up, the contact and the Newmark update. The first and last rows are written
    apart rather than by `tri_row` in one loop, which was slower here (how this layout
    was chosen, with timings: docs/performance.md)."""
    n = U.size
    Ut = np.empty(n)
    rhs = np.empty(n)
    bdt2 = beta * dt * dt
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    E0 = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
    min_u0 = U[0]
    t_out[0] = 0.0
    U_out[0, :] = U
    V_out[0, :] = V
    cu_out[0] = U[0]
    s_out[0] = 0.0
    E_out[0] = E0
    k = 1
    c2 = (0.5 - beta) * dt * dt
    for step in range(1, nsteps + 1):
        # pass 1 (up): predictor, right-hand side M Ut + bdt2 (F + alpha K U) (rows as
        # in `tri_matvec`) and the forward sweep of `pt_solve`, the same operations
        cur = U[0] + dt * V[0] + c2 * A[0]
        Ut[0] = cur
        if n == 1:
            y = Md[0] * cur + bdt2 * (F[0] + alpha * (Kd[0] * U[0]))
            rhs[0] = y / Sd[0]
        else:
            nxt = U[1] + dt * V[1] + c2 * A[1]
            r = Md[0] * cur + Me[0] * nxt
            r += bdt2 * (F[0] + alpha * (Kd[0] * U[0] + Ke[0] * U[1]))
            y = r
            rhs[0] = y / Sd[0]
            for i in range(1, n - 1):
                prev, cur = cur, nxt
                Ut[i] = cur
                nxt = U[i + 1] + dt * V[i + 1] + c2 * A[i + 1]
                r = (Md[i] * cur + Me[i - 1] * prev) + Me[i] * nxt
                ku = (Kd[i] * U[i] + Ke[i - 1] * U[i - 1]) + Ke[i] * U[i + 1]
                r += bdt2 * (F[i] + alpha * ku)
                y = r - Se[i - 1] * y
                rhs[i] = y / Sd[i]
            j = n - 1
            Ut[j] = nxt
            r = Md[j] * nxt + Me[j - 1] * cur
            r += bdt2 * (F[j] + alpha * (Kd[j] * U[j] + Ke[j - 1] * U[j - 1]))
            y = r - Se[j - 1] * y
            rhs[j] = y / Sd[j]
        # pass 2 (down): the backward sweep
        pt_backward(Se, rhs)
        # pass 3 (up): contact, Newmark update
        mu = 0.0
        if rhs[0] < 0.0:
            mu = -rhs[0] / w[0]
        lam = mu / bdt2
        newmark_update(rhs, mu, w, mu != 0.0, Ut, U, V, A, dt, bdt2, gamma, massless)
        if U[0] < min_u0:
            min_u0 = U[0]
        if is_sample(step, nsteps, stride):
            energy = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
            record_sample(k, step * dt, U, V, -lam, energy,
                          t_out, U_out, V_out, cu_out, s_out, E_out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1
