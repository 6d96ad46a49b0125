"""The trapezoidal rule for the internal forces with the contact force fully implicit at
t_{n+1} (Kane, Repetto, Ortiz, Marsden 1999), with or without the contact-stabilizing
predictor of Deuflhard, Krause, Ertel (2008): the step of `schemes/kane.py` and
`schemes/contact_stabilized.py`, on the general sparse problem and on the bar's
tridiagonal form.

One step from (U^n, V^n), h = dt, S = M + h^2/4 K (factored once, as `standard`'s S with
beta = 1/4):

1. the predictor U~ = U^n + h V^n; with the contact-stabilizing predictor, U~ is
   replaced by its projection onto the admissible set in the mass norm,
   argmin_{gap0 + C U >= 0} |U - U^n - h V^n|_M: U~ + M^-1 C^T mu_p with the linear
   complementarity problem of the Delassus matrix C M^-1 C^T (M factored once; a
   lumped M makes it one clamp per contact dof);
2. S U^{n+1} = M U~ - h^2/4 K U^n + h^2/2 F + C^T mu (a time-dependent F: the mean of
   its values at t_n and t_{n+1}, the trapezoidal rule), exact contact at t_{n+1}
   through the Delassus matrix C S^-1 C^T (`contact_bench.kernels.sparse`: `lcp_solve`,
   `correct`); the obstacle's force lambda = 2 mu / h^2, applied over the whole step
   (backward Euler for the contact force, the trapezoidal rule for the others);
3. V^{n+1} = B + 2 / h (U^{n+1} - U~) with B = V^n (Kane; Deuflhard-Krause-Ertel) or
   B = (U~ - U^n) / h (Klapproth's variant: the velocity the predictor left).

Without a projection, U~ = U^n + h V^n and step 3 is V^{n+1} = 2 (U^{n+1} - U^n) / h -
V^n: Kane's scheme, U^{n+1} = U^n + h V^n + h^2/4 (a_el^n + a_el^{n+1}) + h^2/2 M^-1
C^T lambda with a_el = M^-1 (F - K U) (the elastic acceleration, never carrying the
contact force into the next step). No initial acceleration is needed.

The sampled force (stress, contact statistics) is the one the velocity update feels,
applied whole at the step's end (impulse weight 1): 2 mu / h^2, plus mu_p / h^2 of the
predictor with Klapproth's velocity.

With Coulomb friction (`ContactSet.frictional`; Krause and Walloth's frictional variant)
step 2's contact is Signorini and Coulomb together on V^{n+1} (`kane_friction_step`); the
predictor's projection stays normal only.

The bar's tridiagonal form (`prepare_kane_banded`) takes the same step in node order:
S and M factored once (LAPACK dpttrf), their responses to a unit force at the contact
node, S^-1 e0 and M^-1 e0, make both projections one scaled vector each.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit

from contact_bench.api.plugin import Semidiscrete, Stepper, Trajectory
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.loop import OK, drive
from contact_bench.core.sampling import blown_up, energy_rows, record_sample, row_sums
from contact_bench.core.tridiag import Implicit, factor_pt, pt_solve, tri_matvec
from contact_bench.kernels.common import allocate, bar_ops, run_spec, trajectory
from contact_bench.kernels.contact import (
    ContactOps,
    Friction,
    contact_ops,
    coulomb_bound,
    friction_ops,
    gaps,
    hold,
    push,
    row_value,
    signorini,
)
from contact_bench.kernels.csr import CSR, csr_arrays, matvec
from contact_bench.kernels.linalg import LU, lu
from contact_bench.kernels.recording import plain_sample
from contact_bench.kernels.solvers import lcp_solve
from contact_bench.kernels.sparse import Factor
from contact_bench.kernels.stepper import LoopStepper, with_tforce
from contact_bench.kernels.time_load import LoadOps, NoLoad, force_at, load_ops, load_scratch

#: the predictors (step 1) and velocity updates (step 3), as the kernel's codes
PREDICTORS = {"none": 0, "projected": 1, "projected_klapproth": 2}


class KaneOps(NamedTuple):
    """Kane's step's operators: M, K, F, S's factor with its Delassus matrix W and
    response Z (kept or not), M's factor with C M^-1 C^T and M^-1 C^T (the projected
    predictors'), the contact dofs and gaps, dt, the predictor's code, the energy's
    offset and the LCP's tolerance."""

    M: CSR
    K: CSR
    F: np.ndarray
    fac: LU
    ct: ContactOps  # the gaps with S's factor: W = G S^-1 G^T, Z = S^-1 G^T
    at_contact: np.ndarray  # -gap0
    weights: np.ndarray
    mfac: LU
    ctm: ContactOps  # the gaps with M's factor (the projected predictors')
    dt: float
    predictor: int
    offset: float
    tol: float
    load: LoadOps | NoLoad  # the time load (`contact_bench.kernels.time_load`)


