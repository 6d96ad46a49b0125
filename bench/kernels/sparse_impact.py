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
  g = -e g(U^{n-1}) exactly. A time-dependent F is weighted over the three levels as
  the stiffness is (F(t_n) for beta = 0). The sample at t_n is (U^n, (U^{n+1} - U^{n-1}) / 2 dt)
  with the force r^n (so the kernel runs one step past the last sample), as in 1D; with
  that centred velocity the vertical momentum obeys the trapezoid rule on the sampled
  force exactly; the impulse the kernel accumulates is that trapezoid plus dt r^0 / 2,
  the change from the data V0 of sample 0 to the centred velocity at level 0.
* `moreau_jean_sparse` (`schemes/moreau_jean.py`): the theta-method on velocities,
  S = M + theta^2 dt^2 K,

      S V^{n+1} = M V^n + dt (F - K U^n) - theta (1 - theta) dt^2 K V^n + C^T P^{n+1},
      U^{n+1} = U^n + dt (theta V^{n+1} + (1 - theta) V^n)

  (a time-dependent F at the theta point t_n + theta dt, where U is weighted),

  with Newton's law 0 <= v_j^{n+1} + e v_j^n _|_ P_j >= 0 on the contact dofs whose
  predicted gap g_j(U^n) + dt/2 v_j^n is <= 0 (P_j = 0 on the others): the LCP on the
  rows and columns of W of that index set. P is an impulse; the per-step contact force
  (the sampled stress, the chatter and peak-force statistics) is P / dt.

Both refuse a problem with massless dofs: an impact law acts on momentum.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit

from contact_bench.api.plugin import Trajectory
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.loop import BLOWN, OK, START_LEVEL, drive
from contact_bench.kernels.contact import (
    ContactOps,
    Friction,
    contact_ops,
    coulomb,
    curved_ops,
    follow,
    friction_ops,
    gaps,
    hold,
    is_curved,
    push,
    row_dot,
    row_value,
    selection_rows,
)
from contact_bench.kernels.csr import CSR, csr_arrays, matvec
from contact_bench.kernels.linalg import LU, lu
from contact_bench.kernels.recording import csr_energy, plain_sample
from contact_bench.kernels.solvers import lcp_solve
from contact_bench.kernels.sparse import Factor, initial_acceleration
from contact_bench.kernels.stepper import LoopStepper, with_tforce
from contact_bench.kernels.time_load import (
    LoadOps,
    NoLoad,
    force_at,
    has_time_load,
    load_ops,
    load_scratch,
)


class ImpactOps(NamedTuple):
    """An impact law's operators: M, K, F, S's factor (or S's diagonal `sdiag`, non-empty
    when S is diagonal, with each contact row's 1 / (G_j S^-1 G_j^T), `sw`), the gaps and
    W = G S^-1 G^T, Z = S^-1 G^T (kept or not), the scheme's two parameters
    (Paoli-Schatzman: beta, e; Moreau-Jean: theta, e), dt, the energy's offset and the
    LCP's tolerance."""

    M: CSR
    K: CSR
    F: np.ndarray
    sdiag: np.ndarray
    sw: np.ndarray
    fac: LU
    ct: ContactOps
    weights: np.ndarray
    a: float  # beta (Paoli-Schatzman) or theta (Moreau-Jean)
    e: float
    dt: float
    offset: float
    tol: float
    load: LoadOps | NoLoad  # the time load (`contact_bench.kernels.time_load`)


class ImpactState(NamedTuple):
    """U^{n-1} (Paoli-Schatzman), U^n, V^n (Moreau-Jean), the next state X, the contact
    forces, the LCP's unknowns and active set, the load, scratch."""

    Um: np.ndarray
    U: np.ndarray
    V: np.ndarray
    X: np.ndarray
    force: np.ndarray
    mu: np.ndarray
    active: np.ndarray
    was: np.ndarray
    rhs: np.ndarray
    tmp: np.ndarray
    w: np.ndarray
    work: np.ndarray
    gf: np.ndarray
    gm: np.ndarray
    idx: np.ndarray
    Fn: np.ndarray
    Fa: np.ndarray
    Fb: np.ndarray
    vals: np.ndarray


