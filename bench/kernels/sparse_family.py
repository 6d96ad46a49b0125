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

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.sparse.linalg import LinearOperator

from contact_bench.api.plugin import Trajectory
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.contact_stats import (
    CONTACT_IMPULSE,
    SAMPLE_IMPULSE,
    contact_extra,
    first_contact_impulse,
    new_stats,
    stats_gap,
    stats_update,
)
from contact_bench.core.loop import OK, START_PROJECTED, drive
from contact_bench.core.sampling import blown_up, n_samples
from contact_bench.kernels.contact import ContactOps, row_dot
from contact_bench.kernels.csr import CSR, csr_arrays, matvec
from contact_bench.kernels.linalg import LU, lu
from contact_bench.kernels.recording import csr_energy
from contact_bench.kernels.sparse import (
    Factor,
    MasslessSplit,
    heavy_acceleration,
    massless_solve,
)
from contact_bench.kernels.stepper import LoopStepper, SparseStepper
from contact_bench.kernels.time_load import (
    LoadOps,
    NoLoad,
    force_at,
    load_ops,
    load_points,
    load_scratch,
)


class MasslessOps(NamedTuple):
    """The massless-contact ODE's operators (`MasslessSplit`'s arrays with F and the
    contact dofs' gaps): hv, mv the dofs with mass and the massless ones, cl the contact
    dofs' positions in mv, K's rows Kh = K[hv] and Km = K[mv] (massless columns dropped),
    K_mm's and M_hh's factors (or M_hh's diagonal), W = C K_mm^-1 C^T, Z = K_mm^-1 C^T."""

    F: np.ndarray
    hv: np.ndarray
    mv: np.ndarray
    Kh: CSR
    Km: CSR
    mfac: LU
    hfac: LU
    diag_h: np.ndarray
    ct: ContactOps  # G restricted to the massless dofs, with K_mm's factor
    at_contact: np.ndarray  # -gap0
    tol: float
    load: LoadOps | NoLoad  # the time load (`contact_bench.kernels.time_load`)


def massless_ops(split: MasslessSplit, p: SparseProblem) -> MasslessOps:
    """`MasslessOps` of a problem's split."""
    return MasslessOps(np.asarray(p.F, float), split.hv, split.mv, split.Kh, split.Kmh,
                       split.mfac, split.hfac, split.diag_h, split.ct, split.at_contact,
                       split.tol, load_ops(p))


@njit(cache=True)
def massless_velocity(o, V, active, rm, vm, wm):  # pragma: no cover - compiled
    """V[mv] <- d u_m / dt: K_mm v_m = -K_mh v_h, with G_A v_m = 0 on the active contact
    points (a correction Z nu, W_AA nu = -(G v)_A). A time load's rate dF_m/dt is left
    out of it (its term K_mm^-1 dF_m/dt is of the order of the space discretisation's
    error); the displacements feel the whole load."""
    ct, mv = o.ct, o.mv
    W, Z, sel = ct.W, ct.Z, ct.sel
    nm = mv.size
    matvec(o.Km, V, rm)
    for b in range(nm):
        rm[b] = -rm[b]
    lu(o.mfac, rm, vm, wm)
    idx = np.flatnonzero(active)
    if idx.size:
        sub = np.empty((idx.size, idx.size))
        rhs = np.empty(idx.size)
        for a in range(idx.size):
            d = sel[idx[a]]
            rhs[a] = -vm[d] if d >= 0 else -row_dot(ct.G, idx[a], vm)
            for b in range(idx.size):
                sub[a, b] = W[idx[a], idx[b]]
        nu = np.linalg.solve(sub, rhs)
        for b in range(nm):
            acc = 0.0
            for a in range(idx.size):
                acc += Z[b, idx[a]] * nu[a]
            vm[b] += acc
        for a in range(idx.size):
            if sel[idx[a]] >= 0:
                vm[sel[idx[a]]] = 0.0
    for b in range(nm):
        V[mv[b]] = vm[b]


