"""The midpoint rule with energy-conserving contact: Laursen-Chawla and Laursen-Love.

Shared by `schemes/laursen_chawla.py` and `schemes/laursen_love.py`, on every problem
form (the bar's `BarProblem` through its CSR matrices, a body's `SparseProblem`). The
step is the implicit midpoint rule with the obstacle's force lambda acting at the
midpoint,

    M (V1 - V0) / dt + K (U0 + U1) / 2 = F + C^T lambda,    U1 - U0 = dt (V0 + V1) / 2,

in displacement form S U1 = M (U0 + dt V0) + dt^2 / 4 (2 F - K U0) + C^T mu with
S = M + dt^2 / 4 K factored once and mu = dt^2 / 2 lambda (C picks the contact dofs).
Its energy E = 1/2 V.M.V + 1/2 U.K.U - F.U changes by exactly lambda . (g1 - g0) over a
step (g the gaps): the contact condition decides the energy.

The contact-free solution X_f is corrected by X = X_f + Z mu through the Delassus matrix
W = C S^-1 C^T, with the linear complementarity solver of the Newmark stepper
(`contact_bench.kernels.sparse`: `lcp_solve`, `correct`, `delassus`):

* `PERSISTENCY` (Laursen, Chawla 1997): on the contact dofs closed at t_n (g0 <= tol)
  the discrete persistency condition: Dg = g1 - g0 >= 0, lambda >= 0, lambda . Dg = 0
  (an LCP on the gap increments); the others are free (lambda = 0). lambda . Dg = 0:
  the energy is conserved to round-off; a dof that arrives in a step penetrates by at
  most the step's travel dt |v| and is held there while it pushes.
* `SIGNORINI_VELOCITY_UPDATE` (Laursen, Love 2002): exact Signorini at t_{n+1} (g1 >= 0,
  lambda >= 0, lambda . g1 = 0), which loses D = lambda . g0 >= 0 of energy in a step
  where a dof arrives (g0 > 0; a dof within the LCP's round-off tolerance of the
  obstacle counts as in contact: no update for a round-off loss); then a velocity
  update V1 += s M^-1 C^T lambda (an impulse along the step's contact force) restores
  it: s is the root s >= 0 of 1/2 s^2 lambda.D_M.lambda + s lambda.(C V1) = D,
  D_M = C M^-1 C^T (M factored once): the obstacle's impulse s lambda only pushes.
  When the contact dofs already leave (lambda.(C V1) > 0) it is the small root; when
  they still approach it is the one that turns their velocity along lambda around.

Per step the statistics of `contact_bench.kernels.recording` (the LL impulse counted in
the step's force: lambda + s lambda / dt).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit

from contact_bench.api.sparse import SparseProblem
from contact_bench.core.contact_stats import impulse_update, stats_update
from contact_bench.kernels.csr import csr_arrays, csr_matvec
from contact_bench.kernels.recording import csr_energy, smallest_gap, write_sample
from contact_bench.kernels.sparse import (
    Factor,
    contact_operators,
    correct,
    delassus,
    lcp_solve,
    lu_solve,
)
from contact_bench.kernels.stepper import KernelStepper

#: Laursen-Chawla: the persistency condition on the dofs closed at t_n
PERSISTENCY = 0
#: Laursen-Love: exact Signorini at t_{n+1}, then the energy-restoring velocity update
SIGNORINI_VELOCITY_UPDATE = 1
MODES = (PERSISTENCY, SIGNORINI_VELOCITY_UPDATE)


@njit(cache=True)
def _midpoint_kernel(Mp, Mi, Mx, Kp, Ki, Kx, F, fac, cd, gap0, weights, W, Z, keep_z,
                     mfac, Y, keep_y, U, V, dt, mode, nsteps, stride, offset,
                     t_out, U_out, V_out, cu_out, s_out, E_out, stats,
                     tol):  # pragma: no cover - compiled
    Lp, Li, Lx, Up, Ui, Ux, pr, pc = fac
    n = U.size
    nc = cd.size
    q = 0.25 * dt * dt
    to_force = 2.0 / (dt * dt)
    rhs = np.empty(n)
    X = np.empty(n)
    w = np.empty(n)
    work = np.empty(n)
    y = np.empty(n)
    mu = np.zeros(nc)
    lam = np.zeros(nc)
    push = np.zeros(nc)  # the step's force for the statistics (LL: with the update)
    qg = np.empty(nc)
    active = np.zeros(nc, np.bool_)
    status = np.zeros(nc, np.bool_)
    area = weights.sum()
    E0 = E_out[0]
    min_gap = smallest_gap(gap0, U, cd)
    was = False
    k = 1
    for step in range(1, nsteps + 1):
        for i in range(n):
            w[i] = U[i] + dt * V[i]
        csr_matvec(Mp, Mi, Mx, w, rhs)
        csr_matvec(Kp, Ki, Kx, U, w)
        for i in range(n):
            rhs[i] += q * (2.0 * F[i] - w[i])
        lu_solve(Lp, Li, Lx, Up, Ui, Ux, pr, pc, rhs, X, work)
        pen = False
        for j in range(nc):
            d = cd[j]
            if mode == PERSISTENCY:  # the increment on the dofs closed at t_n, else free
                qg[j] = X[d] - U[d] if gap0[j] + U[d] <= tol else np.inf
            else:  # the gap at t_{n+1}
                qg[j] = gap0[j] + X[d]
            pen = pen or qg[j] < 0.0
        if pen:
            for j in range(nc):
                active[j] = active[j] and qg[j] < np.inf  # a free dof is never active
            lcp_solve(W, qg, mu, active, tol, was)
            correct(fac, cd, Z, keep_z, mu, X, rhs, w, work)
            for j in range(nc):
                if active[j]:  # exactly: no increment (persistency), or gap 0 (Signorini)
                    X[cd[j]] = U[cd[j]] if mode == PERSISTENCY else -gap0[j]
        else:
            mu[:] = 0.0
        was = pen
        loss = 0.0  # lambda . (g0 - g1): the energy the contact took this step
        for j in range(nc):
            lam[j] = to_force * mu[j]
            if gap0[j] + U[cd[j]] > tol:  # arrived from an open gap (beyond round-off)
                loss += lam[j] * (U[cd[j]] - X[cd[j]])
        for i in range(n):
            V[i] = (X[i] - U[i]) * (2.0 / dt) - V[i]
            U[i] = X[i]
        for j in range(nc):
            push[j] = lam[j]
        if mode == SIGNORINI_VELOCITY_UPDATE and loss > 0.0:
            # y = M^-1 C^T lambda; a = 1/2 lambda.D_M.lambda; b = lambda.(C V1)
            if keep_y:
                for i in range(n):
                    acc = 0.0
                    for j in range(nc):
                        acc += Y[i, j] * lam[j]
                    y[i] = acc
            else:
                rhs[:] = 0.0
                for j in range(nc):
                    rhs[cd[j]] = lam[j]
                lu_solve(mfac[0], mfac[1], mfac[2], mfac[3], mfac[4], mfac[5], mfac[6],
                         mfac[7], rhs, y, work)
            a = 0.0
            b = 0.0
            for j in range(nc):
                a += 0.5 * lam[j] * y[cd[j]]
                b += lam[j] * V[cd[j]]
            if a > 0.0:
                # the root s >= 0: the obstacle's impulse pushes (lambda >= 0)
                root = np.sqrt(b * b + 4.0 * a * loss)
                s = 2.0 * loss / (b + root) if b > 0.0 else (root - b) / (2.0 * a)
                for i in range(n):
                    V[i] += s * y[i]
                for j in range(nc):
                    push[j] += s * lam[j] / dt
        stats_update(stats, status, push, step, dt)
        impulse_update(stats, push, dt, 1.0)
        min_gap = smallest_gap(gap0, U, cd, min_gap)
        if step % stride == 0 or step == nsteps:
            e = csr_energy(Mp, Mi, Mx, Kp, Ki, Kx, F, U, V, offset, w)
            blown = write_sample(k, step * dt, U, V, gap0, cd, -lam.sum() / area, e, E0,
                                 t_out, U_out, V_out, cu_out, s_out, E_out, stats)
            k += 1
            if blown:
                return k, step, min_gap, step
    return k, nsteps, min_gap, -1


class MidpointContactStepper(KernelStepper):
    """The midpoint step with the contact condition `mode` (module docstring) prepared:
    S = M + dt^2 / 4 K factored with its Delassus matrix and, for the velocity update,
    M factored (M^-1 C^T kept when Z is). ValueError for a mass with massless dofs (the midpoint
    velocity and the update's M^-1 need inertia on every dof)."""

    def __init__(self, p: SparseProblem, dt: float, mode: int) -> None:
        if mode not in MODES:
            raise ValueError(f"mode = {mode!r}: not one of {MODES}")
        if np.any(p.massless):
            raise ValueError("the midpoint contact step needs a mass on every dof "
                             "(no massless dofs)")
        super().__init__(p, dt)
        dt = self.dt
        n = p.nfree
        cd = np.asarray(p.contact.dofs, np.int64)
        fac = Factor.of(p.M + (0.25 * dt * dt) * p.K)
        Z, W, keep_z = contact_operators(fac, cd, n)
        keep_y = mode == SIGNORINI_VELOCITY_UPDATE and keep_z
        Y, marrays = np.zeros((1, 1)), fac.arrays
        if mode == SIGNORINI_VELOCITY_UPDATE:  # M^-1 C^T kept, or a solve per update
            mfac = Factor.of(sp.csr_matrix(p.M))
            marrays = mfac.arrays
            if keep_y:
                Y = delassus(mfac, cd, n)[0]
        self.kernel = _midpoint_kernel
        self.state = (p.U0.astype(float).copy(), p.V0.astype(float).copy())
        self.operators = (*csr_arrays(p.M), *csr_arrays(p.K), np.asarray(p.F, float),
                          fac.arrays, cd, np.asarray(p.contact.gap0, float),
                          np.asarray(p.contact.weights, float), W, np.ascontiguousarray(Z),
                          keep_z, marrays, np.ascontiguousarray(Y), keep_y)
        self.params = (dt, int(mode))
        self.tail = (1e-13 * max(float(np.max(np.abs(p.U0))),
                                 float(np.max(np.abs(p.contact.gap0), initial=0.0)), 1e-300),)


def prepare_midpoint_contact(p: SparseProblem, dt: float, mode: int) -> MidpointContactStepper:
    """The midpoint rule with Laursen-Chawla's persistency (`PERSISTENCY`) or Laursen-Love's
    exact contact and velocity update (`SIGNORINI_VELOCITY_UPDATE`) on a problem of the
    general form (module docstring)."""
    return MidpointContactStepper(p, dt, mode)
