"""Explicit stepping of a piecewise-linear contact law on the general sparse problem.

The explicit (beta = 0) counterpart of `contact_bench.kernels.sparse.newmark_sparse`
with a `ContactLaw` (penalty springs, Nitsche), for any mass variant:

    U_{n+1} = U_n + dt V_n + dt^2/2 A_n,
    M A_{n+1} = F - K' U_{n+1} + Q^T mu(U_{n+1}),   mu_i = c_i max(0, -y_i),  y = P U + y0,
    V_{n+1} = V_n + dt ((1 - gamma) A_n + gamma A_{n+1})

(gamma = 1/2: the central difference). The law is evaluated at U_{n+1}, explicitly. A
diagonal M (lumped) is a division, any other M one solve with its factor (`Factor`,
once outside the loop).

Massless dofs (zero mass rows: the redistributed variants) have no acceleration: they
are quasi-static, solved each step from their own rows with the law,

    K'_mm u_m + K'_mh u_h - Q_m^T mu = F_m,   mu = c max(0, -(P U + y0)),

a piecewise-linear problem in mu: with the free solution u_f (K'_mm factored once) and
Z = K'_mm^-1 Q_m^T, W = P_m Z (n_c x n_c, computed once), y = y_f + W mu, solved
exactly by `penalty_solve`'s active-set iteration, then u_m = u_f + Z mu (the same
elimination as `quasistatic_sparse`'s exact contact, with the law in place of the
complementarity). Their velocity is the backward difference. The response matrices
(Z here, M^-1 C^T in `taylor_flanagan_sparse`) are kept dense when they hold at most
`KEEP_Z_ENTRIES` values; beyond, only their n_c x n_c rows at the contact dofs are kept
and the correction Z mu is one more solve with the factor already made (matrix-free, as
`newmark_sparse` does): memory O(n + n_c^2) at any size.

`taylor_flanagan_sparse`: the Taylor-Flanagan central difference with a factored
(consistent) mass, the penetrating contact dofs stopped together through the Delassus
matrix C M^-1 C^T (its docstring).

`stable_dt`: the step's limit 1 / (sqrt(gamma/2 - beta) omega_max) (beta = 0, gamma =
1/2: 2 / omega_max), with omega_max^2 the largest generalized eigenvalue (in modulus) of
(K' + the law's stiffness, M), both with no contact dof active and with every one, the
massless dofs eliminated statically, by scipy's ARPACK (`eigs`: Nitsche's active
stiffness K' + Q^T diag(c) P is unsymmetric for theta != 1) on the operator M^-1 K'.
For the penalty every active set's stiffness lies between the two (the springs add a
positive semi-definite term); for Nitsche the two states are an estimate, checked by
runs at 0.95 and 1.05 times it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.sparse.linalg import ArpackNoConvergence, LinearOperator, eigs

from contact_bench.api.plugin import Trajectory
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.loop import BLOWN, OK, drive
from contact_bench.kernels.contact import (
    ContactOps,
    gaps,
    row_dot,
    selection_rows,
    spread,
)
from contact_bench.kernels.csr import CSR, csr_arrays, matvec
from contact_bench.kernels.linalg import LU, lu
from contact_bench.kernels.sparse import (
    ContactLaw,
    Factor,
    initial_acceleration,
    lcp_solve,
    penalty_solve,
    response_rows,
)
from contact_bench.kernels.stepper import LoopStepper
from contact_bench.kernels.time_load import (
    LoadOps,
    NoLoad,
    force_at,
    initial_load,
    load_ops,
    load_scratch,
)

#: below this many dofs with mass the eigenvalue of `omega_max_squared` is taken densely
SMALL_DENSE = 64
#: largest dense response matrix (values) the explicit steppers keep; beyond, matrix-free
KEEP_Z_ENTRIES = 10_000_000


class ExplicitLawOps(NamedTuple):
    """Explicit Newmark with a contact law: M, K' (K with the law's stiffness), F, the
    split into dofs with mass (hv) and massless ones (mv) with K''s rows Kh = K'[hv] and
    Km = K'[mv] (massless columns dropped), K'_mm's and M_hh's factors (or M_hh's
    diagonal), the law (y = P U + y0, force Q^T mu, mu = c max(0, -y); QT = Q^T, QTm its
    massless rows), the massless elimination's W and Z (kept or not)."""

    M: CSR
    K: CSR
    F: np.ndarray
    hv: np.ndarray
    mv: np.ndarray
    Kh: CSR
    Km: CSR
    mfac: LU
    hfac: LU
    diag_h: np.ndarray
    P: CSR
    QT: CSR
    QTm: CSR
    y0: np.ndarray
    c: np.ndarray
    ew: float
    sc: np.ndarray
    fscale: float
    W: np.ndarray
    Z: np.ndarray
    keep_z: bool
    weights: np.ndarray
    dt: float
    gamma: float
    offset: float
    load: LoadOps | NoLoad  # the time load (`contact_bench.kernels.time_load`)