@njit(cache=True)
def ps_step(o, s, step):  # pragma: no cover - compiled
    """Paoli-Schatzman: level `step`'s contact force r^n and U^{n+1} (in X) from
    (U^{n-1}, U^n) (module docstring); level 0 from the start (`loop.START_LEVEL`). A
    time load is weighted as the stiffness is: beta F(t_{n+1}) + (1 - 2 beta) F(t_n) +
    beta F(t_{n-1}) (F(t_n) for the explicit beta = 0)."""
    Um, U, X, rhs, tmp, w, gf, gm = s.Um, s.U, s.X, s.rhs, s.tmp, s.w, s.gf, s.gm
    ct, beta, e, dt = o.ct, o.a, o.e, o.dt
    sel = ct.sel
    n = U.size
    nc = sel.size
    dt2 = dt * dt
    diag = o.sdiag.size > 0
    if step > 0:  # level step - 1 is sampled: move on to level step
        for i in range(n):
            Um[i] = U[i]
            U[i] = X[i]
    # S X = M (2 U^n - U^{n-1}) - dt^2 K ((1 - 2 beta) U^n + beta U^{n-1}) + dt^2 F
    for i in range(n):
        tmp[i] = 2.0 * U[i] - Um[i]
    matvec(o.M, tmp, rhs)
    for i in range(n):
        tmp[i] = (1.0 - 2.0 * beta) * U[i] + beta * Um[i]
    matvec(o.K, tmp, w)
    F = force_at(o.load, o.F, step * dt, s.vals, s.Fn)
    if has_time_load(o.load) and beta != 0.0:
        Fa = force_at(o.load, o.F, (step - 1) * dt, s.vals, s.Fa)
        Fb = force_at(o.load, o.F, (step + 1) * dt, s.vals, s.Fb)
        for i in range(n):
            Fa[i] = beta * (Fa[i] + Fb[i]) + (1.0 - 2.0 * beta) * F[i]
        F = Fa
    for i in range(n):
        rhs[i] += dt2 * (F[i] - w[i])
    if diag:
        for i in range(n):
            X[i] = rhs[i] / o.sdiag[i]
    else:
        lu(o.fac, rhs, X, s.work)
    gaps(ct, Um, gm)
    gaps(ct, X, gf)  # the last: a curved obstacle's tangent at the prediction X
    pen = False
    finite = True
    for j in range(nc):  # the constrained combination g(X) + e g(U^{n-1})
        gf[j] = gf[j] + e * gm[j]
        pen = pen or gf[j] < 0.0
        finite = finite and np.isfinite(gf[j])
    if not finite:  # blown up between samples: no contact problem to solve
        return BLOWN
    mu, lam, active = s.mu, s.force, s.active
    if pen:
        if diag:  # W diagonal (rows on distinct dofs): the projection row by row
            Gp, Gi, Gx = ct.G
            for j in range(nc):
                active[j] = gf[j] < 0.0
                d = sel[j]
                if d >= 0:
                    mu[j] = -gf[j] * o.sdiag[d] if active[j] else 0.0
                else:
                    swj = o.sw[j]
                    if is_curved(ct):  # 1 / (G_j S^-1 G_j^T) of the moving normal
                        acc = 0.0
                        for kk in range(Gp[j], Gp[j + 1]):
                            acc += Gx[kk] * Gx[kk] / o.sdiag[Gi[kk]]
                        swj = 1.0 / acc
                    mu[j] = -gf[j] * swj if active[j] else 0.0
                    for kk in range(Gp[j], Gp[j + 1]):
                        X[Gi[kk]] += Gx[kk] * mu[j] / o.sdiag[Gi[kk]]
        else:
            lcp_solve(ct.W, gf, mu, active, o.tol, s.was[0])
            push(ct, o.fac, mu, X, (rhs, w, s.work))
        for j in range(nc):  # on the constraint exactly
            gm[j] = -ct.gap0[j] - e * gm[j]
        hold(ct, active, X, gm)
        for j in range(nc):
            lam[j] = mu[j] / dt2
    else:
        mu[:] = 0.0
        lam[:] = 0.0
    s.was[0] = pen
    return OK