class KaneState(NamedTuple):
    """(U, V), the step's force, the two LCPs' unknowns and active sets, the loads at
    t_n and t_{n+1}, scratch."""

    U: np.ndarray
    V: np.ndarray
    force: np.ndarray
    mu: np.ndarray
    mup: np.ndarray
    active: np.ndarray
    activep: np.ndarray
    was: np.ndarray  # (2,): the previous step's LCPs ran (the step's, the predictor's)
    Ut: np.ndarray
    X: np.ndarray
    rhs: np.ndarray
    w: np.ndarray
    work: np.ndarray
    gf: np.ndarray
    Fa: np.ndarray
    Fb: np.ndarray
    vals: np.ndarray


@njit(inline="always")
def _kane_free(o, s, step):  # pragma: no cover - compiled
    """Steps 1 and 2 without the step's contact force: U~ (s.Ut; projected with the
    projecting predictors, s.mup its multipliers) and X = S^-1 (M U~ - h^2/4 K U^n +
    h^2/4 (F(t_n) + F(t_{n+1}))); 2 F is the sum of the loads at t_n and t_{n+1} (the
    trapezoidal rule)."""
    U, V, Ut, X, rhs, w, work, gf = s.U, s.V, s.Ut, s.X, s.rhs, s.w, s.work, s.gf
    mup, dt, predictor = s.mup, o.dt, o.predictor
    n = U.size
    c = 0.25 * dt * dt
    for i in range(n):  # 1. the predictor U^n + h V^n ...
        Ut[i] = U[i] + dt * V[i]
    mup[:] = 0.0
    if predictor > 0:  # ... projected onto the admissible set in the M norm
        pen = gaps(o.ctm, Ut, gf)
        if pen:
            lcp_solve(o.ctm.W, gf, mup, s.activep, o.tol, s.was[1])
            push(o.ctm, o.mfac, mup, Ut, (rhs, w, work))
            hold(o.ctm, s.activep, Ut, o.at_contact)
        s.was[1] = pen
    # 2. S U^{n+1} = M U~ - h^2/4 K U^n + h^2/4 (F(t_n) + F(t_{n+1})) + C^T mu
    Fa = force_at(o.load, o.F, (step - 1) * dt, s.vals, s.Fa)
    Fb = force_at(o.load, o.F, step * dt, s.vals, s.Fb)
    matvec(o.M, Ut, rhs)
    matvec(o.K, U, w)
    for i in range(n):
        rhs[i] += c * (Fa[i] + Fb[i] - w[i])
    lu(o.fac, rhs, X, work)


@njit(inline="always")
def _kane_update(o, s, mu):  # pragma: no cover - compiled
    """The step's force from the normal multipliers mu (and the predictor's) and step 3:
    V^{n+1} = B + 2 / h (U^{n+1} - U~), U^{n+1} = X."""
    U, V, Ut, X = s.U, s.V, s.Ut, s.X
    mup, lam, dt, predictor = s.mup, s.force, o.dt, o.predictor
    n = U.size
    nc = o.at_contact.size
    idt2 = 1.0 / (dt * dt)
    for j in range(nc):
        lam[j] = 2.0 * mu[j] * idt2
        if predictor == 2:
            lam[j] += mup[j] * idt2
    # 3. V^{n+1} = B + 2 / h (U^{n+1} - U~)
    for i in range(n):
        base = (Ut[i] - U[i]) / dt if predictor == 2 else V[i]
        V[i] = base + 2.0 * (X[i] - Ut[i]) / dt
        U[i] = X[i]