class ExplicitLawState(NamedTuple):
    """(U, V, A), the law's forces (mu, and the contact points' force fscale mu), its
    active set and values y, the load, scratch."""

    U: np.ndarray
    V: np.ndarray
    A: np.ndarray
    force: np.ndarray
    mu: np.ndarray
    active: np.ndarray
    y: np.ndarray
    f: np.ndarray
    rm: np.ndarray
    um: np.ndarray
    wm: np.ndarray
    zw: np.ndarray
    rh: np.ndarray
    ah: np.ndarray
    wh: np.ndarray
    w: np.ndarray
    Fn: np.ndarray
    vals: np.ndarray


@njit(cache=True)
def explicit_law_step(o, s, step):  # pragma: no cover - compiled
    """Advance (U, V, A) in place (module docstring); the massless rows and A_{n+1} at
    U_{n+1} with the load at t_{n+1}."""
    U, V, A, mu, y, dt, gamma = s.U, s.V, s.A, s.mu, s.y, o.dt, o.gamma
    F = force_at(o.load, o.F, step * dt, s.vals, s.Fn)
    hv, mv = o.hv, o.mv
    rm, um, wm, rh, ah = s.rm, s.um, s.wm, s.rh, s.ah
    nh, nm, nc = hv.size, mv.size, o.y0.size
    for a in range(nh):
        i = hv[a]
        U[i] += dt * V[i] + 0.5 * dt * dt * A[i]
    if nm:  # the massless dofs from their rows, the law solved exactly
        matvec(o.Km, U, rm)
        for b in range(nm):
            rm[b] = F[mv[b]] - rm[b]
        lu(o.mfac, rm, um, wm)
        for b in range(nm):
            i = mv[b]
            wm[b] = U[i]  # the old position, for the velocity
            U[i] = um[b]
        matvec(o.P, U, y)
        pen = False
        for j in range(nc):
            y[j] += o.y0[j]
            pen = pen or y[j] < 0.0
        if pen:
            penalty_solve(o.W, y, o.c, mu, s.active)
            if o.keep_z:
                on = np.flatnonzero(mu)
                for b in range(nm):
                    acc = 0.0
                    for j in on:
                        acc += o.Z[b, j] * mu[j]
                    U[mv[b]] += acc
            else:  # matrix-free: K'_mm^-1 Q_m^T mu (wm holds the old positions)
                matvec(o.QTm, mu, rm)
                lu(o.mfac, rm, um, s.zw)
                for b in range(nm):
                    U[mv[b]] += um[b]
        for b in range(nm):
            i = mv[b]
            V[i] = (U[i] - wm[b]) / dt
    matvec(o.P, U, y)  # the law at U_{n+1}
    for j in range(nc):
        y[j] += o.y0[j]
        mu[j] = o.c[j] * max(0.0, -y[j])
        s.force[j] = o.fscale * mu[j]
    matvec(o.QT, mu, s.f)  # Q^T mu
    matvec(o.Kh, U, rh)
    for a in range(nh):
        i = hv[a]
        rh[a] = F[i] - rh[a] + s.f[i]
    if o.diag_h.size:
        for a in range(nh):
            ah[a] = rh[a] / o.diag_h[a]
    else:
        lu(o.hfac, rh, ah, s.wh)
    for a in range(nh):
        i = hv[a]
        V[i] += dt * ((1.0 - gamma) * A[i] + gamma * ah[a])
        A[i] = ah[a]
    return OK


