"""Stepping on the general sparse problem (`contact_bench.api.sparse.SparseProblem`).

Shared by the schemes' 2D/3D paths (their `prepare` on a body's problem). Everything
factorable is factored once, when the stepper is prepared, outside the loop; the loops
are numba kernels over CSR arrays.

* `Factor` (`contact_bench.kernels.linalg`): S factored once; SuperLU's L and U as CSR
  arrays for the compiled loops' triangular solves (`lu_solve`), and a multi-right-hand-side
  solve (CHOLMOD's Cholesky when S is SPD) for the Delassus matrix at set-up.
* Exact contact: the contact-free solution X_f of S X = b is corrected by
  X = X_f + Z mu with Z = S^-1 C^T (C picks the contact dofs): the gaps g = g_f + W mu
  with the Delassus matrix W = C S^-1 C^T (n_c x n_c, computed once: one solve with n_c
  right-hand sides, `Factor.solve_many`)
  must satisfy the linear complementarity problem g >= 0, mu >= 0, g.mu = 0, solved
  exactly by principal pivoting (`lcp_solve`: block pivoting, then Murty's least-index
  rule, which terminates for a positive definite W). Z is kept whole when it fits in
  `KEEP_Z_ENTRIES` values, else the columns of the contact patch (the rows of smallest
  initial gap, `contact_bench.kernels.contact.patch_rows`); a step pushing outside them
  makes a second solve with C^T mu.
* `newmark_sparse`: Newmark(beta > 0, gamma) in displacement form, S = M + beta dt^2 K,
  the obstacle's force lambda = mu / (beta dt^2) at t_{n+1} (the 1D kernel's algorithm,
  `contact_bench.kernels.newmark`, on many contact dofs). Massless dofs (zero mass
  rows) have no acceleration: their velocity is the backward difference.
* `quasistatic_sparse`: explicit Newmark (beta = 0) with massless contact dofs: the
  dofs with mass advance explicitly, the massless ones are solved from their own rows
  (K_mm factored once) with exact contact on the Delassus matrix C K_mm^-1 C^T.
* `central_sparse`: the explicit central difference with a diagonal (lumped) mass and
  the Taylor-Flanagan contact force (`schemes/taylor_flanagan.py`): a contact dof that
  would penetrate is stopped where it was.

Per step the kernels count the contact status switches (chatter), the smallest gap,
the first contact's start and end and the peak total contact force
(`contact_bench.kernels.recording`).

Each `x_sparse(p, dt, nsteps, stride, ...)` is `prepare_x(p, dt, ...).run(nsteps,
stride)`: `prepare_x` does the set-up once (`contact_bench.kernels.stepper`), `run`
steps from the initial state.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit

from contact_bench.api.plugin import Trajectory
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.loop import OK, drive
from contact_bench.kernels.contact import (
    ContactOps,
    Friction,
    add_response,
    contact_lcp,
    contact_ops,
    coulomb,
    friction_ops,
    gap_rows,
    gaps,
    hold,
    law_ops,
    near_rows,
    push,
    restrict,
    row_dot,
    row_value,
    selection_rows,
)
from contact_bench.kernels.csr import CSR, csr_arrays, matvec
from contact_bench.kernels.linalg import LU, Factor, lu
from contact_bench.kernels.recording import csr_energy, plain_sample
from contact_bench.kernels.solvers import lcp_solve, penalty_coulomb_solve, penalty_solve
from contact_bench.kernels.stepper import LoopStepper, with_tforce
from contact_bench.kernels.time_load import (
    LoadOps,
    NoLoad,
    force_at,
    initial_load,
    last_force,
    load_ops,
    load_scratch,
)

# ------------------------------------------------------------------------ CSR kernels


# -------------------------------------------------------------------------- Newmark


class NewmarkOps(NamedTuple):
    """What a Newmark step reads: M, K, F, S's factor, the contact (exact: its dofs,
    gaps, Delassus matrix W and response Z; or a law on y = P X + y0), the time load."""

    M: CSR
    K: CSR
    F: np.ndarray
    fac: LU
    ct: ContactOps  # the gaps (or a law's y = P X + y0: G = P, G^T = Q^T) and W, Z
    at_contact: np.ndarray  # -gap0: where an active selection row's dof is held
    weights: np.ndarray
    massless: np.ndarray
    beta: float
    gamma: float
    dt: float
    offset: float
    tol: float
    kappa: np.ndarray  # a law's stiffnesses (empty: exact contact)
    cpen: np.ndarray  # kappa beta dt^2
    ew: float
    sc: np.ndarray
    fscale: float
    alpha: float
    load: LoadOps | NoLoad  # the time load (`contact_bench.kernels.time_load`)


class NewmarkState(NamedTuple):
    """A Newmark run's state: U, V, the predictors P, Q, the contact's forces and active
    set, the load at the step's time and scratch."""

    U: np.ndarray
    V: np.ndarray
    P: np.ndarray
    Q: np.ndarray
    force: np.ndarray  # lambda, the obstacle's force at t_{n+1}
    mu: np.ndarray
    active: np.ndarray
    was: np.ndarray  # (1,): the previous step was in contact (the LCP's warm start)
    Fn: np.ndarray
    vals: np.ndarray
    rhs: np.ndarray
    X: np.ndarray
    work: np.ndarray
    w: np.ndarray
    gf: np.ndarray
    y: np.ndarray


@njit(inline="always")
def _newmark_free(o, s, step):  # pragma: no cover - compiled
    """The step's contact-free solution X of S X = M P + beta dt^2 (F_n + alpha K U^n)."""
    n = s.U.size
    beta, dt = o.beta, o.dt
    U, P, X, rhs, w = s.U, s.P, s.X, s.rhs, s.w
    bdt2 = beta * dt * dt
    # the load at the equation's time t_{n+1} + alpha dt (`force_at`; F without a time
    # load): with a_n in the predictors, the trapezoidal rule's average of the loads at
    # t_n and t_{n+1}; HHT's at t_{n+1+alpha}
    Fn = force_at(o.load, o.F, (step + o.alpha) * dt, s.vals, s.Fn)
    matvec(o.M, P, rhs)
    if o.alpha != 0.0:  # HHT: + alpha beta dt^2 K U^n
        matvec(o.K, U, w)
        for i in range(n):
            rhs[i] += bdt2 * (Fn[i] + o.alpha * w[i])
    else:
        for i in range(n):
            rhs[i] += bdt2 * Fn[i]
    lu(o.fac, rhs, X, s.work)


