"""The massless-contact ODE (P_U^mod) on the general sparse problem: `ode_verlet`'s and
`ode_adaptive`'s sparse paths.

With every contact dof massless (a redistributed mass), the dofs with mass (h) carry
the dynamics and the massless ones (m) are a function of them, the solution of their
own rows with exact contact:

    K_mm u_m = F_m - K_mh u_h + C^T lambda,  g = gap0 + C u_m >= 0 _|_ lambda >= 0,

(K_mm factored once, the contact by the LCP on the Delassus matrix W = C K_mm^-1 C^T,
as `contact_bench.kernels.sparse.quasistatic_sparse`), so that

    M_hh u_h'' = (F - K U)_h,  U = (u_h, u_m(u_h)),

is an ODE with a Lipschitz right-hand side (M_hh factored once unless diagonal). The
massless dofs are not a state: their velocity is the exact derivative of u_m(u_h),
K_mm v_m = -K_mh v_h with v = 0 on the contact dofs sitting on the obstacle (the 1D
schemes' v0 = -(K01 / K00) v1, or 0 in contact).

* `verlet_sparse`: velocity Verlet with a fixed step (the same update of the dofs with
  mass as `quasistatic_sparse` at gamma = 1/2; the difference is the massless dofs'
  velocity and the projection of the massless dofs at t = 0, as in 1D).
* `massless_ode_omega`: the largest angular frequency of the ODE, which bounds the
  explicit step: with every contact dof on the obstacle (pinning dofs only stiffens
  the Schur complement below, so this contact state has the largest frequency),
  omega_max^2 = the largest eigenvalue of (K_hh - K_hI K_II^-1 K_Ih, M_hh), I the
  massless dofs off the contact set (scipy's `eigsh`, factored solves, no dense matrix).
* `adaptive_sparse`: scipy's DOP853 with error control on (u_h, v_h); the right-hand
  side (`ode_rhs`) is one massless solve with its LCP and one solve with M_hh. The
  contact impulse J (J' = the total contact force) is one more component of the state,
  out of the error control: integrated with the velocities' stages and weights, it is
  the impulse the integrator applies (the momentum balance holds to round-off at the
  samples, which the solver's dense output interpolates linearly in its stages).

Both accumulate the contact impulse and record it at each sample (the statistics of
`contact_bench.kernels.sparse`): Verlet's with weights 1/2, 1/2.
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
    SAMPLE_IMPULSE,
    contact_extra,
    first_contact_impulse,
    impulse_update,
    new_stats,
    stats_update,
)
from contact_bench.core.sampling import blown_up, n_samples
from contact_bench.kernels.csr import csr_arrays, csr_matvec
from contact_bench.kernels.recording import csr_energy, smallest_gap, write_sample
from contact_bench.kernels.sparse import (
    Factor,
    MasslessSplit,
    add_response,
    lcp_solve,
    lu_solve,
)
from contact_bench.kernels.stepper import KernelStepper, SparseStepper


@njit(cache=True)
def massless_solve(U, F, mv, cl, Kmp, Kmi, Kmx, mfac, W, Z, gap0, tol, mu, active, warm,
                   rm, um, wm, gf):  # pragma: no cover - compiled
    """U[mv] <- u_m(u_h), the massless rows solved with exact contact; mu (out) the
    obstacle's forces, active (in/out) the contact dofs on the obstacle. Returns whether
    any contact dof would penetrate without the obstacle (the LCP ran)."""
    nm, nc = mv.size, cl.size
    csr_matvec(Kmp, Kmi, Kmx, U, rm)  # K_mh u_h
    for b in range(nm):
        rm[b] = F[mv[b]] - rm[b]
    lu_solve(mfac[0], mfac[1], mfac[2], mfac[3], mfac[4], mfac[5], mfac[6], mfac[7],
             rm, um, wm)
    pen = False
    for j in range(nc):
        gf[j] = gap0[j] + um[cl[j]]
        pen = pen or gf[j] < 0.0
    if pen:
        lcp_solve(W, gf, mu, active, tol, warm)
        add_response(Z, mu, um)
        for j in range(nc):
            if active[j]:
                um[cl[j]] = -gap0[j]  # on the obstacle: the gap is 0 exactly
    else:
        mu[:] = 0.0
        active[:] = False
    for b in range(nm):
        U[mv[b]] = um[b]
    return pen


@njit(cache=True)
def heavy_acceleration(U, F, hv, Khp, Khi, Khx, hfac, diag_h, rh, ah, wh
                       ):  # pragma: no cover - compiled
    """ah = M_hh^-1 (F - K U)_h."""
    nh = hv.size
    csr_matvec(Khp, Khi, Khx, U, rh)
    for a in range(nh):
        rh[a] = F[hv[a]] - rh[a]
    if diag_h.size:
        for a in range(nh):
            ah[a] = rh[a] / diag_h[a]
    else:
        lu_solve(hfac[0], hfac[1], hfac[2], hfac[3], hfac[4], hfac[5], hfac[6], hfac[7],
                 rh, ah, wh)


@njit(cache=True)
def massless_velocity(V, mv, cl, Kmp, Kmi, Kmx, mfac, W, Z, active, rm, vm, wm
                      ):  # pragma: no cover - compiled
    """V[mv] <- d u_m / dt: K_mm v_m = -K_mh v_h, with v = 0 on the active contact dofs
    (a correction Z nu, W_AA nu = -v_A)."""
    nm = mv.size
    csr_matvec(Kmp, Kmi, Kmx, V, rm)
    for b in range(nm):
        rm[b] = -rm[b]
    lu_solve(mfac[0], mfac[1], mfac[2], mfac[3], mfac[4], mfac[5], mfac[6], mfac[7],
             rm, vm, wm)
    idx = np.flatnonzero(active)
    if idx.size:
        sub = np.empty((idx.size, idx.size))
        rhs = np.empty(idx.size)
        for a in range(idx.size):
            rhs[a] = -vm[cl[idx[a]]]
            for b in range(idx.size):
                sub[a, b] = W[idx[a], idx[b]]
        nu = np.linalg.solve(sub, rhs)
        for b in range(nm):
            acc = 0.0
            for a in range(idx.size):
                acc += Z[b, idx[a]] * nu[a]
            vm[b] += acc
        for a in range(idx.size):
            vm[cl[idx[a]]] = 0.0
    for b in range(nm):
        V[mv[b]] = vm[b]


@njit(cache=True)
def _verlet_kernel(Mp, Mi, Mx, Kp, Ki, Kx, F, hv, mv, cl, Khp, Khi, Khx, Kmp, Kmi, Kmx,
                   mfac, hfac, diag_h, W, Z, tol, gap0, weights, U, V, dt, nsteps, stride,
                   offset, t_out, U_out, V_out, cu_out, s_out, E_out, stats
                   ):  # pragma: no cover - compiled
    """Velocity Verlet on the dofs with mass, the massless ones u_m(u_h) at every step
    (module docstring); sample 0 is the projected initial state."""
    n = U.size
    nh, nm, nc = hv.size, mv.size, cl.size
    rm = np.empty(nm)
    um = np.empty(nm)
    wm = np.empty(nm)
    rh = np.empty(nh)
    A = np.empty(nh)
    wh = np.empty(nh)
    w = np.empty(n)
    gf = np.empty(nc)
    mu = np.zeros(nc)
    active = np.zeros(nc, np.bool_)
    status = np.zeros(nc, np.bool_)
    area = weights.sum()
    was = massless_solve(U, F, mv, cl, Kmp, Kmi, Kmx, mfac, W, Z, gap0, tol, mu, active,
                         False, rm, um, wm, gf)
    heavy_acceleration(U, F, hv, Khp, Khi, Khx, hfac, diag_h, rh, A, wh)
    massless_velocity(V, mv, cl, Kmp, Kmi, Kmx, mfac, W, Z, active, rm, um, wm)
    stats[LAST_FORCE] = mu.sum()  # the force at t = 0 in A: the impulse's start
    E0 = csr_energy(Mp, Mi, Mx, Kp, Ki, Kx, F, U, V, offset, w)
    gdofs = mv[cl]  # the contact dofs in U
    min_gap = smallest_gap(gap0, U, gdofs)
    t_out[0] = 0.0
    U_out[0, :] = U
    V_out[0, :] = V
    cu_out[0] = min_gap
    s_out[0] = -mu.sum() / area
    E_out[0] = E0
    h = 0.5 * dt
    k = 1
    for step in range(1, nsteps + 1):
        for a in range(nh):
            i = hv[a]
            V[i] += h * A[a]
            U[i] += dt * V[i]
        was = massless_solve(U, F, mv, cl, Kmp, Kmi, Kmx, mfac, W, Z, gap0, tol, mu,
                             active, was, rm, um, wm, gf)
        heavy_acceleration(U, F, hv, Khp, Khi, Khx, hfac, diag_h, rh, A, wh)
        for a in range(nh):
            V[hv[a]] += h * A[a]
        stats_update(stats, status, mu, step, dt)
        impulse_update(stats, mu, dt, 0.5)
        min_gap = smallest_gap(gap0, U, gdofs, min_gap)
        if step % stride == 0 or step == nsteps:
            massless_velocity(V, mv, cl, Kmp, Kmi, Kmx, mfac, W, Z, active, rm, um, wm)
            e = csr_energy(Mp, Mi, Mx, Kp, Ki, Kx, F, U, V, offset, w)
            blown = write_sample(k, step * dt, U, V, gap0, gdofs, -mu.sum() / area, e, E0,
                                  t_out, U_out, V_out, cu_out, s_out, E_out, stats)
            k += 1
            if blown:
                return k, step, min_gap, step
    return k, nsteps, min_gap, -1


class VerletStepper(KernelStepper):
    """`verlet_sparse` prepared: the massless split (`MasslessSplit`: K_mm and M_hh
    factored, the Delassus matrix) computed once."""

    keeps_selection = False  # the kernel writes sample 0 itself

    def __init__(self, p: SparseProblem, dt: float) -> None:
        self.split = MasslessSplit.of(p)
        super().__init__(p, dt)
        self.kernel = _verlet_kernel
        self.state = (p.U0.astype(float).copy(), p.V0.astype(float).copy())
        self.params = (self.dt,)
        self.operators = (*csr_arrays(p.M), *csr_arrays(p.K), np.asarray(p.F, float),
                          *self.split.args(), np.asarray(p.contact.gap0, float),
                          np.asarray(p.contact.weights, float))


def prepare_verlet(p: SparseProblem, dt: float) -> VerletStepper:
    """Velocity Verlet on the massless-contact ODE (module docstring). ValueError unless
    every contact dof is massless."""
    return VerletStepper(p, dt)


def verlet_sparse(p: SparseProblem, dt: float, nsteps: int, stride: int) -> Trajectory:
    """`prepare_verlet(p, dt).run(nsteps, stride)`."""
    return prepare_verlet(p, dt).run(nsteps, stride)


def massless_ode_omega(p: SparseProblem) -> float:
    """omega_max of the massless-contact ODE in its stiffest contact state (module
    docstring); velocity Verlet is stable for dt omega_max < 2."""
    from scipy.sparse.linalg import LinearOperator, eigsh

    massless = p.massless
    hv = np.flatnonzero(~massless)
    free = massless.copy()
    free[np.asarray(p.contact.dofs, np.int64)] = False  # pinned on the obstacle
    iv = np.flatnonzero(free)
    K = sp.csr_matrix(p.K)
    Khh = sp.csr_matrix(K[hv][:, hv])
    if iv.size:
        KIh = sp.csr_matrix(K[iv][:, hv])
        fac = Factor.of(K[iv][:, iv])

        def schur(x: np.ndarray) -> np.ndarray:
            x = np.ravel(x)
            return Khh @ x - KIh.T @ fac.solve(KIh @ x)
    else:
        def schur(x: np.ndarray) -> np.ndarray:
            return Khh @ np.ravel(x)
    op = LinearOperator((hv.size, hv.size), matvec=schur, dtype=float)
    Mhh = sp.csc_matrix(p.M[hv][:, hv])
    if hv.size <= 2:
        raise ValueError("the massless-contact ODE needs more than two dofs with mass")
    # a fixed start vector: ARPACK's own random one moves the limit (and a dt taken from
    # it) in the last digits from one call to the next
    lam = eigsh(op, k=1, M=Mhh, which="LA", tol=1e-10, return_eigenvectors=False,
                v0=np.random.default_rng(0).standard_normal(hv.size))
    return float(np.sqrt(lam[0]))


# ------------------------------------------------------------------- adaptive (DOP853)


@njit(cache=True)
def ode_rhs(y, U, F, hv, mv, cl, Khp, Khi, Khx, Kmp, Kmi, Kmx, mfac, hfac, diag_h, W, Z,
            tol, gap0, mu, active):  # pragma: no cover - compiled
    """d/dt (u_h, v_h) = (v_h, M_hh^-1 (F - K U)_h) with U = (u_h, u_m(u_h)); U (the
    full displacement), mu and active are scratch (active: the last evaluation's
    contact set, the LCP's warm start)."""
    nh, nm, nc = hv.size, mv.size, cl.size
    for a in range(nh):
        U[hv[a]] = y[a]
    massless_solve(U, F, mv, cl, Kmp, Kmi, Kmx, mfac, W, Z, gap0, tol, mu, active, True,
                   np.empty(nm), np.empty(nm), np.empty(nm), np.empty(nc))
    dy = np.empty(2 * nh)
    dy[:nh] = y[nh:]
    ah = np.empty(nh)
    heavy_acceleration(U, F, hv, Khp, Khi, Khx, hfac, diag_h, np.empty(nh), ah, np.empty(nh))
    dy[nh:] = ah
    return dy


@njit(cache=True)
def ode_samples(Ys, F, hv, mv, cl, Khp, Khi, Khx, Kmp, Kmi, Kmx, mfac, hfac, diag_h, W, Z,
                tol, gap0, U_out, V_out, lam_out):  # pragma: no cover - compiled
    """The full samples from the integrator's (u_h, v_h) columns: u_m(u_h), its
    derivative and the obstacle's forces (lam_out, n_c per sample)."""
    nh, nm, nc = hv.size, mv.size, cl.size
    rm, um, wm, gf = np.empty(nm), np.empty(nm), np.empty(nm), np.empty(nc)
    mu = np.zeros(nc)
    active = np.zeros(nc, np.bool_)
    for s in range(Ys.shape[1]):
        for a in range(nh):
            U_out[s, hv[a]] = Ys[a, s]
            V_out[s, hv[a]] = Ys[nh + a, s]
        U = U_out[s]
        V = V_out[s]
        massless_solve(U, F, mv, cl, Kmp, Kmi, Kmx, mfac, W, Z, gap0, tol, mu, active, False,
                       rm, um, wm, gf)
        massless_velocity(V, mv, cl, Kmp, Kmi, Kmx, mfac, W, Z, active, rm, um, wm)
        lam_out[s, :] = mu


def speed_scale(p: SparseProblem) -> float:
    """A speed the data can give: max|V0| + sqrt(2 g H), g the largest load per unit
    mass of a dof, H = max|U0| (a free fall from the initial lift)."""
    rows = np.asarray(p.M @ np.ones(p.nfree)).ravel()
    heavy = rows > 0
    g = float(np.max(np.abs(p.F[heavy]) / rows[heavy], initial=0.0))
    return float(np.max(np.abs(p.V0), initial=0.0)
                 + np.sqrt(2.0 * g * float(np.max(np.abs(p.U0), initial=0.0))))


class AdaptiveStepper(SparseStepper):
    """`adaptive_sparse` prepared: the massless split (`MasslessSplit`) and the absolute
    tolerances computed once; `run` integrates from t = 0 with fresh scratch arrays (the
    LCP's warm start included), so that two runs take the same steps."""

    def __init__(self, p: SparseProblem, dt: float, rtol: float) -> None:
        self.split = MasslessSplit.of(p)
        super().__init__(p, dt)
        self.rtol = rtol
        hv = self.split.hv
        U, V = p.U0.astype(float).copy(), p.V0.astype(float).copy()
        nh = hv.size
        # the state (u_h, v_h, J): J' = the total contact force, integrated with the same
        # stages and weights as v_h (J out of the error control: an infinite tolerance)
        self.y0 = np.concatenate([U[hv], V[hv], [0.0]])
        atol = np.full(2 * nh + 1, rtol * (float(np.max(np.abs(U))) + speed_scale(p) + 1e-300))
        atol[-1] = np.inf
        self.atol = atol
        self.F = np.asarray(p.F, float)
        self.gap0 = np.asarray(p.contact.gap0, float)

    def run(self, nsteps: int, stride: int) -> Trajectory:
        from scipy.integrate import solve_ivp  # here: 20 MB that other schemes' runs skip

        p, split, dt, rtol = self.problem, self.split, self.dt, self.rtol
        hv, F, gap0 = split.hv, self.F, self.gap0
        steps = np.arange(0, nsteps + 1, stride)
        if steps[-1] != nsteps:
            steps = np.append(steps, nsteps)
        assert steps.size == n_samples(nsteps, stride)
        t_eval = steps * dt
        U = p.U0.astype(float).copy()
        nc = p.contact.size
        force = np.zeros(nc)  # the last evaluation's contact forces
        args = (U, F, hv, split.mv, split.cl, *split.Kh, *split.Kmh, split.mfac, split.hfac,
                split.diag_h, split.W, split.Z, split.tol, gap0, force,
                np.zeros(nc, np.bool_))

        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            return np.append(ode_rhs(y[:-1], *args), force.sum())

        sol = solve_ivp(rhs, (0.0, float(t_eval[-1])), self.y0.copy(), method="DOP853",
                        t_eval=t_eval, rtol=rtol, atol=self.atol)
        k = sol.t.size
        impulse = np.array(sol.y[-1])
        Us = np.zeros((k, p.nfree))
        Vs = np.zeros((k, p.nfree))
        lam = np.zeros((k, nc))
        ode_samples(np.ascontiguousarray(sol.y[:-1]), F, hv, split.mv, split.cl, *split.Kh,
                    *split.Kmh, split.mfac, split.hfac, split.diag_h, split.W, split.Z,
                    split.tol, gap0, Us, Vs, lam)
        energy = (0.5 * np.einsum("ij,ij->i", Vs, (p.M @ Vs.T).T)
                  + 0.5 * np.einsum("ij,ij->i", Us, (p.K @ Us.T).T) - Us @ F + p.energy_offset)
        gaps = p.gaps(Us) if nc else np.full((k, 1), np.inf)
        area = float(np.sum(p.contact.weights))
        stats = new_stats(samples=k)
        stats[SAMPLE_IMPULSE:] = impulse
        status = np.zeros(nc, bool)
        for s in range(1, k):  # the contact statistics at the samples (not the inner steps)
            stats_update(stats, status, lam[s], int(steps[s]), dt)
            first_contact_impulse(stats, impulse[s])
        blow = None
        bad = [blown_up(e, energy[0]) for e in energy]
        if any(bad):
            first = int(np.argmax(bad))
            blow, k = float(sol.t[first]), first + 1
        elif sol.status != 0:
            blow = float(sol.t[-1]) if k else 0.0
        if k:
            stats[CONTACT_IMPULSE] = impulse[k - 1]
        extra = contact_extra(stats, k)
        extra.update(nfev=int(sol.nfev), message=str(sol.message), rtol=rtol)
        cu = gaps.min(axis=1)
        return Trajectory(t=sol.t[:k], U=Us[:k], V=Vs[:k], contact_u=cu[:k],
                          stress=-lam[:k].sum(axis=1) / area, energy=energy[:k],
                          min_contact_u=float(cu[:k].min()) if k else 0.0,
                          steps_done=int(steps[k - 1]) if k else 0, blowup_time=blow,
                          extra=extra)


def prepare_adaptive(p: SparseProblem, dt: float, rtol: float) -> AdaptiveStepper:
    """The massless-contact ODE by DOP853 with relative tolerance `rtol` and absolute
    tolerance rtol (max|U0| + `speed_scale`) on (u_h, v_h), with the contact impulse
    integrated along (module docstring); dt is the sampling interval only. The contact
    statistics are the samples'. ValueError unless every contact dof is massless."""
    return AdaptiveStepper(p, dt, rtol)


def adaptive_sparse(p: SparseProblem, dt: float, nsteps: int, stride: int,
                    rtol: float) -> Trajectory:
    """`prepare_adaptive(p, dt, rtol).run(nsteps, stride)`."""
    return prepare_adaptive(p, dt, rtol).run(nsteps, stride)