@njit(cache=True)
def explicit_law_sample(o, s):  # pragma: no cover - compiled
    """The energy with the law's (its y at U_{n+1}), the law's stress and V."""
    U, V, w = s.U, s.V, s.w
    matvec(o.M, V, w)
    e = 0.5 * (V @ w)
    matvec(o.K, U, w)
    e += 0.5 * (U @ w) - o.F @ U + o.offset
    st = 0.0
    for j in range(o.y0.size):  # the law's energy and stress
        yn = min(0.0, s.y[j])
        e += 0.5 * o.ew * o.c[j] * yn * yn
        st += o.sc[j] * yn
    return e, st / o.weights.sum(), V


@njit(cache=True)
def explicit_law_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `explicit_law_step`."""
    return drive(explicit_law_step, explicit_law_sample, ops, st, rec, nsteps, stride)


def keeps_response(rows: int, nc: int) -> bool:
    """Whether a dense response matrix of rows x n_c values is kept (at most
    `KEEP_Z_ENTRIES` values, read at each call); else the steppers go matrix-free."""
    return rows * nc <= KEEP_Z_ENTRIES


def penalty_law(p: SparseProblem, kappa: np.ndarray) -> ContactLaw:
    """Penalty springs kappa_i on the contact points' gaps as a `ContactLaw` (P = Q = G,
    the gap operator)."""
    C = p.contact.gap_operator(p.nfree)
    kappa = np.asarray(kappa, float)
    return ContactLaw(C, C, np.asarray(p.contact.gap0, float), kappa, 1.0, kappa,
                      friction=True)


def _stiffness(p: SparseProblem, law: ContactLaw) -> sp.csr_matrix:
    return sp.csr_matrix(p.K if law.K_extra is None else p.K + law.K_extra)


class ExplicitLawStepper(LoopStepper):
    """`explicit_law_sparse` prepared: K'_mm and M_hh factored, the massless elimination's
    matrices, the initial acceleration and sample 0's energy and stress computed once."""

    adds_time_load = True
    any_gap_operator = True
    loop = staticmethod(explicit_law_loop)

    def __init__(self, p: SparseProblem, dt: float, gamma: float, law: ContactLaw) -> None:
        super().__init__(p, dt)
        dt, gamma = self.dt, float(gamma)
        n = p.nfree
        K = _stiffness(p, law)
        Pm, Qm = sp.csr_matrix(law.P), sp.csr_matrix(law.Q)
        y0, c = np.asarray(law.y0, float), np.asarray(law.c, float)
        massless = p.massless
        hv = np.flatnonzero(~massless).astype(np.int64)
        mv = np.flatnonzero(massless).astype(np.int64)
        nc = p.contact.size
        keep_z = keeps_response(mv.size, nc)
        if mv.size:
            Kmm = K[mv][:, mv]
            mfac = Factor.of(Kmm)
            Qmt = sp.csc_matrix(Qm[:, mv].T)
            Pmm = sp.csr_matrix(Pm[:, mv])
            if keep_z:
                Z = mfac.solve_many(Qmt)
                W = np.ascontiguousarray(Pmm @ Z)
            else:  # W = P_m K'_mm^-1 Q_m^T column by column, Z not kept
                Z = np.zeros((1, 1))
                W = np.empty((nc, nc))
                for j0, j1, X in mfac.solve_blocks(Qmt):
                    W[:, j0:j1] = Pmm @ X
            keep = np.ones(n)
            keep[mv] = 0.0
            Kmh = sp.csr_matrix(K[mv] @ sp.diags(keep))
            Kmh.eliminate_zeros()
        else:
            mfac = Factor.of(sp.identity(1, format="csc"))
            Z, W = np.zeros((0, nc)), np.zeros((nc, nc))
            Kmh = sp.csr_matrix((0, n))
        Mhh = sp.csr_matrix(p.M[hv][:, hv])
        diag = Mhh.nnz == np.count_nonzero(Mhh.diagonal())
        hfac = Factor.of(sp.identity(1, format="csc")) if diag else Factor.of(Mhh)
        U, V = p.U0.astype(float).copy(), p.V0.astype(float).copy()
        mu0 = c * np.maximum(0.0, -(Pm @ U + y0))
        A = initial_acceleration(p, initial_load(p) - K @ U + Qm.T @ mu0)
        self.initial = (U, V, A)
        yneg = np.minimum(0.0, Pm @ U + y0)
        self.sample0 = {  # sample 0's energy and stress, with the law's terms
            "energy": float(p.energy(U, V) + 0.5 * U @ ((K - p.K) @ U)
                            + 0.5 * float(law.ew) * np.sum(c * yneg * yneg)),
            "stress": float(np.sum(np.asarray(law.sc, float) * yneg)
                            / np.sum(p.contact.weights))}
        # the law's total force at t = 0 (in the initial acceleration): the impulse's start
        self.force0 = float(law.fscale) * float(np.sum(mu0))
        self.gamma = gamma
        self.ops = ExplicitLawOps(
            csr_arrays(p.M), csr_arrays(K), np.asarray(p.F, float), hv, mv,
            csr_arrays(K[hv]), csr_arrays(Kmh), mfac.arrays, hfac.arrays,
            Mhh.diagonal() if diag else np.zeros(0), csr_arrays(Pm), csr_arrays(Qm.T),
            csr_arrays(sp.csr_matrix(Qm[:, mv].T)), y0, c, float(law.ew),
            np.asarray(law.sc, float), float(law.fscale), W, np.ascontiguousarray(Z), keep_z,
            np.asarray(p.contact.weights, float), self.dt, gamma, float(p.energy_offset),
            load_ops(p))

    def new_state(self) -> ExplicitLawState:
        n, o = self.problem.nfree, self.ops
        nh, nm, nc = o.hv.size, o.mv.size, o.y0.size
        U, V, A = (a.copy() for a in self.initial)
        vals, Fn = load_scratch(o.load, n)
        return ExplicitLawState(U, V, A, np.zeros(nc), np.zeros(nc), np.zeros(nc, np.bool_),
                                np.empty(nc), np.empty(n), np.empty(nm), np.empty(nm),
                                np.empty(nm), np.empty(nm), np.empty(nh), np.empty(nh),
                                np.empty(nh), np.empty(n), Fn, vals)