@njit(cache=True)
def ps_sample(o, s):  # pragma: no cover - compiled
    """Level n: U^n with the centred velocity (U^{n+1} - U^{n-1}) / 2 dt and force r^n."""
    for i in range(s.U.size):
        s.tmp[i] = (s.X[i] - s.Um[i]) / (2.0 * o.dt)
    en = csr_energy(o.M, o.K, o.F, s.U, s.tmp, o.offset, s.w)
    return en, -s.force.sum() / o.weights.sum(), s.tmp


@njit(cache=True)
def ps_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `ps_step`."""
    return drive(ps_step, ps_sample, ops, st, rec, nsteps, stride)


def _refuse_massless(p: SparseProblem, what: str) -> None:
    if np.any(p.massless):
        raise ValueError(f"{what} needs mass at every dof (an impact law acts on momentum); "
                         "this problem has massless dofs")


class PaoliSchatzmanStepper(LoopStepper):
    """`paoli_schatzman_sparse` prepared: S factored (unless diagonal), the Delassus
    matrix and the state (U^{-1}, U^0) computed once."""

    adds_time_load = True
    any_gap_operator = True
    follows_curved = True
    loop = staticmethod(ps_loop)

    def __init__(self, p: SparseProblem, dt: float, e: float, beta: float) -> None:
        _refuse_massless(p, "restitution (Paoli-Schatzman)")
        super().__init__(p, dt)
        dt, e, beta = self.dt, float(e), float(beta)
        n = p.nfree
        G = sp.csr_matrix(p.contact.gap_operator(n))
        gap0 = np.asarray(p.contact.gap0, float)
        S = sp.csr_matrix(p.M + (beta * dt * dt) * p.K)
        sd = np.asarray(S.diagonal(), float)
        # a diagonal S with rows on distinct dofs: no factor, no Delassus matrix, W =
        # diag(G_j S^-1 G_j^T); rows sharing dofs (node-to-segment rows) couple through
        # W, so S is factored like any other and the LCP solved
        diag = (S.nnz == np.count_nonzero(sd)
                and (abs(G) @ abs(G).T).nnz <= G.shape[0])
        if diag:
            fac = Factor.of(sp.identity(1, format="csc"))
            ct = ContactOps(csr_arrays(G), csr_arrays(G.T), gap0, selection_rows(G),
                            np.zeros((1, 1)), np.zeros((1, 1)), False)
            if p.contact.obstacle is not None:  # G, G^T, gap0 follow it (W unused)
                ct = curved_ops(Factor.of(sp.csc_matrix(sp.diags(sd))), p.contact.obstacle,
                                keep=False)
            sw = 1.0 / np.asarray(G.multiply(G) @ (1.0 / sd)).ravel()
        else:
            fac = Factor.of(S)
            ct = contact_ops(fac, G, gap0, obstacle=p.contact.obstacle)
            sw = np.zeros(0)
        U = p.U0.astype(float).copy()
        self.initial = (U - dt * p.V0 + 0.5 * dt * dt * initial_acceleration(p), U)  # (Um, U)
        # the centred momentum changes by dt (r^{n-1} + r^n) / 2 from level n-1 to n; at
        # level 0 by dt r^0 / 2 from the data V0 (sample 0) to the centred velocity
        self.gamma = 0.5
        self.start = START_LEVEL
        tol = 1e-13 * max(float(np.max(np.abs(U))),
                          float(np.max(np.abs(p.contact.gap0), initial=0.0)), 1e-300)
        self.ops = ImpactOps(csr_arrays(p.M), csr_arrays(p.K), np.asarray(p.F, float),
                             sd if diag else np.zeros(0), sw, fac.arrays, ct,
                             np.asarray(p.contact.weights, float), beta, e, dt,
                             float(p.energy_offset), tol, load_ops(p))

    def new_state(self) -> ImpactState:
        Um, U = (a.copy() for a in self.initial)
        return impact_state(Um, U, np.zeros(0), self.ops)


def impact_state(Um: np.ndarray, U: np.ndarray, V: np.ndarray, o: ImpactOps) -> ImpactState:
    """A fresh `ImpactState` from (U^{-1}, U^0) or (U^0, V^0), zeroed scratch."""
    n, nc = U.size, o.ct.gap0.size
    vals, Fn = load_scratch(o.load, n)
    return ImpactState(Um, U, V, np.empty(n), np.zeros(nc), np.zeros(nc),
                       np.zeros(nc, np.bool_), np.zeros(1, np.bool_), np.empty(n),
                       np.empty(n), np.empty(n), np.empty(n), np.empty(nc), np.empty(nc),
                       np.empty(nc, np.int64), Fn, np.empty(Fn.size), np.empty(Fn.size), vals)


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
def mj_step(o, s, step):  # pragma: no cover - compiled
    """Moreau-Jean on (U, V) in place (module docstring); F is the load at the theta
    point t_n + theta dt, where the step's velocities and stiffness are weighted."""
    U, V, X, rhs, ku, kv = s.U, s.V, s.X, s.rhs, s.tmp, s.w
    ct, theta, e, dt = o.ct, o.a, o.e, o.dt
    sel = ct.sel
    n = U.size
    nc = sel.size
    c = theta * (1.0 - theta) * dt * dt
    follow(ct, U, s.gf)  # a curved obstacle: its tangent at U^n
    # S X = M V + dt (F - K U) - c K V: the free velocity
    F = force_at(o.load, o.F, (step - 1.0 + theta) * dt, s.vals, s.Fn)
    matvec(o.M, V, rhs)
    matvec(o.K, U, ku)
    matvec(o.K, V, kv)
    for i in range(n):
        rhs[i] += dt * (F[i] - ku[i]) - c * kv[i]
    lu(o.fac, rhs, X, s.work)
    # the index set: predicted gap <= 0; Newton's law on its points
    idx, mu, active, held = s.idx, s.mu, s.active, s.gm
    m = 0
    pen = False
    for j in range(nc):
        d = sel[j]
        if d >= 0:
            xn, vn, un = X[d], V[d], U[d]
        else:
            xn, vn, un = row_dot(ct.G, j, X), row_dot(ct.G, j, V), row_dot(ct.G, j, U)
        if not np.isfinite(xn):  # blown up between samples
            return BLOWN
        held[j] = -e * vn  # an active selection row's velocity, exactly
        if ct.gap0[j] + un + 0.5 * dt * vn <= 0.0:
            idx[m] = j
            m += 1
            pen = pen or xn + e * vn < 0.0
    mu[:] = 0.0
    active[:] = False
    if pen:
        Ws = np.empty((m, m))
        qs = np.empty(m)
        ms = np.zeros(m)
        acts = np.zeros(m, np.bool_)
        for a in range(m):
            j = idx[a]
            d = sel[j]
            qs[a] = (X[d] + e * V[d]) if d >= 0 else (row_dot(ct.G, j, X)
                                                       + e * row_dot(ct.G, j, V))
            for b in range(m):
                Ws[a, b] = ct.W[j, idx[b]]
        lcp_solve(Ws, qs, ms, acts, o.tol, False)
        for a in range(m):
            mu[idx[a]] = ms[a]
            active[idx[a]] = acts[a]
        push(ct, o.fac, mu, X, (rhs, kv, s.work))
        hold(ct, active, X, held)  # on the law exactly
    for j in range(nc):
        s.force[j] = mu[j] / dt  # the impulse as a mean force over the step
    for i in range(n):
        U[i] += dt * (theta * X[i] + (1.0 - theta) * V[i])
        V[i] = X[i]
    return OK