@njit(cache=True)
def kane_step(o, s, step):  # pragma: no cover - compiled
    """Kane's step, with the predictor `o.predictor` (module docstring)."""
    _kane_free(o, s, step)
    s.was[0] = signorini(o.ct, o.fac, s.X, s.mu, s.active, s.was[0], o.tol,
                         (s.gf, s.rhs, s.w, s.work))
    _kane_update(o, s, s.mu)
    return OK


@njit(cache=True)
def kane_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `kane_step`."""
    return drive(kane_step, plain_sample, ops, st, rec, nsteps, stride)


def kane_state(o: KaneOps, initial: tuple[np.ndarray, ...]) -> KaneState:
    """A fresh `KaneState` from the initial (U, V), copied, and zeroed scratch."""
    U, V = (a.copy() for a in initial)
    n, nc = U.size, o.at_contact.size
    vals, Fa = load_scratch(o.load, n)
    return KaneState(U, V, np.zeros(nc), np.zeros(nc), np.zeros(nc), np.zeros(nc, np.bool_),
                     np.zeros(nc, np.bool_), np.zeros(2, np.bool_), np.empty(n), np.empty(n),
                     np.empty(n), np.empty(n), np.empty(n), np.empty(nc), Fa, np.empty(n),
                     vals)


class KaneStepper(LoopStepper):
    """Kane's step prepared (module docstring): S = M + h^2/4 K factored with its Delassus
    matrix and, with a projected predictor, M factored with C M^-1 C^T."""

    adds_time_load = True
    any_gap_operator = True
    follows_curved = True
    loop = staticmethod(kane_loop)

    def __init__(self, p: SparseProblem, dt: float, predictor: str = "none") -> None:
        if predictor not in PREDICTORS:
            raise ValueError(f"predictor must be one of {tuple(PREDICTORS)}, got {predictor!r}")
        super().__init__(p, dt)
        n, h = p.nfree, self.dt
        if np.any(p.massless):
            raise ValueError("Kane's step needs mass on every dof (the predictor projects "
                             "in the mass norm)")
        G = sp.csr_matrix(p.contact.gap_operator(n))
        gap0 = np.asarray(p.contact.gap0, float)
        M, K = sp.csr_matrix(p.M), sp.csr_matrix(p.K)
        fac = Factor.of(M + (0.25 * h * h) * K)
        self.factor = fac
        ct = contact_ops(fac, G, gap0, obstacle=p.contact.obstacle)
        if PREDICTORS[predictor]:
            mfac = Factor.of(M)
            ctm = contact_ops(mfac, G, gap0, obstacle=p.contact.obstacle)
        else:  # no projection: placeholders the step never reads
            mfac, ctm = fac, ct
        tol = 1e-13 * max(float(np.max(np.abs(p.U0))),
                          float(np.max(np.abs(p.contact.gap0), initial=0.0)), 1e-300)
        self.ops = KaneOps(csr_arrays(M), csr_arrays(K), np.asarray(p.F, float), fac.arrays, ct,
                           -gap0, np.asarray(p.contact.weights, float), mfac.arrays, ctm, h,
                           PREDICTORS[predictor], float(p.energy_offset), tol, load_ops(p))
        self.initial = (p.U0.astype(float).copy(), p.V0.astype(float).copy())

    def new_state(self) -> KaneState:
        return kane_state(self.ops, self.initial)


def prepare_kane(p: SparseProblem, dt: float, predictor: str = "none") -> KaneStepper:
    """Kane's step on `p` with step `dt` (module docstring); `predictor` one of
    `PREDICTORS`: "none" (Kane et al.), "projected" (Deuflhard-Krause-Ertel),
    "projected_klapproth" (their predictor with Klapproth's velocity update). With
    friction (`ContactSet.frictional`) Coulomb's law in step 2 (`kane_friction_step`).
    ValueError when a dof has no mass."""
    if p.contact.frictional:
        return FrictionalKaneStepper(p, dt, predictor)
    return KaneStepper(p, dt, predictor)


# ------------------------------------------------- Coulomb friction (Krause-Walloth)


FrictionalKaneState = with_tforce(
    KaneState, "FrictionalKaneState",
    """`KaneState` with the step's force on each tangent row (`tforce`); `mu` holds (r_n,
    r_t).""")


class FrictionalKaneOps(NamedTuple):
    """Kane's operators (`KaneOps`) and the frictional contact (`Friction`: the stacked
    normal and tangent rows' Delassus matrix with S's factor)."""

    base: KaneOps
    fr: Friction


@njit(cache=True)
def kane_friction_step(o, s, step):  # pragma: no cover - compiled
    """Kane's step with Coulomb friction in step 2 (Krause and Walloth's frictional
    contact-stabilized Newmark; the predictor's projection stays normal only): Signorini
    on the gaps of U^{n+1} and Coulomb on V^{n+1} = (2 / h) (U^{n+1} - Y), Y = U~ - h B / 2
    (affine in U^{n+1} with one positive factor: the tangent rows of X - Y are the slips
    in the law's units), with the bound |r_t| <= thr + mu (r_n + mu_p / 2) under
    Klapproth's velocity: the predictor's normal impulse mu_p / h enters V^{n+1} beside
    the step's 2 r_n / h, so a sliding point's tangential impulse is mu times its whole
    normal impulse (`coulomb_bound`); without it (dke) mu_p moves no momentum and the
    bound is thr + mu r_n. s.mu holds (r_n, r_t), the next step's warm start."""
    b, fr = o.base, o.fr
    _kane_free(b, s, step)
    U, V, Ut, X, gf, r, mup = s.U, s.V, s.Ut, s.X, s.gf, s.mu, s.mup
    n = U.size
    nc = b.at_contact.size
    klap = b.predictor == 2
    pen = gaps(b.ct, X, gf)
    thr = fr.thr.copy()
    if klap:
        for j in range(nc):
            if mup[j] > 0.0 and fr.mu[j] > 0.0:
                thr[j] += 0.5 * fr.mu[j] * mup[j]
                pen = True
    if pen:
        q = np.empty(r.size)
        Y = np.empty(n)
        for i in range(n):
            Y[i] = X[i] - (0.5 * (Ut[i] + U[i]) if klap else Ut[i] - 0.5 * b.dt * V[i])
        for j in range(nc):
            q[j] = gf[j]
        for i in range(nc, r.size):
            q[i] = row_value(fr.ct, i, Y)
        coulomb_bound(fr, np.arange(nc), q, r, thr, max(b.tol, 1e-13 * np.max(np.abs(q))))
        push(fr.ct, b.fac, r, X, (s.rhs, s.w, s.work))
        for j in range(nc):
            s.active[j] = r[j] > 0.0
        hold(b.ct, s.active, X, b.at_contact)  # in contact: the gap is 0 exactly
    else:
        r[:] = 0.0
        s.active[:] = False
    _kane_update(b, s, r)
    idt2 = 1.0 / (b.dt * b.dt)
    for i in range(nc, r.size):  # the tangential force, as the normal one's 2 r_n / h^2
        s.tforce[i - nc] = 2.0 * r[i] * idt2
    return OK


@njit(cache=True)
def kane_friction_sample(o, s):  # pragma: no cover - compiled
    """`plain_sample` of the base operators."""
    return plain_sample(o.base, s)


@njit(cache=True)
def kane_friction_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `kane_friction_step`."""
    return drive(kane_friction_step, kane_friction_sample, ops, st, rec, nsteps, stride)


class FrictionalKaneStepper(KaneStepper):
    """`KaneStepper` on a problem with friction (`ContactSet.frictional`): the same
    set-up, the stacked normal and tangent rows' Delassus matrix with S's factor,
    `kane_friction_step`. A curved obstacle is refused (its tangent rows would stay
    fixed while the normals follow it)."""

    follows_curved = False
    loop = staticmethod(kane_friction_loop)

    def __init__(self, p: SparseProblem, dt: float, predictor: str = "none") -> None:
        super().__init__(p, dt, predictor)
        self.ops = FrictionalKaneOps(self.ops, friction_ops(self.factor, p.contact, p.nfree))

    def new_state(self) -> FrictionalKaneState:
        st = kane_state(self.ops.base, self.initial)
        nc, nr = st.force.size, self.ops.fr.ct.gap0.size
        return FrictionalKaneState(*st._replace(mu=np.zeros(nr)), np.zeros(nr - nc))


# ------------------------------------------------------------------ the bar, banded


@njit(cache=True)
def _kane_banded_kernel(bar, S, wM, U, V, predictor, run, out):  # pragma: no cover - compiled
    """`_kane_kernel`'s step on the tridiagonal bar (the `Bar`), node 0 on the obstacle at
    0: S the `Implicit` factors (df, ef) of S = M + dt^2/4 K with wS = S^-1 e0, wM = M^-1
    e0; run: the `Run`; out: the `Samples`. Returns (samples, steps, min u0, blow-up step
    or -1)."""
    Md, Me, Kd, Ke, F = bar
    df, ef, wS = S
    dt, nsteps, stride, offset = run
    E_out = out.energy
    n = U.size
    c = 0.25 * dt * dt
    idt = 1.0 / dt
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)
    Ut = np.empty(n)
    X = np.empty(n)
    tmp = np.empty(n)
    E0 = E_out[0]
    min_u0 = U[0]
    k = 1
    for step in range(1, nsteps + 1):
        for i in range(n):
            Ut[i] = U[i] + dt * V[i]
        mup = 0.0
        if predictor > 0 and Ut[0] < 0.0:
            mup = -Ut[0] / wM[0]
            for i in range(n):
                Ut[i] += mup * wM[i]
            Ut[0] = 0.0
        tri_matvec(Md, Me, Ut, X)
        tri_matvec(Kd, Ke, U, tmp)
        for i in range(n):
            X[i] += c * (2.0 * F[i] - tmp[i])
        pt_solve(df, ef, X)
        mu = 0.0
        if X[0] < 0.0:
            mu = -X[0] / wS[0]
            for i in range(n):
                X[i] += mu * wS[i]
            X[0] = 0.0
        lam = 2.0 * mu * idt * idt
        if predictor == 2:
            lam += mup * idt * idt
        for i in range(n):
            base = (Ut[i] - U[i]) * idt if predictor == 2 else V[i]
            V[i] = base + 2.0 * (X[i] - Ut[i]) * idt
            U[i] = X[i]
        min_u0 = min(min_u0, U[0])
        if step % stride == 0 or step == nsteps:
            energy = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
            record_sample(k, step * dt, U, V, -lam, energy, out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1


class BandedKaneStepper(Stepper):
    """Kane's step on the bar's tridiagonal form, prepared: S = M + dt^2/4 K and M
    factored, S^-1 e0 and M^-1 e0 computed once."""

    def __init__(self, semi: Semidiscrete, dt: float, predictor: str = "none") -> None:
        if predictor not in PREDICTORS:
            raise ValueError(f"predictor must be one of {tuple(PREDICTORS)}, got {predictor!r}")
        if semi.massless:
            raise ValueError("Kane's step needs a contact node with mass")
        self.semi, self.dt, self.predictor = semi, float(dt), PREDICTORS[predictor]
        M, K, c = semi.M, semi.K, 0.25 * self.dt * self.dt
        self.df, self.ef = factor_pt(M.diag + c * K.diag, M.off + c * K.off)
        self.wS = np.zeros(semi.nfree)
        self.wS[0] = 1.0
        pt_solve(self.df, self.ef, self.wS)
        self.wM = np.zeros(semi.nfree)
        self.wM[0] = 1.0
        dfm, efm = factor_pt(M.diag, M.off)
        pt_solve(dfm, efm, self.wM)

    def run(self, nsteps: int, stride: int) -> Trajectory:
        semi = self.semi
        M, K = semi.M, semi.K
        out = allocate(semi, nsteps, stride)
        U, V = semi.U0.astype(float).copy(), semi.V0.astype(float).copy()
        out.U[0], out.V[0], out.cu[0] = U, V, U[0]
        out.energy[0] = energy_rows(row_sums(M.diag, M.off), M.off, row_sums(K.diag, K.off),
                                    K.off, semi.F, U, V, semi.energy_offset)
        k, done, min_u0, blow = _kane_banded_kernel(
            bar_ops(semi), Implicit(self.df, self.ef, self.wS), self.wM, U, V, self.predictor,
            run_spec(semi, self.dt, nsteps, stride), out)
        return trajectory(out, k, done, min_u0, blow, self.dt)


def prepare_kane_banded(semi: Semidiscrete, dt: float, predictor: str = "none"
                        ) -> BandedKaneStepper:
    """`prepare_kane` on the bar's tridiagonal form (module docstring). ValueError with
    a massless contact node."""
    return BandedKaneStepper(semi, dt, predictor)