@njit(inline="always")
def _newmark_update(o, s):  # pragma: no cover - compiled
    """U, V and the predictors P, Q from the step's solution X."""
    n = s.U.size
    beta, gamma, dt = o.beta, o.gamma, o.dt
    U, V, P, Q, X = s.U, s.V, s.P, s.Q, s.X
    k1 = (gamma + 0.5 - beta) / beta
    k2 = 1.0 / beta
    kv = gamma / (beta * dt)
    idt = 1.0 / dt
    for i in range(n):
        if o.massless[i]:  # no inertia: backward-difference velocity, no acceleration
            v = X[i] - U[i]
            V[i] = v * idt
            P[i] = X[i] + v
            Q[i] = v
        else:  # d = beta dt^2 a^{n+1}
            d = X[i] - P[i]
            V[i] = kv * d + Q[i] * idt
            P[i] = k1 * d + (X[i] + Q[i])
            Q[i] = k2 * d + Q[i]
        U[i] = X[i]


@njit(cache=True)
def newmark_step(o, s, step):  # pragma: no cover - compiled
    """One Newmark step (module docstring; `loop.drive`'s step)."""
    nc = o.ct.gap0.size
    bdt2 = o.beta * o.dt * o.dt
    X, rhs, w, gf = s.X, s.rhs, s.w, s.gf
    penalty = o.kappa.size > 0
    _newmark_free(o, s, step)
    pen = gaps(o.ct, X, gf)
    lam, mu, active = s.force, s.mu, s.active
    if pen:
        if penalty:
            penalty_solve(o.ct.W, gf, o.cpen, mu, active)
        else:
            contact_lcp(o.ct, o.fac, gf, mu, active, o.tol, s.was[0])
        push(o.ct, o.fac, mu, X, (rhs, w, s.work))
        if not penalty:
            hold(o.ct, active, X, o.at_contact)  # in contact: the gap is 0 exactly
        for j in range(nc):
            lam[j] = o.fscale * mu[j] / bdt2
    else:
        mu[:] = 0.0
        lam[:] = 0.0
    s.was[0] = pen
    _newmark_update(o, s)
    return OK


@njit(cache=True)
def newmark_sample(o, s):  # pragma: no cover - compiled
    """The sampled energy (with a law's), stress and velocity (`loop.drive`'s sample)."""
    e = csr_energy(o.M, o.K, o.F, s.U, s.V, o.offset, s.w)
    area = o.weights.sum()
    if o.kappa.size == 0:
        return e, -s.force.sum() / area, s.V
    # the law's energy, ew sum_i kappa_i / 2 min(0, y_i)^2, and its stress
    matvec(o.ct.G, s.U, s.y)
    st = 0.0
    for i in range(o.kappa.size):
        yi = min(0.0, s.y[i] + o.ct.gap0[i])
        e += 0.5 * o.ew * o.kappa[i] * yi * yi
        st += o.sc[i] * yi
    return e, st / area, s.V


@njit(cache=True)
def newmark_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `newmark_step`."""
    return drive(newmark_step, newmark_sample, ops, st, rec, nsteps, stride)


# ------------------------------------------------- Newmark with Coulomb friction


FrictionalNewmarkState = with_tforce(
    NewmarkState, "FrictionalNewmarkState",
    """`NewmarkState` with the step's force on each tangent row (`tforce`); `mu` holds
    (r_n, r_t).""")


class FrictionalNewmarkOps(NamedTuple):
    """Newmark's operators (`NewmarkOps`, exact contact) and the frictional contact
    (`contact_bench.kernels.contact.Friction`)."""

    base: NewmarkOps
    fr: Friction


@njit(cache=True)
def newmark_friction_step(o, s, step):  # pragma: no cover - compiled
    """Newmark with exact contact and Coulomb friction at t_{n+1}: Signorini on the gaps
    of X and Coulomb on the velocity V^{n+1} along the tangents (`contact.coulomb`).
    V^{n+1} is affine in X with a positive factor per dof, kv (X - P + Q beta / gamma)
    with mass, (X - U) / dt without, the same on a contact node's dofs, so a tangent
    row's slip is its row of X - Y with Y those origins, scaled (the law does not see the
    scale); a sliding point's tangential force is mu times its normal one, exactly. s.mu
    holds (r_n, r_t), the next step's warm start; the step's force is r_n / (beta dt^2)."""
    b, fr = o.base, o.fr
    n = s.U.size
    ct, cf = b.ct, fr.ct
    nc = ct.gap0.size
    bdt2 = b.beta * b.dt * b.dt
    X, rhs, w, gf = s.X, s.rhs, s.w, s.gf
    _newmark_free(b, s, step)
    pen = gaps(ct, X, gf)
    r, active = s.mu, s.active
    if pen:
        q = np.empty(r.size)
        Y = np.empty(n)
        bg = b.beta / b.gamma
        for i in range(n):
            Y[i] = X[i] - (s.U[i] if b.massless[i] else s.P[i] - bg * s.Q[i])
        for j in range(nc):
            q[j] = gf[j]
        for i in range(nc, r.size):
            q[i] = row_value(cf, i, Y)
        coulomb(fr, np.arange(nc), q, r, max(b.tol, 1e-13 * np.max(np.abs(q))))
        push(cf, b.fac, r, X, (rhs, w, s.work))
        for j in range(nc):
            active[j] = r[j] > 0.0
        hold(ct, active, X, b.at_contact)  # in contact: the gap is 0 exactly
    else:
        r[:] = 0.0
        active[:] = False
    for j in range(nc):
        s.force[j] = r[j] / bdt2
    for i in range(nc, r.size):
        s.tforce[i - nc] = r[i] / bdt2
    s.was[0] = pen
    _newmark_update(b, s)
    return OK


@njit(cache=True)
def newmark_penalty_friction_step(o, s, step):  # pragma: no cover - compiled
    """Newmark with penalty springs and Coulomb friction at t_{n+1}: the normal spring
    r_n = c max(0, -g) and a tangential spring of the same stiffness on the slip
    increment T (X - U^n) from the previous step's tangential force, returned onto the
    disc |r_t| <= mu r_n (an interval in 2D; `penalty_coulomb_solve`; r = lambda beta
    dt^2, c = kappa beta dt^2).
    A sliding point's tangential force is mu times its normal one, exactly. s.mu holds
    (r_n, r_t): r_t is the next step's rho."""
    b, fr = o.base, o.fr
    n = s.U.size
    ct, cf = b.ct, fr.ct
    nc = ct.gap0.size
    bdt2 = b.beta * b.dt * b.dt
    X, rhs, w, gf = s.X, s.rhs, s.w, s.gf
    _newmark_free(b, s, step)
    pen = gaps(ct, X, gf)
    r = s.mu
    if pen:
        q = np.empty(r.size)
        Y = np.empty(n)
        for i in range(n):
            Y[i] = X[i] - s.U[i]
        for j in range(nc):
            q[j] = gf[j]
        for i in range(nc, r.size):
            q[i] = row_value(cf, i, Y)
        rho = r[nc:].copy()
        penalty_coulomb_solve(cf.W, q, fr.mu, b.cpen, rho, r)
        push(cf, b.fac, r, X, (rhs, w, s.work))
    else:
        r[:] = 0.0
    for j in range(nc):
        s.force[j] = b.fscale * r[j] / bdt2
    for i in range(nc, r.size):
        s.tforce[i - nc] = b.fscale * r[i] / bdt2
    s.was[0] = pen
    _newmark_update(b, s)
    return OK