def prepare_explicit_law(p: SparseProblem, dt: float, gamma: float, law: ContactLaw
                         ) -> ExplicitLawStepper:
    """Explicit Newmark (beta = 0, gamma) with the contact `law` at t_{n+1} (module
    docstring). The sampled energy is newmark_sparse's: 1/2 V.M.V + 1/2 U.K'.U - F.U +
    offset + ew sum_i c_i / 2 min(0, y_i)^2; the stress sum_i sc_i min(0, y_i) / area;
    the contact force of dof i (chatter, contact times, peak) fscale c_i max(0, -y_i)."""
    return ExplicitLawStepper(p, dt, gamma, law)


def explicit_law_sparse(p: SparseProblem, dt: float, nsteps: int, stride: int, gamma: float,
                        law: ContactLaw) -> Trajectory:
    """`prepare_explicit_law(p, dt, gamma, law).run(nsteps, stride)`."""
    return prepare_explicit_law(p, dt, gamma, law).run(nsteps, stride)


def omega_max_squared(p: SparseProblem, law: ContactLaw | None = None,
                      active: bool = True) -> float:
    """The largest generalized eigenvalue (modulus) of (K' + Q^T diag(c) P, M) with every
    contact dof of the law active (`active`; else of (K', M)), of (K, M) without a law;
    the massless dofs eliminated statically (the Schur complement of their K block):
    ARPACK on the operator M_hh^-1 K_s (M_hh factored once, or diagonal)."""
    K = sp.csr_matrix(p.K)
    if law is not None:
        K = _stiffness(p, law)
        if active:
            K = sp.csr_matrix(K + sp.csr_matrix(law.Q).T @ sp.diags(np.asarray(law.c, float))
                              @ sp.csr_matrix(law.P))
    massless = p.massless
    hv, mv = np.flatnonzero(~massless), np.flatnonzero(massless)
    Khh = sp.csr_matrix(K[hv][:, hv])
    Mhh = sp.csr_matrix(p.M[hv][:, hv])
    if mv.size:
        mfac = Factor.of(sp.csr_matrix(K[mv][:, mv]))
        Khm, Kmh = sp.csr_matrix(K[hv][:, mv]), sp.csr_matrix(K[mv][:, hv])

        def kmul(x: np.ndarray) -> np.ndarray:
            return Khh @ x - Khm @ mfac.solve(Kmh @ x)
    else:
        def kmul(x: np.ndarray) -> np.ndarray:
            return Khh @ x
    d = Mhh.diagonal()
    if Mhh.nnz == np.count_nonzero(d):
        def op(x: np.ndarray) -> np.ndarray:
            return kmul(np.ravel(x)) / d
    else:
        mh = Factor.of(Mhh)

        def op(x: np.ndarray) -> np.ndarray:
            return mh.solve(kmul(np.ravel(x)))
    if hv.size <= SMALL_DENSE:  # ARPACK needs n > 3; a few dozen columns are cheap
        cols = np.column_stack([op(e) for e in np.eye(hv.size)]) if hv.size else np.zeros((1, 1))
        return float(np.max(np.abs(np.linalg.eigvals(cols))))
    A = LinearOperator((hv.size, hv.size), matvec=op, dtype=float)
    # a random start: a symmetric one (ones) never sees the antisymmetric modes of a
    # symmetric scene, and the largest may be one of them
    try:
        val = eigs(A, k=1, which="LM", return_eigenvectors=False, tol=1e-8, maxiter=100_000,
                   v0=np.random.default_rng(0).standard_normal(hv.size))
    except ArpackNoConvergence as exc:  # the Ritz value reached so far, if any
        if not len(exc.eigenvalues):
            raise
        val = exc.eigenvalues
    return float(np.max(np.abs(val)))