@njit(cache=True)
def mj_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `mj_step`."""
    return drive(mj_step, plain_sample, ops, st, rec, nsteps, stride)


# ------------------------------------------------- Moreau-Jean with Coulomb friction


FrictionalImpactState = with_tforce(
    ImpactState, "FrictionalImpactState",
    """`ImpactState` with the step's force on each tangent row (`tforce`: its impulse over
    dt); `mu` holds (P_n, P_t).""")


class FrictionalImpactOps(NamedTuple):
    """Moreau-Jean's operators (`ImpactOps`) and the frictional contact (`Friction`)."""

    base: ImpactOps
    fr: Friction


@njit(cache=True)
def mjf_step(o, s, step):  # pragma: no cover - compiled
    """Moreau-Jean with the Coulomb cone on velocities: the step of `mj_step`, with the
    impulses (P_n, P_t) of the points whose predicted gap is <= 0 solving Signorini on
    v_n^{n+1} + e v_n^n and Coulomb on v_t^{n+1} (`contact.coulomb`): a sliding point's
    tangential impulse is mu P_n against its slip, exactly. s.mu holds (P_n, P_t), the
    next step's warm start."""
    b, fr = o.base, o.fr
    U, V, X, rhs, ku, kv = s.U, s.V, s.X, s.rhs, s.tmp, s.w
    ct, cf, theta, e, dt = b.ct, fr.ct, b.a, b.e, b.dt
    n = U.size
    nc = ct.gap0.size
    c = theta * (1.0 - theta) * dt * dt
    F = force_at(b.load, b.F, (step - 1.0 + theta) * dt, s.vals, s.Fn)
    matvec(b.M, V, rhs)
    matvec(b.K, U, ku)
    matvec(b.K, V, kv)
    for i in range(n):
        rhs[i] += dt * (F[i] - ku[i]) - c * kv[i]
    lu(b.fac, rhs, X, s.work)
    r, active, held, idx = s.mu, s.active, s.gm, s.idx
    nh = r.size
    q = np.empty(nh)
    m = 0
    pen = False
    for j in range(nc):
        xn, vn, un = row_value(ct, j, X), row_value(ct, j, V), row_value(ct, j, U)
        if not np.isfinite(xn):  # blown up between samples
            return BLOWN
        held[j] = -e * vn
        q[j] = xn + e * vn
        if ct.gap0[j] + un + 0.5 * dt * vn <= 0.0:
            idx[m] = j
            m += 1
            pen = pen or q[j] < 0.0
    active[:] = False
    if pen:
        for i in range(nc, nh):
            q[i] = row_value(cf, i, X)
        coulomb(fr, idx[:m], q, r, max(b.tol, 1e-13 * np.max(np.abs(q))))
        push(cf, b.fac, r, X, (rhs, kv, s.work))
        for j in range(nc):
            active[j] = r[j] > 0.0
        hold(ct, active, X, held)  # on Newton's law exactly
    else:
        r[:] = 0.0
    for j in range(nc):
        s.force[j] = r[j] / dt
    for i in range(nc, nh):
        s.tforce[i - nc] = r[i] / dt
    for i in range(n):
        U[i] += dt * (theta * X[i] + (1.0 - theta) * V[i])
        V[i] = X[i]
    return OK