@njit(cache=True)
def newmark_penalty_friction_loop(ops, st, rec, nsteps, stride):  # pragma: no cover
    """The one loop (`contact_bench.core.loop.drive`) with
    `newmark_penalty_friction_step`."""
    return drive(newmark_penalty_friction_step, newmark_friction_sample, ops, st, rec,
                 nsteps, stride)


@njit(cache=True)
def newmark_friction_sample(o, s):  # pragma: no cover - compiled
    """`newmark_sample` of the base operators."""
    return newmark_sample(o.base, s)


@njit(cache=True)
def newmark_friction_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `newmark_friction_step`."""
    return drive(newmark_friction_step, newmark_friction_sample, ops, st, rec, nsteps, stride)


# ------------------------------------------------- Nitsche with Coulomb friction


class NitscheFrictionOps(NamedTuple):
    """Newmark's operators with a law (`NewmarkOps`), the law's stacked normal and
    tangential rows (`Friction`: W = [P; Pt] S^-1 [Q; Qt]^T, Coulomb's mu) and St (the
    slip increment's rows, CSR)."""

    base: NewmarkOps
    fr: Friction
    St: CSR


@njit(cache=True)
def newmark_nitsche_friction_step(o, s, step):  # pragma: no cover - compiled
    """Newmark with a piecewise-linear normal law and its tangential law at t_{n+1}
    (`ContactLaw.Pt`, Nitsche's friction; n_t = 1 or 2 tangent rows per point): on y =
    (P X + y0, Pt X - St U^n) the reactions r = c max(0, -y_n) and r_t = -proj(c y_t)
    onto the disc |r_t| <= mu r_n (an interval in 2D), solved together by
    `penalty_coulomb_solve` (its return map from rho = 0: the law has no memory but U^n);
    X += S^-1 [Q; Qt]^T r. A point whose y_t is beyond the bound has its tangential force
    mu times its normal one, exactly. s.mu holds (r_n, r_t)."""
    b, fr = o.base, o.fr
    cf = fr.ct
    nc = b.ct.gap0.size
    bdt2 = b.beta * b.dt * b.dt
    X, U, r = s.X, s.U, s.mu
    _newmark_free(b, s, step)
    q = np.empty(r.size)
    pen = False
    for i in range(r.size):
        q[i] = cf.gap0[i] + row_dot(cf.G, i, X)
        if i < nc:
            pen = pen or q[i] < 0.0
        else:
            q[i] -= row_dot(o.St, i - nc, U)
    if pen:
        penalty_coulomb_solve(cf.W, q, fr.mu, b.cpen, np.zeros(r.size - nc), r)
        push(cf, b.fac, r, X, (s.rhs, s.w, s.work))
    else:
        r[:] = 0.0
    for j in range(nc):
        s.force[j] = b.fscale * r[j] / bdt2
    for i in range(nc, r.size):  # the tangential reaction (theta's term not counted)
        s.tforce[i - nc] = b.fscale * r[i] / bdt2
    s.was[0] = pen
    _newmark_update(b, s)
    return OK


@njit(cache=True)
def newmark_nitsche_friction_loop(ops, st, rec, nsteps, stride):  # pragma: no cover
    """The one loop (`contact_bench.core.loop.drive`) with
    `newmark_nitsche_friction_step`."""
    return drive(newmark_nitsche_friction_step, newmark_friction_sample, ops, st, rec,
                 nsteps, stride)


@dataclass
class ContactLaw:
    """A piecewise-linear contact force at t_{n+1}: on y = P U + y0 (n_c values) the
    force is -sum_i c_i min(0, y_i) q_i (q_i the rows of Q), which adds
    K_extra to the stiffness; its energy ew sum_i c_i / 2 min(0, y_i)^2, its sampled
    stress sum_i sc_i min(0, y_i) / (zone's measure).

    penalty: P = Q = C (the contact dofs), y0 = gap0, c = sc = kappa_i, ew = 1.
    Nitsche: P = gam C + B, Q = gam C + theta B (B: the normal stress at the contact
    dofs), y0 = gam gap0, c = w_i / gam, ew = theta, sc = w_i, K_extra = -(theta / gam)
    B^T M_f B (M_f the zone's mass, `ContactSet.face_mass`).
    """

    P: sp.csr_matrix
    Q: sp.csr_matrix
    y0: np.ndarray
    c: np.ndarray
    ew: float
    sc: np.ndarray
    K_extra: sp.csr_matrix | None = None
    #: the force on the contact dofs is fscale mu / (beta dt^2) (Q's coefficient of C:
    #: 1 for the penalty, gam for Nitsche), for the peak-force column
    fscale: float = 1.0
    #: the springs take Coulomb friction on a frictional problem: a tangential spring of
    #: the same stiffness with Coulomb's return map (`newmark_penalty_friction_step`)
    friction: bool = False
    #: a tangential law (Nitsche's friction, `newmark_nitsche_friction_step`): on
    #: y_t = Pt X - St U^n (one row per tangent row) the force Qt^T (c tau) with
    #: tau = -proj_[-mu p, mu p](y_t), p = max(0, -y) the point's normal value; None:
    #: no tangential law
    Pt: sp.csr_matrix | None = None
    Qt: sp.csr_matrix | None = None
    St: sp.csr_matrix | None = None


def initial_acceleration(p: SparseProblem, r: np.ndarray | None = None) -> np.ndarray:
    """M A0 = r on the dofs with mass (0 on the massless ones); r = F - K U0 unless
    given (a contact law's force at t = 0 included), F with the time load at t = 0."""
    if r is None:
        r = initial_load(p) - p.K @ p.U0
    A = np.zeros(p.nfree)
    heavy = ~p.massless
    Mh = p.M[heavy][:, heavy]
    if Mh.nnz == np.count_nonzero(Mh.diagonal()):  # diagonal
        A[heavy] = r[heavy] / Mh.diagonal()
    else:
        A[heavy] = Factor.of(Mh).solve(r[heavy])
    return A


def response_rows(fac: Factor, G: sp.csr_matrix, keep: bool) -> tuple[np.ndarray, np.ndarray]:
    """(Z, G Z) for Z = S^-1 G^T (S's factor `fac`, block solves `Factor.solve_blocks`):
    Z whole when `keep`, else a (1, 1) placeholder and only G Z (a selection G: Z's rows)."""
    G = sp.csr_matrix(G)
    sel = selection_rows(G)
    n, nc = fac.n, G.shape[0]
    Z = np.empty((n, nc)) if keep else np.zeros((1, 1))
    Zr = np.empty((nc, nc))
    for j0, j1, X in fac.solve_blocks(sp.csc_matrix(G.T)):
        if keep:
            Z[:, j0:j1] = X
        Zr[:, j0:j1] = gap_rows(G, sel, X)
    return Z, Zr


def is_spring(law: ContactLaw, G: sp.spmatrix) -> bool:
    """Whether `law` is penalty springs on the gaps of G (P = Q = G, no added stiffness,
    its force and energy unscaled): the law a curved obstacle's tangent can carry."""
    return (law.K_extra is None and law.fscale == 1.0 and law.ew == 1.0
            and all(A.shape == G.shape and (sp.csr_matrix(A) != G).nnz == 0
                    for A in (law.P, law.Q)))


def newmark_state(o: NewmarkOps, initial: tuple[np.ndarray, ...]) -> NewmarkState:
    """A fresh `NewmarkState` from the initial (U, V, P, Q), copied, and zeroed scratch."""
    U, V, P, Q = (a.copy() for a in initial)
    n, nc = U.size, o.ct.gap0.size
    vals, Fn = load_scratch(o.load, n)
    return NewmarkState(U, V, P, Q, np.zeros(nc), np.zeros(nc), np.zeros(nc, np.bool_),
                        np.zeros(1, np.bool_), Fn, vals, np.empty(n), np.empty(n),
                        np.empty(n), np.empty(n), np.empty(nc), np.empty(nc))


class NewmarkStepper(LoopStepper):
    """`newmark_sparse` prepared: S factored, the contact operators (Z, W or the law's),
    the initial acceleration and the predictors (P, Q) computed once."""

    adds_time_load = True
    any_gap_operator = True
    follows_curved = True  # exact contact and the penalty spring (not a general law)
    loop = staticmethod(newmark_loop)

    def __init__(self, p: SparseProblem, dt: float, beta: float, gamma: float,
                 kappa: np.ndarray | None = None, law: ContactLaw | None = None,
                 alpha: float = 0.0) -> None:
        if not beta > 0.0:
            raise ValueError("newmark_sparse needs beta > 0 (the explicit path is "
                             "central_sparse)")
        super().__init__(p, dt)
        dt, beta, gamma = self.dt, float(beta), float(gamma)
        n = p.nfree
        G = sp.csr_matrix(p.contact.gap_operator(n))
        curved = p.contact.obstacle
        if curved is not None and law is not None and not is_spring(law, G):
            raise ValueError("newmark_sparse follows a curved obstacle with exact contact "
                             "or penalty springs on its gaps, not a general contact law")
        if kappa is not None:
            kappa = np.asarray(kappa, float)
            law = ContactLaw(G, G, np.asarray(p.contact.gap0, float), kappa, 1.0, kappa)
        K = p.K if law is None or law.K_extra is None else sp.csr_matrix(p.K + law.K_extra)
        if law is not None:
            Pm, y0 = sp.csr_matrix(law.P), np.asarray(law.y0, float)
            lk, ew, sc = np.asarray(law.c, float), float(law.ew), np.asarray(law.sc, float)
            fscale = float(law.fscale)
        else:
            Pm, y0 = G, np.asarray(p.contact.gap0, float)
            lk, ew, sc = np.zeros(0), 0.0, np.zeros(0)
            fscale = 1.0
        if law is not None:  # the sampled energy at t = 0 with the law's terms
            y = np.minimum(0.0, Pm @ p.U0 + y0)
            self.sample0["energy"] = float(p.energy(p.U0, p.V0)
                                           + 0.5 * p.U0 @ ((K - p.K) @ p.U0)
                                           + 0.5 * ew * np.sum(lk * y * y))
        # the law's total force at t = 0 (in the initial acceleration): the impulse's start
        self.force0 = (fscale * float(np.sum(lk * np.maximum(0.0, -(Pm @ p.U0 + y0))))
                       if law is not None else 0.0)
        U, V = p.U0.astype(float).copy(), p.V0.astype(float).copy()
        F0 = initial_load(p)
        if law is not None:  # the full force at t = 0: K' and the law's, if active
            r = F0 - K @ U - law.Q.T @ (lk * np.minimum(0.0, Pm @ U + y0))
            A = initial_acceleration(p, r)
        else:
            A = initial_acceleration(p, F0 - K @ U)
        # the state: the next predictor P = U + dt V + (1/2 - beta) dt^2 A and
        # Q = dt V + (1 - gamma) dt^2 A (the 1D kernel's, `contact_bench.kernels.newmark`)
        self.initial = (U, V, U + dt * V + (0.5 - beta) * dt * dt * A,
                        dt * V + dt * dt * (1.0 - gamma) * A)
        # S factored after the initial acceleration, whose factor of M (as large as S's)
        # is released by then: the two factors are never held at once (the set-up's peak
        # memory); S not held whole beside PARDISO's factor (`Factor.of_sum`)
        fac = Factor.of_sum(p.M, K, (1.0 + float(alpha)) * beta * dt * dt)
        self.factor = fac
        if law is None:  # exact contact: W's columns of the rows near contact, the rest lazily
            # (a curved obstacle's operators are its tangent's, `curved_ops`: no rows first)
            first = None if curved is not None else near_rows(G, y0, U, V, A, dt)
            ct = contact_ops(fac, G, y0, obstacle=curved, first=first)
        elif curved is not None:  # the spring on the curved obstacle's tangent
            ct = contact_ops(fac, G, y0, keep=True, obstacle=curved)
        else:  # Z = S^-1 Q^T, W = P Z (unsymmetric for Nitsche, theta != 1)
            Z = fac.solve_many(sp.csc_matrix(law.Q.T))
            W = np.ascontiguousarray(law.P @ Z)
            ct = ContactOps(csr_arrays(Pm), csr_arrays(sp.csr_matrix(law.Q).T), y0,
                            selection_rows(Pm), W, np.ascontiguousarray(Z), True)
        tol = 1e-13 * max(float(np.max(np.abs(U))), float(np.max(np.abs(p.contact.gap0),
                                                                 initial=0.0)), 1e-300)
        self.gamma = gamma
        self.ops = NewmarkOps(
            csr_arrays(p.M), csr_arrays(K), np.asarray(p.F, float), fac.arrays, ct,
            -np.asarray(p.contact.gap0, float), np.asarray(p.contact.weights, float),
            p.massless, beta, gamma, dt, float(p.energy_offset), tol, lk,
            lk * (beta * dt * dt), ew, sc, fscale, float(alpha), load_ops(p))

    def new_state(self) -> NewmarkState:
        return newmark_state(self.ops, self.initial)


class FrictionalNewmarkStepper(NewmarkStepper):
    """`NewmarkStepper` (exact contact) on a problem with friction
    (`ContactSet.frictional`): the same set-up, the stacked normal and tangent rows'
    Delassus matrix, `newmark_friction_step`. Those rows are fixed for the run, so it
    refuses a curved obstacle (`SparseStepper`)."""

    follows_curved = False
    loop = staticmethod(newmark_friction_loop)

    def __init__(self, p: SparseProblem, dt: float, beta: float, gamma: float,
                 alpha: float = 0.0, law: ContactLaw | None = None) -> None:
        super().__init__(p, dt, beta, gamma, law=law, alpha=alpha)
        self.ops = FrictionalNewmarkOps(self.ops, friction_ops(self.factor, p.contact,
                                                               p.nfree))

    def new_state(self) -> FrictionalNewmarkState:
        st = newmark_state(self.ops.base, self.initial)
        nc, nh = st.force.size, self.ops.fr.ct.gap0.size
        return FrictionalNewmarkState(*st._replace(mu=np.zeros(nh)), np.zeros(nh - nc))


class FrictionalPenaltyStepper(FrictionalNewmarkStepper):
    """`NewmarkStepper` with penalty springs (`ContactLaw.friction`) on a problem with
    Coulomb friction (one tangent per point in 2D, two in 3D):
    `newmark_penalty_friction_step`."""

    loop = staticmethod(newmark_penalty_friction_loop)

    def __init__(self, p: SparseProblem, dt: float, beta: float, gamma: float,
                 law: ContactLaw) -> None:
        if p.contact.tresca is not None:
            raise ValueError("penalty friction is built for Coulomb friction (no Tresca "
                             "threshold)")
        super().__init__(p, dt, beta, gamma, law=law)


class FrictionalNitscheStepper(NewmarkStepper):
    """`NewmarkStepper` with a law that has tangential rows (`ContactLaw.Pt`: Nitsche's
    friction) on a problem with Coulomb friction (one tangent per point in 2D, two in 3D:
    the disc's projection): S with the law's added stiffness
    (both its normal and tangential terms), the stacked rows' W and Z (`law_ops`),
    `newmark_nitsche_friction_step`. The initial acceleration has the law's normal force
    at t = 0 and no tangential one (no slip increment yet). A curved obstacle is refused
    (the tangent rows would stay fixed)."""

    follows_curved = False
    loop = staticmethod(newmark_nitsche_friction_loop)
    new_state = FrictionalNewmarkStepper.new_state

    def __init__(self, p: SparseProblem, dt: float, beta: float, gamma: float,
                 law: ContactLaw) -> None:
        c = p.contact
        nt = c.tangents.shape[0] // c.size
        if c.tangents.shape[0] != nt * c.size or nt not in (1, 2) or c.tresca is not None:
            raise ValueError("Nitsche's friction is built for Coulomb friction with one or "
                             "two tangents per contact point (no Tresca threshold); this "
                             f"problem has {c.tangents.shape[0]} tangent rows for "
                             f"{c.size} points")
        super().__init__(p, dt, beta, gamma, law=law)
        P = sp.vstack([law.P, law.Pt], format="csr")
        Q = sp.vstack([law.Q, law.Qt], format="csr")
        y0 = np.concatenate([np.asarray(law.y0, float), np.zeros(law.Pt.shape[0])])
        mu = np.zeros(c.size) if c.friction is None else np.asarray(c.friction, float)
        fr = Friction(law_ops(self.factor, P, Q, y0), mu.copy(), np.zeros(c.size), nt)
        self.ops = NitscheFrictionOps(self.ops, fr, csr_arrays(sp.csr_matrix(law.St)))


def prepare_newmark(p: SparseProblem, dt: float, beta: float, gamma: float,
                    kappa: np.ndarray | None = None, law: ContactLaw | None = None,
                    alpha: float = 0.0) -> NewmarkStepper:
    """Newmark(beta > 0, gamma) with exact contact at t_{n+1} (module docstring), or
    a piecewise-linear `law` (`ContactLaw`: Nitsche), or penalty springs: `kappa` (one
    stiffness per contact dof) gives the force kappa_i max(0, -g_i) at t_{n+1}; the
    law's step is solved exactly (`penalty_solve`), its energy is sampled. `alpha` != 0:
    HHT-alpha, M A1 + (1 + alpha) K U1 - alpha K U0 = F + C^T lambda, S = M + (1 + alpha)
    beta dt^2 K (`schemes/hht.py`; beta and gamma are the caller's). Exact contact on a
    problem with friction (`ContactSet.frictional`): Coulomb's law on V^{n+1}
    (`FrictionalNewmarkStepper`); a law with tangential rows (Nitsche's:
    `FrictionalNitscheStepper`) or penalty springs that take friction
    (`FrictionalPenaltyStepper`) take theirs; any other law is refused in one line."""
    if p.contact.frictional:
        if law is not None and law.Pt is not None and kappa is None and alpha == 0.0:
            return FrictionalNitscheStepper(p, dt, beta, gamma, law)
        if law is not None and law.friction and kappa is None and alpha == 0.0:
            return FrictionalPenaltyStepper(p, dt, beta, gamma, law)
        if kappa is not None or law is not None:
            raise ValueError("newmark_sparse with this contact law (Nitsche, or penalty "
                             "stiffnesses alone) has no friction; this problem's contact "
                             "has mu > 0")
        return FrictionalNewmarkStepper(p, dt, beta, gamma, alpha)
    return NewmarkStepper(p, dt, beta, gamma, kappa, law, alpha)


def newmark_sparse(p: SparseProblem, dt: float, nsteps: int, stride: int, beta: float,
                   gamma: float, kappa: np.ndarray | None = None,
                   law: ContactLaw | None = None, alpha: float = 0.0) -> Trajectory:
    """`prepare_newmark(p, dt, ...).run(nsteps, stride)`."""
    return prepare_newmark(p, dt, beta, gamma, kappa, law, alpha).run(nsteps, stride)


@dataclass
class MasslessSplit:
    """The arrays of the split into dofs with mass (hv) and massless dofs (mv), for the
    compiled kernels: the massless rows K_mm factored with the contact operators of the
    gap operator restricted to them (G_m = G[:, mv]: W = G_m K_mm^-1 G_m^T, Z = K_mm^-1
    G_m^T), M_hh factored unless diagonal (`quasistatic_sparse`,
    `contact_bench.kernels.sparse_family`). ValueError unless every dof in a contact row
    is massless and some dof has mass."""

    hv: np.ndarray
    mv: np.ndarray
    Kh: CSR  # CSR rows K[hv] (all columns)
    Kmh: CSR  # CSR rows K[mv] with the massless columns dropped
    mfac: LU  # K_mm factored
    hfac: LU  # M_hh factored (unless diagonal)
    diag_h: np.ndarray  # M_hh's diagonal when it is diagonal, else empty
    ct: ContactOps  # G_m with K_mm's factor (Z kept)
    at_contact: np.ndarray  # -gap0
    tol: float

    @classmethod
    def of(cls, p: SparseProblem) -> MasslessSplit:
        massless = p.massless
        hv, mv = np.flatnonzero(~massless), np.flatnonzero(massless)
        G = sp.csr_matrix(p.contact.gap_operator(p.nfree))
        if G[:, hv].nnz or hv.size == 0:
            raise ValueError("the massless-contact ODE needs massless contact dofs "
                             "(a redistributed mass) and dofs with mass")
        K = sp.csr_matrix(p.K)
        mfac = Factor.of(K[mv][:, mv])
        gap0 = np.asarray(p.contact.gap0, float)
        ct = contact_ops(mfac, G[:, mv], gap0, keep=True,
                         obstacle=restrict(p.contact.obstacle, mv, p.nfree))
        keep = np.ones(p.nfree)
        keep[mv] = 0.0
        Kmh = sp.csr_matrix(K[mv] @ sp.diags(keep))
        Kmh.eliminate_zeros()
        Mhh = sp.csr_matrix(p.M[hv][:, hv])
        diag = Mhh.nnz == np.count_nonzero(Mhh.diagonal())
        hfac = Factor.of(sp.identity(1, format="csc")) if diag else Factor.of(Mhh)
        tol = 1e-13 * max(float(np.max(np.abs(p.U0))),
                          float(np.max(np.abs(p.contact.gap0), initial=0.0)), 1e-300)
        return cls(hv, mv, csr_arrays(K[hv]), csr_arrays(Kmh), mfac.arrays, hfac.arrays,
                   np.asarray(Mhh.diagonal(), float) if diag else np.zeros(0), ct, -gap0, tol)


@njit(cache=True)
def massless_solve(o, F, U, mu, active, warm, scr):  # pragma: no cover - compiled
    """U[mv] <- u_m(u_h), the massless rows solved with exact contact under the load F
    (o.F, or the time load's `force_at`); mu (out) the obstacle's forces, active (in/out)
    the contact dofs on the obstacle; scr: scratch (rm, um, wm of the massless dofs'
    size, gf of the contact's). Returns whether any contact dof would penetrate without
    the obstacle (the LCP ran). `o`: any operators carrying a `MasslessSplit`'s mv, Km,
    mfac, ct, at_contact and tol (`QuasistaticOps`, `sparse_family.MasslessOps`,
    `semi_explicit.BodyOps`): the one massless solve of every scheme with massless
    contact dofs."""
    rm, um, wm, gf = scr
    mv = o.mv
    nm = mv.size
    matvec(o.Km, U, rm)  # K_mh u_h
    for b in range(nm):
        rm[b] = F[mv[b]] - rm[b]
    lu(o.mfac, rm, um, wm)
    pen = gaps(o.ct, um, gf)
    if pen:
        lcp_solve(o.ct.W, gf, mu, active, o.tol, warm)
        add_response(o.ct.Z, mu, um)
        hold(o.ct, active, um, o.at_contact)  # on the obstacle: the gap is 0 exactly
    else:
        mu[:] = 0.0
        active[:] = False
    for b in range(nm):
        U[mv[b]] = um[b]
    return pen


@njit(cache=True)
def heavy_acceleration(o, F, U, rh, ah, wh):  # pragma: no cover - compiled
    """ah = M_hh^-1 (F - K U)_h (rh, wh: scratch; `o` with a `MasslessSplit`'s hv, Kh,
    hfac and diag_h)."""
    nh = o.hv.size
    matvec(o.Kh, U, rh)
    for a in range(nh):
        rh[a] = F[o.hv[a]] - rh[a]
    if o.diag_h.size:
        for a in range(nh):
            ah[a] = rh[a] / o.diag_h[a]
    else:
        lu(o.hfac, rh, ah, wh)


# ------------------------------------------------------- explicit central difference


class CentralOps(NamedTuple):
    """The kick-drift central difference's operators: the diagonal mass m (and dt / m),
    K, F, the contact dofs and their gaps."""

    m: np.ndarray
    c: np.ndarray  # dt / m
    K: CSR
    F: np.ndarray
    G: CSR
    sel: np.ndarray  # per contact point: the dof its row selects, or -1 (a general row)
    meff: np.ndarray  # per contact point: 1 / (G_j M^-1 G_j^T), the mass along its row
    gap0: np.ndarray
    weights: np.ndarray
    dt: float
    offset: float
    load: LoadOps | NoLoad  # the time load (`contact_bench.kernels.time_load`)


class CentralState(NamedTuple):
    """(U^n, V^{n-1/2}), the contact forces, the load at t_n and scratch."""

    U: np.ndarray
    Vh: np.ndarray
    force: np.ndarray
    Un: np.ndarray
    tmp: np.ndarray
    Fn: np.ndarray
    vals: np.ndarray


@njit(cache=True)
def central_step(o, s, step):  # pragma: no cover - compiled
    """Kick-drift central difference with a diagonal mass m (> 0 everywhere), carrying
    (U^n, V^{n-1/2}); a contact point whose predicted gap is negative gets the force
    lambda = max(0, -m_j G_j V^{n+1/2} / dt) that stops it (Taylor-Flanagan; m_j the mass
    along its row, a selected dof's own mass). The kick from U^n feels the load at t_n,
    evaluated at the end of the step that reached U^n."""
    U, Vh, Un, lam, c, dt = s.U, s.Vh, s.Un, s.force, o.c, o.dt
    n = U.size
    Kp, Ki, Kx = o.K
    if step > 1:  # kick and drift fused with the product K U: one pass
        F = last_force(o.load, o.F, s.Fn)  # at t_n
        for i in range(n):
            ku = 0.0
            for kk in range(Kp[i], Kp[i + 1]):
                ku += Kx[kk] * U[Ki[kk]]
            v = Vh[i] + c[i] * (F[i] - ku)
            Vh[i] = v
            Un[i] = U[i] + dt * v
    else:
        for i in range(n):
            Un[i] = U[i] + dt * Vh[i]
    Gp, Gi, Gx = o.G
    for j in range(o.sel.size):
        d = o.sel[j]
        lam[j] = 0.0
        if d >= 0:
            if o.gap0[j] + Un[d] < 0.0:
                lj = -Vh[d] * o.m[d] / dt
                if lj > 0.0:
                    lam[j] = lj
                    Un[d] += dt * c[d] * lj
                    Vh[d] += c[d] * lj
        elif o.gap0[j] + row_dot(o.G, j, Un) < 0.0:  # stop the normal velocity G_j V
            lj = -row_dot(o.G, j, Vh) * o.meff[j] / dt
            if lj > 0.0:
                lam[j] = lj
                for kk in range(Gp[j], Gp[j + 1]):
                    i = Gi[kk]
                    Un[i] += dt * c[i] * Gx[kk] * lj
                    Vh[i] += c[i] * Gx[kk] * lj
    U[:] = Un
    force_at(o.load, o.F, step * dt, s.vals, s.Fn)  # the next kick's and the sample's
    return OK


@njit(cache=True)
def central_sample(o, s):  # pragma: no cover - compiled
    """The energy with the velocity V^n = V^{n-1/2} + dt/2 M^-1 (F(t_n) - K U^n) (the
    energy's potential with the constant F)."""
    U, tmp, m, F = s.U, s.tmp, o.m, o.F
    Ft = last_force(o.load, F, s.Fn)
    matvec(o.K, U, tmp)
    for i in range(U.size):
        tmp[i] = s.Vh[i] + 0.5 * o.dt * ((Ft[i] - tmp[i]) / m[i])
    e = -(F @ U) + o.offset
    for i in range(U.size):
        e += 0.5 * m[i] * tmp[i] * tmp[i]
    matvec(o.K, U, s.Un)
    e += 0.5 * (U @ s.Un)
    return e, -s.force.sum() / o.weights.sum(), tmp


@njit(cache=True)
def central_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `central_step`."""
    return drive(central_step, central_sample, ops, st, rec, nsteps, stride)


class CentralStepper(LoopStepper):
    """`central_sparse` prepared: the diagonal mass and the initial half-step velocity."""

    adds_time_load = True
    any_gap_operator = True
    loop = staticmethod(central_loop)

    def __init__(self, p: SparseProblem, dt: float) -> None:
        M = sp.csr_matrix(p.M)
        m = np.asarray(M.diagonal(), float)
        if M.nnz != np.count_nonzero(m) or not np.all(m > 0):
            raise ValueError("central_sparse needs a diagonal mass with positive entries "
                             "(lumped)")
        super().__init__(p, dt)
        U, V = p.U0.astype(float).copy(), p.V0.astype(float).copy()
        A = initial_acceleration(p)
        self.initial = (U, V + 0.5 * self.dt * A)  # (U^0, V^{1/2})
        G = sp.csr_matrix(p.contact.gap_operator(p.nfree))
        meff = 1.0 / np.asarray(G.multiply(G) @ (1.0 / m)).ravel()
        self.ops = CentralOps(m, self.dt / m, csr_arrays(p.K), np.asarray(p.F, float),
                              csr_arrays(G), selection_rows(G), meff,
                              np.asarray(p.contact.gap0, float),
                              np.asarray(p.contact.weights, float), self.dt,
                              float(p.energy_offset), load_ops(p))

    def new_state(self) -> CentralState:
        n = self.problem.nfree
        U, Vh = (a.copy() for a in self.initial)
        vals, Fn = load_scratch(self.ops.load, n)
        return CentralState(U, Vh, np.zeros(self.ops.sel.size), np.empty(n), np.empty(n),
                            Fn, vals)


def prepare_central(p: SparseProblem, dt: float) -> CentralStepper:
    """The explicit central difference with a diagonal mass and the Taylor-Flanagan
    contact force (module docstring). ValueError unless M is diagonal and positive."""
    return CentralStepper(p, dt)


def central_sparse(p: SparseProblem, dt: float, nsteps: int, stride: int) -> Trajectory:
    """`prepare_central(p, dt).run(nsteps, stride)`."""
    return prepare_central(p, dt).run(nsteps, stride)


# ------------------------------------- explicit with massless (quasi-static) contact dofs


class QuasistaticOps(NamedTuple):
    """Explicit Newmark with massless contact dofs: the split into dofs with mass (hv)
    and massless ones (mv), their rows of K, K_mm's and M_hh's factors (or M_hh's
    diagonal), the contact dofs' positions in mv (cl) and the Delassus matrix W = C
    K_mm^-1 C^T with Z = K_mm^-1 C^T."""

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
    ct: ContactOps  # G restricted to the massless dofs, with K_mm's factor
    at_contact: np.ndarray
    weights: np.ndarray
    dt: float
    gamma: float
    offset: float
    tol: float
    load: LoadOps | NoLoad  # the time load (`contact_bench.kernels.time_load`)


class QuasistaticState(NamedTuple):
    """(U, V, A), the obstacle's forces mu, the active set, the load and scratch."""

    U: np.ndarray
    V: np.ndarray
    A: np.ndarray
    force: np.ndarray
    active: np.ndarray
    was: np.ndarray
    rm: np.ndarray
    um: np.ndarray
    wm: np.ndarray
    rh: np.ndarray
    ah: np.ndarray
    wh: np.ndarray
    w: np.ndarray
    gf: np.ndarray
    Fn: np.ndarray
    vals: np.ndarray


@njit(cache=True)
def quasistatic_step(o, s, step):  # pragma: no cover - compiled
    """Central differences on the dofs with mass (hv), the massless ones (mv) solved
    from their own rows each step, with exact contact on the contact dofs among them
    (`massless_solve`); both at U_{n+1} with the load at t_{n+1}."""
    U, V, A, dt, gamma = s.U, s.V, s.A, o.dt, o.gamma
    F = force_at(o.load, o.F, step * dt, s.vals, s.Fn)
    hv, mv, ah = o.hv, o.mv, s.ah
    nh, nm = hv.size, mv.size
    for a in range(nh):
        i = hv[a]
        U[i] += dt * V[i] + 0.5 * dt * dt * A[i]
    for b in range(nm):  # the massless dofs' old positions, kept in V until solved
        V[mv[b]] = U[mv[b]]
    s.was[0] = massless_solve(o, F, U, s.force, s.active, s.was[0],
                              (s.rm, s.um, s.wm, s.gf))
    for b in range(nm):  # their backward difference
        i = mv[b]
        V[i] = (U[i] - V[i]) / dt
    heavy_acceleration(o, F, U, s.rh, ah, s.wh)
    for a in range(nh):
        i = hv[a]
        V[i] += dt * ((1.0 - gamma) * A[i] + gamma * ah[a])
        A[i] = ah[a]
    return OK


@njit(cache=True)
def quasistatic_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `quasistatic_step`."""
    return drive(quasistatic_step, plain_sample, ops, st, rec, nsteps, stride)


class QuasistaticStepper(LoopStepper):
    """`quasistatic_sparse` prepared: K_mm and M_hh factored, the Delassus matrix and the
    initial acceleration computed once."""

    adds_time_load = True
    any_gap_operator = True
    follows_curved = True
    loop = staticmethod(quasistatic_loop)

    def __init__(self, p: SparseProblem, dt: float, gamma: float = 0.5) -> None:
        if p.contact.gap_operator(p.nfree)[:, np.flatnonzero(~p.massless)].nnz:
            raise ValueError("the explicit quasi-static path needs massless contact dofs")
        super().__init__(p, dt)
        split = MasslessSplit.of(p)
        self.gamma = float(gamma)
        self.initial = (p.U0.astype(float).copy(), p.V0.astype(float).copy(),
                        initial_acceleration(p))
        self.ops = QuasistaticOps(
            csr_arrays(p.M), csr_arrays(p.K), np.asarray(p.F, float), split.hv, split.mv,
            split.Kh, split.Kmh, split.mfac, split.hfac, split.diag_h, split.ct,
            split.at_contact, np.asarray(p.contact.weights, float), self.dt, float(gamma),
            float(p.energy_offset), split.tol, load_ops(p))

    def new_state(self) -> QuasistaticState:
        n, nh, nm = self.problem.nfree, self.ops.hv.size, self.ops.mv.size
        nc = self.ops.at_contact.size
        U, V, A = (a.copy() for a in self.initial)
        vals, Fn = load_scratch(self.ops.load, n)
        return QuasistaticState(U, V, A, np.zeros(nc), np.zeros(nc, np.bool_),
                                np.zeros(1, np.bool_), np.empty(nm), np.empty(nm),
                                np.empty(nm), np.empty(nh), np.empty(nh), np.empty(nh),
                                np.empty(n), np.empty(nc), Fn, vals)


def prepare_quasistatic(p: SparseProblem, dt: float, gamma: float = 0.5
                        ) -> QuasistaticStepper:
    """Explicit Newmark (beta = 0, gamma; 1/2: central differences) with massless contact
    dofs (the seed's P_U^mod on many dofs): the dofs with mass advance explicitly (a
    solve with their mass block, factored once, unless it is diagonal), the massless
    ones are quasi-static, solved from their rows with K_mm factored once and exact
    contact through the Delassus matrix C K_mm^-1 C^T. ValueError unless every contact
    dof is massless."""
    return QuasistaticStepper(p, dt, gamma)


def quasistatic_sparse(p: SparseProblem, dt: float, nsteps: int, stride: int,
                       gamma: float = 0.5) -> Trajectory:
    """`prepare_quasistatic(p, dt, gamma).run(nsteps, stride)`."""
    return prepare_quasistatic(p, dt, gamma).run(nsteps, stride)