def stable_dt(p: SparseProblem, beta: float, gamma: float,
              law: ContactLaw | None = None) -> float | None:
    """Newmark's (2 beta < gamma) step limit 1 / (sqrt(gamma/2 - beta) omega_max) on this
    problem, omega_max^2 the larger of `omega_max_squared` with the law inactive and with
    every contact dof active (None: unconditionally stable, 2 beta >= gamma)."""
    if 2.0 * beta >= gamma:
        return None
    w2 = omega_max_squared(p, law, False)
    if law is not None:
        w2 = max(w2, omega_max_squared(p, law, True))
    return float(1.0 / (np.sqrt(gamma / 2.0 - beta) * np.sqrt(w2)))


# ------------------------------------------- Taylor-Flanagan with a non-diagonal mass


class TaylorFlanaganOps(NamedTuple):
    """Taylor-Flanagan with a factored mass: M, K, F, M's factor (and its diagonal when
    M is diagonal, else empty), the gaps with Z = M^-1 G^T (kept or not) and W = (Zc +
    Zc^T) / 2, Zc = G Z."""

    M: CSR
    K: CSR
    F: np.ndarray
    fac: LU
    mdiag: np.ndarray
    ct: ContactOps
    weights: np.ndarray
    Zc: np.ndarray
    dt: float
    offset: float
    load: LoadOps | NoLoad  # the time load (`contact_bench.kernels.time_load`)


class TaylorFlanaganState(NamedTuple):
    """(U, V, A), the contact forces, the impulses mu = dt lam, the stopped set, the
    load, scratch."""

    U: np.ndarray
    V: np.ndarray
    A: np.ndarray
    force: np.ndarray
    mu: np.ndarray
    inJ: np.ndarray
    g: np.ndarray
    rhs: np.ndarray
    work: np.ndarray
    w: np.ndarray
    Fn: np.ndarray
    vals: np.ndarray


