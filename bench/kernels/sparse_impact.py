"""Impact laws on the general sparse problem (`contact_bench.api.sparse.SparseProblem`).

The two schemes whose contact condition is an impact law rather than a force at t_{n+1},
on many contact dofs, with the machinery of `contact_bench.kernels.sparse` (S factored
once, `lu_solve`, the Delassus matrix W = C S^-1 C^T, `lcp_solve`).

* `paoli_schatzman_sparse` (`schemes/restitution.py`): the two-step scheme

      M (U^{n+1} - 2 U^n + U^{n-1}) + dt^2 K (beta U^{n+1} + (1 - 2 beta) U^n
          + beta U^{n-1}) = dt^2 F + dt^2 C^T r^n,
      0 <= g(U^{n+1}) + e g(U^{n-1})  _|_  r^n >= 0   (g = gap0 + C U, per contact dof),

  i.e. U^{n+1} is the projection, in the metric of S = M + beta dt^2 K, of the free
  step onto {g(U) + e g(U^{n-1}) >= 0}: the LCP on W. A diagonal S (lumped mass, beta =
  0) makes W diagonal: the projection is per dof, no solve. An active dof lands on
  g = -e g(U^{n-1}) exactly. The sample at t_n is (U^n, (U^{n+1} - U^{n-1}) / 2 dt)
  with the force r^n (so the kernel runs one step past the last sample), as in 1D; with
  that centred velocity the vertical momentum obeys the trapezoid rule on the sampled
  force exactly; the impulse the kernel accumulates is that trapezoid plus dt r^0 / 2,
  the change from the data V0 of sample 0 to the centred velocity at level 0.
* `moreau_jean_sparse` (`schemes/moreau_jean.py`): the theta-method on velocities,
  S = M + theta^2 dt^2 K,

      S V^{n+1} = M V^n + dt (F - K U^n) - theta (1 - theta) dt^2 K V^n + C^T P^{n+1},
      U^{n+1} = U^n + dt (theta V^{n+1} + (1 - theta) V^n),

  with Newton's law 0 <= v_j^{n+1} + e v_j^n _|_ P_j >= 0 on the contact dofs whose
  predicted gap g_j(U^n) + dt/2 v_j^n is <= 0 (P_j = 0 on the others): the LCP on the
  rows and columns of W of that index set. P is an impulse; the per-step contact force
  (the sampled stress, the chatter and peak-force statistics) is P / dt.

Both refuse a problem with massless dofs: an impact law acts on momentum.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit

from contact_bench.api.plugin import Trajectory
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.contact_stats import (
    CONTACT_IMPULSE,
    LAST_FORCE,
    impulse_update,
    stats_update,
)
from contact_bench.kernels.csr import csr_arrays, csr_matvec
from contact_bench.kernels.recording import csr_energy, smallest_gap, write_sample
from contact_bench.kernels.sparse import (
    Factor,
    contact_operators,
    correct,
    initial_acceleration,
    lcp_solve,
    lu_solve,
)
from contact_bench.kernels.stepper import KernelStepper


@njit(cache=True)
def _ps_kernel(Mp, Mi, Mx, Kp, Ki, Kx, F, sdiag, fac, cd, gap0, weights, W, Z, keep_z,
               Um, U, beta, e, dt, nsteps, stride, offset, t_out, U_out, V_out, cu_out,
               s_out, E_out, stats, tol):  # pragma: no cover - compiled
    """Paoli-Schatzman from (U^{-1}, U^0) (module docstring); `sdiag` non-empty: S is
    that diagonal (per-dof projection), else `fac` and the LCP on W."""
    Lp, Li, Lx, Up, Ui, Ux, pr, pc = fac
    n = U.size
    nc = cd.size
    dt2 = dt * dt
    diag = sdiag.size > 0
    rhs = np.empty(n)
    tmp = np.empty(n)
    X = np.empty(n)
    w = np.empty(n)
    work = np.empty(n)
    gf = np.empty(nc)
    mu = np.zeros(nc)
    lam = np.zeros(nc)
    active = np.zeros(nc, np.bool_)
    status = np.zeros(nc, np.bool_)
    area = weights.sum()
    E0 = E_out[0]
    min_gap = smallest_gap(gap0, U, cd)
    was = False
    k = 1
    for step in range(1, nsteps + 2):
        # S X = M (2 U^n - U^{n-1}) - dt^2 K ((1 - 2 beta) U^n + beta U^{n-1}) + dt^2 F
        for i in range(n):
            tmp[i] = 2.0 * U[i] - Um[i]
        csr_matvec(Mp, Mi, Mx, tmp, rhs)
        for i in range(n):
            tmp[i] = (1.0 - 2.0 * beta) * U[i] + beta * Um[i]
        csr_matvec(Kp, Ki, Kx, tmp, w)
        for i in range(n):
            rhs[i] += dt2 * (F[i] - w[i])
        if diag:
            for i in range(n):
                X[i] = rhs[i] / sdiag[i]
        else:
            lu_solve(Lp, Li, Lx, Up, Ui, Ux, pr, pc, rhs, X, work)
        pen = False
        finite = True
        for j in range(nc):  # the constrained combination g(X) + e g(U^{n-1})
            gf[j] = gap0[j] + X[cd[j]] + e * (gap0[j] + Um[cd[j]])
            pen = pen or gf[j] < 0.0
            finite = finite and np.isfinite(gf[j])
        if not finite:  # blown up between samples: no contact problem to solve
            return k, step - 1, min_gap, step - 1
        if pen:
            if diag:  # W = diag(1 / s): the projection dof by dof
                for j in range(nc):
                    active[j] = gf[j] < 0.0
                    mu[j] = -gf[j] * sdiag[cd[j]] if active[j] else 0.0
            else:
                lcp_solve(W, gf, mu, active, tol, was)
                correct(fac, cd, Z, keep_z, mu, X, rhs, w, work)
            for j in range(nc):
                if active[j]:  # on the constraint exactly
                    X[cd[j]] = -gap0[j] - e * (gap0[j] + Um[cd[j]])
                lam[j] = mu[j] / dt2
        else:
            mu[:] = 0.0
            lam[:] = 0.0
        was = pen
        lvl = step - 1  # level n = step - 1 is complete: its force is r^n
        stats_update(stats, status, lam, lvl, dt)
        # the centred momentum changes by dt (r^{n-1} + r^n) / 2 from level n-1 to n; at
        # level 0 by dt r^0 / 2 from the data V0 (sample 0) to the centred velocity
        if lvl == 0:
            stats[LAST_FORCE] = lam.sum()
            stats[CONTACT_IMPULSE] = 0.5 * dt * stats[LAST_FORCE]
        else:
            impulse_update(stats, lam, dt, 0.5)
        if lvl == 0:
            s_out[0] = -lam.sum() / area
        elif lvl % stride == 0 or lvl == nsteps:
            for i in range(n):
                tmp[i] = (X[i] - Um[i]) / (2.0 * dt)
            en = csr_energy(Mp, Mi, Mx, Kp, Ki, Kx, F, U, tmp, offset, w)
            blown = write_sample(k, lvl * dt, U, tmp, gap0, cd, -lam.sum() / area, en, E0,
                                  t_out, U_out, V_out, cu_out, s_out, E_out, stats)
            k += 1
            if blown:
                return k, lvl, min_gap, lvl
        if step == nsteps + 1:
            break
        for i in range(n):
            Um[i] = U[i]
            U[i] = X[i]
        min_gap = smallest_gap(gap0, U, cd, min_gap)
    return k, nsteps, min_gap, -1


def _refuse_massless(p: SparseProblem, what: str) -> None:
    if np.any(p.massless):
        raise ValueError(f"{what} needs mass at every dof (an impact law acts on momentum); "
                         "this problem has massless dofs")


class PaoliSchatzmanStepper(KernelStepper):
    """`paoli_schatzman_sparse` prepared: S factored (unless diagonal), the Delassus
    matrix and the state (U^{-1}, U^0) computed once."""

    def __init__(self, p: SparseProblem, dt: float, e: float, beta: float) -> None:
        _refuse_massless(p, "restitution (Paoli-Schatzman)")
        super().__init__(p, dt)
        dt, e, beta = self.dt, float(e), float(beta)
        n = p.nfree
        cd = np.asarray(p.contact.dofs, np.int64)
        S = sp.csr_matrix(p.M + (beta * dt * dt) * p.K)
        sd = np.asarray(S.diagonal(), float)
        diag = S.nnz == np.count_nonzero(sd)
        if diag:  # no factor, no Delassus matrix: W = diag(1 / s) on the contact dofs
            fac = Factor.of(sp.identity(1, format="csc"))
            keep_z, Z, W = False, np.zeros((1, 1)), np.zeros((1, 1))
        else:
            fac = Factor.of(S)
            Z, W, keep_z = contact_operators(fac, cd, n)
        U = p.U0.astype(float).copy()
        self.state = (U - dt * p.V0 + 0.5 * dt * dt * initial_acceleration(p), U)  # (Um, U)
        self.kernel = _ps_kernel
        self.tail = (1e-13 * max(float(np.max(np.abs(U))),
                                 float(np.max(np.abs(p.contact.gap0), initial=0.0)), 1e-300),)
        self.operators = (*csr_arrays(p.M), *csr_arrays(p.K), np.asarray(p.F, float),
                          sd if diag else np.zeros(0), fac.arrays, cd,
                          np.asarray(p.contact.gap0, float),
                          np.asarray(p.contact.weights, float), W, Z, keep_z)
        self.params = (beta, e, dt)


def prepare_paoli_schatzman(p: SparseProblem, dt: float, e: float, beta: float
                            ) -> PaoliSchatzmanStepper:
    """The Paoli-Schatzman scheme with restitution e and stiffness weight beta (module
    docstring). ValueError on a problem with massless dofs."""
    return PaoliSchatzmanStepper(p, dt, e, beta)


def paoli_schatzman_sparse(p: SparseProblem, dt: float, nsteps: int, stride: int, e: float,
                           beta: float) -> Trajectory:
    """`prepare_paoli_schatzman(p, dt, e, beta).run(nsteps, stride)`."""
    return prepare_paoli_schatzman(p, dt, e, beta).run(nsteps, stride)


@njit(cache=True)
def _mj_kernel(Mp, Mi, Mx, Kp, Ki, Kx, F, fac, cd, gap0, weights, W, Z, keep_z, U, V,
               theta, e, dt, nsteps, stride, offset, t_out, U_out, V_out, cu_out, s_out,
               E_out, stats, tol):  # pragma: no cover - compiled
    """Moreau-Jean on (U, V) in place (module docstring)."""
    Lp, Li, Lx, Up, Ui, Ux, pr, pc = fac
    n = U.size
    nc = cd.size
    c = theta * (1.0 - theta) * dt * dt
    rhs = np.empty(n)
    ku = np.empty(n)
    kv = np.empty(n)
    X = np.empty(n)
    w = np.empty(n)
    work = np.empty(n)
    mu = np.zeros(nc)
    lam = np.zeros(nc)
    active = np.zeros(nc, np.bool_)
    status = np.zeros(nc, np.bool_)
    idx = np.empty(nc, np.int64)
    area = weights.sum()
    E0 = E_out[0]
    min_gap = smallest_gap(gap0, U, cd)
    k = 1
    for step in range(1, nsteps + 1):
        # S X = M V + dt (F - K U) - c K V: the free velocity
        csr_matvec(Mp, Mi, Mx, V, rhs)
        csr_matvec(Kp, Ki, Kx, U, ku)
        csr_matvec(Kp, Ki, Kx, V, kv)
        for i in range(n):
            rhs[i] += dt * (F[i] - ku[i]) - c * kv[i]
        lu_solve(Lp, Li, Lx, Up, Ui, Ux, pr, pc, rhs, X, work)
        # the index set: predicted gap <= 0; Newton's law on its dofs
        m = 0
        pen = False
        for j in range(nc):
            d = cd[j]
            if not np.isfinite(X[d]):  # blown up between samples
                return k, step, min_gap, step
            if gap0[j] + U[d] + 0.5 * dt * V[d] <= 0.0:
                idx[m] = j
                m += 1
                pen = pen or X[d] + e * V[d] < 0.0
        mu[:] = 0.0
        active[:] = False
        if pen:
            Ws = np.empty((m, m))
            qs = np.empty(m)
            ms = np.zeros(m)
            acts = np.zeros(m, np.bool_)
            for a in range(m):
                qs[a] = X[cd[idx[a]]] + e * V[cd[idx[a]]]
                for b in range(m):
                    Ws[a, b] = W[idx[a], idx[b]]
            lcp_solve(Ws, qs, ms, acts, tol, False)
            for a in range(m):
                mu[idx[a]] = ms[a]
                active[idx[a]] = acts[a]
            correct(fac, cd, Z, keep_z, mu, X, rhs, w, work)
            for j in range(nc):
                if active[j]:  # on the law exactly
                    X[cd[j]] = -e * V[cd[j]]
        for j in range(nc):
            lam[j] = mu[j] / dt  # the impulse as a mean force over the step
        for i in range(n):
            U[i] += dt * (theta * X[i] + (1.0 - theta) * V[i])
            V[i] = X[i]
        stats_update(stats, status, lam, step, dt)
        impulse_update(stats, lam, dt, 1.0)  # the impulse P = dt lam itself
        min_gap = smallest_gap(gap0, U, cd, min_gap)
        if step % stride == 0 or step == nsteps:
            en = csr_energy(Mp, Mi, Mx, Kp, Ki, Kx, F, U, V, offset, w)
            blown = write_sample(k, step * dt, U, V, gap0, cd, -lam.sum() / area, en, E0,
                                  t_out, U_out, V_out, cu_out, s_out, E_out, stats)
            k += 1
            if blown:
                return k, step, min_gap, step
    return k, nsteps, min_gap, -1


class MoreauJeanStepper(KernelStepper):
    """`moreau_jean_sparse` prepared: S factored and the Delassus matrix computed once."""

    def __init__(self, p: SparseProblem, dt: float, e: float, theta: float) -> None:
        _refuse_massless(p, "moreau_jean")
        super().__init__(p, dt)
        dt, e, theta = self.dt, float(e), float(theta)
        n = p.nfree
        cd = np.asarray(p.contact.dofs, np.int64)
        fac = Factor.of(p.M + ((theta * dt) ** 2) * p.K)
        Z, W, keep_z = contact_operators(fac, cd, n)
        U, V = p.U0.astype(float).copy(), p.V0.astype(float).copy()
        self.state = (U, V)
        # a velocity-level tolerance: round-off of the larger of the data's speeds
        vscale = max(float(np.max(np.abs(V))), float(np.max(np.abs(U))) / dt, 1e-300)
        self.kernel = _mj_kernel
        self.tail = (1e-13 * vscale,)
        self.operators = (*csr_arrays(p.M), *csr_arrays(p.K), np.asarray(p.F, float),
                          fac.arrays, cd, np.asarray(p.contact.gap0, float),
                          np.asarray(p.contact.weights, float), W, Z, keep_z)
        self.params = (theta, e, dt)


def prepare_moreau_jean(p: SparseProblem, dt: float, e: float, theta: float
                        ) -> MoreauJeanStepper:
    """Moreau-Jean with restitution e and the theta-method (module docstring).
    ValueError on a problem with massless dofs."""
    return MoreauJeanStepper(p, dt, e, theta)


def moreau_jean_sparse(p: SparseProblem, dt: float, nsteps: int, stride: int, e: float,
                       theta: float) -> Trajectory:
    """`prepare_moreau_jean(p, dt, e, theta).run(nsteps, stride)`."""
    return prepare_moreau_jean(p, dt, e, theta).run(nsteps, stride)


__all__ = ["MoreauJeanStepper", "PaoliSchatzmanStepper", "moreau_jean_sparse",
           "paoli_schatzman_sparse", "prepare_moreau_jean", "prepare_paoli_schatzman"]