class VerletOps(NamedTuple):
    """Velocity Verlet on the massless-contact ODE: the ODE's operators, M and K whole
    (the energy), the contact zone's weights, dt, the energy's offset."""

    ode: MasslessOps
    M: CSR
    K: CSR
    weights: np.ndarray
    dt: float
    offset: float


class VerletState(NamedTuple):
    """(U, V), the acceleration of the dofs with mass, the obstacle's forces and active
    set, scratch."""

    U: np.ndarray
    V: np.ndarray
    A: np.ndarray
    force: np.ndarray
    active: np.ndarray
    was: np.ndarray
    scr: tuple  # (rm, um, wm, gf): `massless_solve`'s scratch
    rh: np.ndarray
    wh: np.ndarray
    w: np.ndarray
    Fn: np.ndarray
    vals: np.ndarray


@njit(cache=True)
def verlet_step(o, s, step):  # pragma: no cover - compiled
    """Velocity Verlet on the dofs with mass, the massless ones u_m(u_h) at every step
    (module docstring); step 0 projects the initial state (`loop.START_PROJECTED`). The
    massless rows and the acceleration at U_{n+1} feel the load at t_{n+1}."""
    ode, U, V, A, dt = o.ode, s.U, s.V, s.A, o.dt
    F = force_at(ode.load, ode.F, step * dt, s.vals, s.Fn)
    if step == 0:
        s.was[0] = massless_solve(ode, F, U, s.force, s.active, False, s.scr)
        heavy_acceleration(ode, F, U, s.rh, A, s.wh)
        massless_velocity(ode, V, s.active, s.scr[0], s.scr[1], s.scr[2])
        return OK
    hv = ode.hv
    h = 0.5 * dt
    for a in range(hv.size):
        i = hv[a]
        V[i] += h * A[a]
        U[i] += dt * V[i]
    s.was[0] = massless_solve(ode, F, U, s.force, s.active, s.was[0], s.scr)
    heavy_acceleration(ode, F, U, s.rh, A, s.wh)
    for a in range(hv.size):
        V[hv[a]] += h * A[a]
    return OK


@njit(cache=True)
def verlet_sample(o, s):  # pragma: no cover - compiled
    """The massless dofs' velocity, then the energy and the obstacle's stress."""
    massless_velocity(o.ode, s.V, s.active, s.scr[0], s.scr[1], s.scr[2])
    e = csr_energy(o.M, o.K, o.ode.F, s.U, s.V, o.offset, s.w)
    return e, -s.force.sum() / o.weights.sum(), s.V