@njit(cache=True)
def tf_step(o, s, step):  # pragma: no cover - compiled
    """Taylor-Flanagan on many contact dofs with a factored mass (`prepare_taylor_flanagan`);
    with a diagonal mass the acceleration's solve is a division (the factor's numbers to
    the bit). A_{n+1} at U_{n+1} with the load at t_{n+1}."""
    U, V, A, lam, mu, inJ, rhs, w = s.U, s.V, s.A, s.force, s.mu, s.inJ, s.rhs, s.w
    ct, Zc, dt, g = o.ct, o.Zc, o.dt, s.g
    sel, W = ct.sel, ct.W
    n = U.size
    nc = sel.size
    for i in range(n):  # drift and half kick
        U[i] += dt * V[i] + 0.5 * dt * dt * A[i]
        V[i] += 0.5 * dt * A[i]
    lam[:] = 0.0
    inJ[:] = False
    grow = False
    gaps(ct, U, g)
    for j in range(nc):
        if not np.isfinite(g[j]):  # blown up between samples: stop before the LCP
            return BLOWN
        if g[j] < 0.0:
            inJ[j] = True
            grow = True
    for _ in range(nc + 1):  # the set of stopped dofs grows until none penetrates
        if not grow:
            break
        idx = np.flatnonzero(inJ)
        m = idx.size
        Ws = np.empty((m, m))
        q = np.empty(m)
        vmax = 0.0
        for a in range(m):  # velocities before this set's correction
            d = sel[idx[a]]
            acc = V[d] if d >= 0 else row_dot(ct.G, idx[a], V)
            for b in range(nc):
                acc -= Zc[idx[a], b] * mu[b]
            q[a] = acc
            vmax = max(vmax, abs(acc))
            for b in range(m):
                Ws[a, b] = W[idx[a], idx[b]]
        ms = np.zeros(m)
        act = np.zeros(m, np.bool_)
        lcp_solve(Ws, q, ms, act, 1e-13 * max(vmax, 1e-300))
        dmu = np.zeros(nc)  # the change of mu = dt lam
        for a in range(m):
            dmu[idx[a]] = ms[a] - mu[idx[a]]
            mu[idx[a]] = ms[a]
        if ct.keep_z:
            on = np.flatnonzero(dmu)
            for i in range(n):
                acc = 0.0
                for b in on:
                    acc += ct.Z[i, b] * dmu[b]
                V[i] += acc
                U[i] += dt * acc
        else:  # matrix-free: M^-1 G^T dmu
            spread(ct, dmu, rhs)
            lu(o.fac, rhs, w, s.work)
            for i in range(n):
                V[i] += w[i]
                U[i] += dt * w[i]
        grow = False
        gaps(ct, U, g)
        for j in range(nc):
            if not inJ[j] and g[j] < 0.0:
                inJ[j] = True
                grow = True
    for j in range(nc):
        lam[j] = mu[j] / dt
        mu[j] = 0.0
    F = force_at(o.load, o.F, step * dt, s.vals, s.Fn)
    matvec(o.K, U, rhs)  # A = M^-1 (F - K U)
    for i in range(n):
        rhs[i] = F[i] - rhs[i]
    if o.mdiag.size:
        for i in range(n):
            A[i] = rhs[i] / o.mdiag[i]
    else:
        lu(o.fac, rhs, A, s.work)
    for i in range(n):
        V[i] += 0.5 * dt * A[i]
    return OK


@njit(cache=True)
def tf_sample(o, s):  # pragma: no cover - compiled
    """The energy, the contact stress and V."""
    U, V, w = s.U, s.V, s.w
    matvec(o.M, V, w)
    e = 0.5 * (V @ w)
    matvec(o.K, U, w)
    e += 0.5 * (U @ w) - o.F @ U + o.offset
    return e, -s.force.sum() / o.weights.sum(), V