@njit(cache=True)
def mjf_sample(o, s):  # pragma: no cover - compiled
    """`plain_sample` of the base operators."""
    return plain_sample(o.base, s)


@njit(cache=True)
def mjf_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `mjf_step`."""
    return drive(mjf_step, mjf_sample, ops, st, rec, nsteps, stride)


class MoreauJeanStepper(LoopStepper):
    """`moreau_jean_sparse` prepared: S factored and the Delassus matrix computed once."""

    adds_time_load = True
    any_gap_operator = True
    follows_curved = True
    loop = staticmethod(mj_loop)

    def __init__(self, p: SparseProblem, dt: float, e: float, theta: float) -> None:
        _refuse_massless(p, "moreau_jean")
        super().__init__(p, dt)
        dt, e, theta = self.dt, float(e), float(theta)
        n = p.nfree
        fac = Factor.of(p.M + ((theta * dt) ** 2) * p.K)
        self.factor = fac
        ct = contact_ops(fac, p.contact.gap_operator(n), np.asarray(p.contact.gap0, float),
                         obstacle=p.contact.obstacle)
        U, V = p.U0.astype(float).copy(), p.V0.astype(float).copy()
        self.initial = (U, V)
        # a velocity-level tolerance: round-off of the larger of the data's speeds
        vscale = max(float(np.max(np.abs(V))), float(np.max(np.abs(U))) / dt, 1e-300)
        self.gamma = 1.0  # the impulse P = dt lam itself
        self.ops = ImpactOps(csr_arrays(p.M), csr_arrays(p.K), np.asarray(p.F, float),
                             np.zeros(0), np.zeros(0), fac.arrays, ct,
                             np.asarray(p.contact.weights, float), theta, e, dt,
                             float(p.energy_offset), 1e-13 * vscale, load_ops(p))

    def new_state(self) -> ImpactState:
        U, V = (a.copy() for a in self.initial)
        return impact_state(np.zeros(0), U, V, self.ops)


class FrictionalMoreauJeanStepper(MoreauJeanStepper):
    """`MoreauJeanStepper` on a problem with friction (`ContactSet.frictional`): the
    same set-up, the stacked normal and tangent rows' Delassus matrix, `mjf_step`. Those
    rows are fixed for the run, so it refuses a curved obstacle (`SparseStepper`)."""

    follows_curved = False
    loop = staticmethod(mjf_loop)

    def __init__(self, p: SparseProblem, dt: float, e: float, theta: float) -> None:
        super().__init__(p, dt, e, theta)
        self.ops = FrictionalImpactOps(self.ops, friction_ops(self.factor, p.contact,
                                                              p.nfree))

    def new_state(self) -> FrictionalImpactState:
        U, V = (a.copy() for a in self.initial)
        st = impact_state(np.zeros(0), U, V, self.ops.base)
        nc, nh = st.force.size, self.ops.fr.ct.gap0.size
        return FrictionalImpactState(*st._replace(mu=np.zeros(nh)), np.zeros(nh - nc))


def prepare_moreau_jean(p: SparseProblem, dt: float, e: float, theta: float
                        ) -> MoreauJeanStepper:
    """Moreau-Jean with restitution e and the theta-method (module docstring); with
    friction (`ContactSet.frictional`) the Coulomb cone on velocities (`mjf_step`).
    ValueError on a problem with massless dofs."""
    if p.contact.frictional:
        return FrictionalMoreauJeanStepper(p, dt, e, theta)
    return MoreauJeanStepper(p, dt, e, theta)


def moreau_jean_sparse(p: SparseProblem, dt: float, nsteps: int, stride: int, e: float,
                       theta: float) -> Trajectory:
    """`prepare_moreau_jean(p, dt, e, theta).run(nsteps, stride)`."""
    return prepare_moreau_jean(p, dt, e, theta).run(nsteps, stride)


__all__ = ["MoreauJeanStepper", "PaoliSchatzmanStepper", "moreau_jean_sparse",
           "paoli_schatzman_sparse", "prepare_moreau_jean", "prepare_paoli_schatzman"]