@njit(cache=True)
def verlet_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `verlet_step`."""
    return drive(verlet_step, verlet_sample, ops, st, rec, nsteps, stride)


class VerletStepper(LoopStepper):
    """`verlet_sparse` prepared: the massless split (`MasslessSplit`: K_mm and M_hh
    factored, the Delassus matrix) computed once."""

    adds_time_load = True
    any_gap_operator = True
    follows_curved = True
    loop = staticmethod(verlet_loop)

    def __init__(self, p: SparseProblem, dt: float) -> None:
        self.split = MasslessSplit.of(p)
        super().__init__(p, dt)
        self.gamma = 0.5
        self.start = START_PROJECTED
        self.ops = VerletOps(massless_ops(self.split, p), csr_arrays(p.M), csr_arrays(p.K),
                             np.asarray(p.contact.weights, float), self.dt,
                             float(p.energy_offset))

    def new_state(self) -> VerletState:
        p, o = self.problem, self.ops.ode
        n, nh, nm, nc = p.nfree, o.hv.size, o.mv.size, o.at_contact.size
        vals, Fn = load_scratch(o.load, n)
        return VerletState(p.U0.astype(float).copy(), p.V0.astype(float).copy(),
                           np.empty(nh), np.zeros(nc), np.zeros(nc, np.bool_),
                           np.zeros(1, np.bool_),
                           (np.empty(nm), np.empty(nm), np.empty(nm), np.empty(nc)),
                           np.empty(nh), np.empty(nh), np.empty(n), Fn, vals)


def prepare_verlet(p: SparseProblem, dt: float) -> VerletStepper:
    """Velocity Verlet on the massless-contact ODE (module docstring). ValueError unless
    every contact dof is massless."""
    return VerletStepper(p, dt)


def verlet_sparse(p: SparseProblem, dt: float, nsteps: int, stride: int) -> Trajectory:
    """`prepare_verlet(p, dt).run(nsteps, stride)`."""
    return prepare_verlet(p, dt).run(nsteps, stride)


def condensed_stiffness(K: sp.csr_matrix, hv: np.ndarray, iv: np.ndarray,
                        s: np.ndarray | None = None) -> LinearOperator:
    """x -> S x on the dofs hv: S = K_hh - K_hI K_II^-1 K_Ih, the stiffness with the dofs
    iv condensed (their rows solved; none: K_hh), for the largest eigenvalue of a state
    whose other dofs are held. With s: D S D, D = diag(s) (s = m^-1/2 of a lumped mass
    turns the generalised eigenproblem into a standard one)."""
    Khh = sp.csr_matrix(K[hv][:, hv])
    if s is not None:
        Khh = sp.diags(s) @ Khh @ sp.diags(s)
    if iv.size:
        KIh = sp.csr_matrix(K[iv][:, hv])
        if s is not None:
            KIh = KIh @ sp.diags(s)
        fac = Factor.of(K[iv][:, iv])

        def schur(x: np.ndarray) -> np.ndarray:
            x = np.ravel(x)
            return Khh @ x - KIh.T @ fac.solve(KIh @ x)
    else:
        def schur(x: np.ndarray) -> np.ndarray:
            return Khh @ np.ravel(x)
    return LinearOperator((hv.size, hv.size), matvec=schur, dtype=float)


def massless_ode_omega(p: SparseProblem) -> float:
    """omega_max of the massless-contact ODE in its stiffest contact state (module
    docstring); velocity Verlet is stable for dt omega_max < 2."""
    from scipy.sparse.linalg import eigsh

    massless = p.massless
    hv = np.flatnonzero(~massless)
    free = massless.copy()
    # pinned on the obstacle: every dof in a contact row (for a general row, its
    # tangential dofs too: a stiffer state still, so the limit stays a bound)
    free[np.unique(sp.csr_matrix(p.contact.gap_operator(p.nfree)).indices)] = False
    op = condensed_stiffness(sp.csr_matrix(p.K), hv, np.flatnonzero(free))
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
def ode_rhs(t, y, U, o, mu, active):  # pragma: no cover - compiled
    """d/dt (u_h, v_h) = (v_h, M_hh^-1 (F(t) - K U)_h) with U = (u_h, u_m(u_h)) (the
    massless rows under F(t) too); U (the full displacement), mu and active are scratch
    (active: the last evaluation's contact set, the LCP's warm start)."""
    hv = o.hv
    nh, nm, nc = hv.size, o.mv.size, o.at_contact.size
    F = force_at(o.load, o.F, t, np.empty(load_points(o.load)), np.empty(U.size))
    for a in range(nh):
        U[hv[a]] = y[a]
    massless_solve(o, F, U, mu, active, True,
                   (np.empty(nm), np.empty(nm), np.empty(nm), np.empty(nc)))
    dy = np.empty(2 * nh)
    dy[:nh] = y[nh:]
    ah = np.empty(nh)
    heavy_acceleration(o, F, U, np.empty(nh), ah, np.empty(nh))
    dy[nh:] = ah
    return dy


@njit(cache=True)
def ode_samples(Ys, ts, o, U_out, V_out, lam_out):  # pragma: no cover - compiled
    """The full samples from the integrator's (u_h, v_h) columns at times ts: u_m(u_h),
    its derivative and the obstacle's forces (lam_out, n_c per sample)."""
    hv = o.hv
    nh, nm, nc = hv.size, o.mv.size, o.at_contact.size
    scr = (np.empty(nm), np.empty(nm), np.empty(nm), np.empty(nc))
    mu = np.zeros(nc)
    active = np.zeros(nc, np.bool_)
    vals, Fn = np.empty(load_points(o.load)), np.empty(U_out.shape[1])
    for s in range(Ys.shape[1]):
        for a in range(nh):
            U_out[s, hv[a]] = Ys[a, s]
            V_out[s, hv[a]] = Ys[nh + a, s]
        U = U_out[s]
        V = V_out[s]
        F = force_at(o.load, o.F, ts[s], vals, Fn)
        massless_solve(o, F, U, mu, active, False, scr)
        massless_velocity(o, V, active, scr[0], scr[1], scr[2])
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
    LCP's warm start included), so that two runs take the same steps. The right-hand
    side feels the time load at the integrator's stage times."""

    adds_time_load = True
    any_gap_operator = True
    follows_curved = True

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
        F = self.F
        steps = np.arange(0, nsteps + 1, stride)
        if steps[-1] != nsteps:
            steps = np.append(steps, nsteps)
        assert steps.size == n_samples(nsteps, stride)
        t_eval = steps * dt
        U = p.U0.astype(float).copy()
        nc = p.contact.size
        force = np.zeros(nc)  # the last evaluation's contact forces
        ops = massless_ops(split, p)
        active = np.zeros(nc, np.bool_)

        # the compiled right-hand side of these arguments' types, resolved once: solve_ivp
        # calls it thousands of times, and the dispatcher would type the operators' tuple
        # at every call (costlier than the evaluation on small meshes)
        f = _compiled_for(ode_rhs, 0.0, self.y0[:-1], U, ops, force, active)

        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            return np.append(f(float(t), np.ascontiguousarray(y[:-1]), U, ops, force, active),
                             force.sum())

        sol = solve_ivp(rhs, (0.0, float(t_eval[-1])), self.y0.copy(), method="DOP853",
                        t_eval=t_eval, rtol=rtol, atol=self.atol)
        k = sol.t.size
        impulse = np.array(sol.y[-1])
        Us = np.zeros((k, p.nfree))
        Vs = np.zeros((k, p.nfree))
        lam = np.zeros((k, nc))
        ode_samples(np.ascontiguousarray(sol.y[:-1]), np.asarray(sol.t, float), ops, Us, Vs,
                    lam)
        energy = (0.5 * np.einsum("ij,ij->i", Vs, (p.M @ Vs.T).T)
                  + 0.5 * np.einsum("ij,ij->i", Us, (p.K @ Us.T).T) - Us @ F + p.energy_offset)
        gaps = p.gaps(Us) if nc else np.full((k, 1), np.inf)
        area = float(np.sum(p.contact.weights))
        cu = gaps.min(axis=1)
        stats = new_stats(samples=k)
        stats[SAMPLE_IMPULSE:] = impulse
        status = np.zeros(nc, bool)
        stats_gap(stats, float(cu[0]), float(steps[0]) * dt)
        for s in range(1, k):  # the contact statistics at the samples (not the inner steps)
            stats_update(stats, status, lam[s], float(cu[s]), int(steps[s]) * dt)
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
        return Trajectory(t=sol.t[:k], U=Us[:k], V=Vs[:k], contact_u=cu[:k],
                          stress=-lam[:k].sum(axis=1) / area, energy=energy[:k],
                          min_contact_u=float(cu[:k].min()) if k else 0.0,
                          steps_done=int(steps[k - 1]) if k else 0, blowup_time=blow,
                          extra=extra)


def _compiled_for(dispatcher: Any, *args: Any) -> Callable[..., Any]:
    """The compiled specialisation of a numba `dispatcher` for the types of `args` (loaded
    from its cache or compiled, not called): a callable taking arguments of exactly those
    types, without the dispatcher's typing of each argument at every call."""
    return dispatcher.compile(tuple(dispatcher.typeof_pyval(a) for a in args))


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