@njit(cache=True)
def tf_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `tf_step`."""
    return drive(tf_step, tf_sample, ops, st, rec, nsteps, stride)


class TaylorFlanaganStepper(LoopStepper):
    """`taylor_flanagan_sparse` prepared: M factored, the response Z = M^-1 C^T and the
    Delassus matrix W = C Z, the initial acceleration computed once."""

    adds_time_load = True
    any_gap_operator = True
    loop = staticmethod(tf_loop)

    def __init__(self, p: SparseProblem, dt: float) -> None:
        if np.any(p.massless):
            raise ValueError("taylor_flanagan needs every dof with mass (no velocity to stop)")
        super().__init__(p, dt)
        n = p.nfree
        G = sp.csr_matrix(p.contact.gap_operator(n))
        fac = Factor.of(p.M)
        keep_z = keeps_response(n, G.shape[0])
        Z, Zc = response_rows(fac, G, keep_z)
        W = np.ascontiguousarray(0.5 * (Zc + Zc.T))
        ct = ContactOps(csr_arrays(G), csr_arrays(G.T), np.asarray(p.contact.gap0, float),
                        selection_rows(G), W, np.ascontiguousarray(Z), keep_z)
        U, V = p.U0.astype(float).copy(), p.V0.astype(float).copy()
        self.initial = (U, V, fac.solve(initial_load(p) - p.K @ U))
        self.gamma = 1.0  # the impulses dt lam, applied whole
        M = sp.csr_matrix(p.M)
        diagonal = M.nnz == np.count_nonzero(M.diagonal())
        self.ops = TaylorFlanaganOps(
            csr_arrays(p.M), csr_arrays(p.K), np.asarray(p.F, float), fac.arrays,
            np.asarray(M.diagonal(), float) if diagonal else np.zeros(0), ct,
            np.asarray(p.contact.weights, float), np.ascontiguousarray(Zc), self.dt,
            float(p.energy_offset), load_ops(p))

    def new_state(self) -> TaylorFlanaganState:
        n, nc = self.problem.nfree, self.ops.ct.sel.size
        U, V, A = (a.copy() for a in self.initial)
        vals, Fn = load_scratch(self.ops.load, n)
        return TaylorFlanaganState(U, V, A, np.zeros(nc), np.zeros(nc), np.zeros(nc, np.bool_),
                                   np.empty(nc), np.empty(n), np.empty(n), np.empty(n), Fn,
                                   vals)


def prepare_taylor_flanagan(p: SparseProblem, dt: float) -> TaylorFlanaganStepper:
    """The Taylor-Flanagan central difference with any positive definite mass.

    The 1D algorithm (`schemes/taylor_flanagan.py`) on many contact dofs: after the drift
    U' = U + dt V + dt^2/2 A and half kick V' = V + dt/2 A, the dofs J whose gap is
    negative get the impulses dt lam_J >= 0 that make their velocities
    V'_J + dt W_JJ lam_J >= 0, complementary to lam_J (W = C M^-1 C^T, the Delassus
    matrix of the contact set under M^-1, computed once; the LCP by `lcp_solve`); then
    U' += dt^2 M^-1 C^T lam, V' += dt M^-1 C^T lam. A stopped dof stays where it was, a
    released one moves up, so J's gaps stay >= 0; with a non-diagonal M the correction
    also moves the other contact dofs, and any of them it pushes below the obstacle joins
    J (the set grows, at most n_c times). With one contact dof this is the 1D step; with
    a diagonal M, each dof's own stop (`central_sparse`). Then A = M^-1 (F - K U') (M
    factored once) and V = V' + dt/2 A. ValueError if a dof is massless."""
    return TaylorFlanaganStepper(p, dt)


def taylor_flanagan_sparse(p: SparseProblem, dt: float, nsteps: int,
                           stride: int) -> Trajectory:
    """`prepare_taylor_flanagan(p, dt).run(nsteps, stride)`."""
    return prepare_taylor_flanagan(p, dt).run(nsteps, stride)
