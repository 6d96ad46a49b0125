"""The midpoint rule with energy-conserving contact: Laursen-Chawla and Laursen-Love.

Shared by `schemes/laursen_chawla.py` and `schemes/laursen_love.py`, on every problem
form (the bar's `BarProblem` through its CSR matrices, a body's `SparseProblem`). The
step is the implicit midpoint rule with the obstacle's force lambda acting at the
midpoint,

    M (V1 - V0) / dt + K (U0 + U1) / 2 = F + C^T lambda,    U1 - U0 = dt (V0 + V1) / 2,

(a time-dependent load F at the midpoint t_{n+1/2})
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

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit

from contact_bench.api.sparse import SparseProblem
from contact_bench.core.loop import OK, drive
from contact_bench.core.refcount import uncounted_inline
from contact_bench.kernels.contact import (
    ContactOps,
    contact_ops,
    gaps,
    hold,
    push,
    row_dot,
    spread,
)
from contact_bench.kernels.csr import CSR, csr_arrays, matvec
from contact_bench.kernels.linalg import LU, lu
from contact_bench.kernels.recording import csr_energy
from contact_bench.kernels.solvers import lcp_solve
from contact_bench.kernels.sparse import Factor
from contact_bench.kernels.stepper import LoopStepper
from contact_bench.kernels.time_load import LoadOps, NoLoad, force_at, load_ops, load_scratch

#: Laursen-Chawla: the persistency condition on the dofs closed at t_n
PERSISTENCY = 0
#: Laursen-Love: exact Signorini at t_{n+1}, then the energy-restoring velocity update
SIGNORINI_VELOCITY_UPDATE = 1
MODES = (PERSISTENCY, SIGNORINI_VELOCITY_UPDATE)


class MidpointOps(NamedTuple):
    """The midpoint step's operators: M, K, F, S's factor, the contact dofs and gaps, the
    Delassus matrix W and response Z (kept or not), M's factor and M^-1 C^T (kept or
    not: Laursen-Love's update), dt, the contact condition `mode`, the energy's offset,
    the LCP's tolerance."""

    M: CSR
    K: CSR
    F: np.ndarray
    fac: LU
    ct: ContactOps  # the gaps with S's factor
    at_contact: np.ndarray  # -gap0
    weights: np.ndarray
    mfac: LU
    Y: np.ndarray
    keep_y: bool
    dt: float
    mode: int
    offset: float
    tol: float
    load: LoadOps | NoLoad  # the time load (`contact_bench.kernels.time_load`)


class MidpointState(NamedTuple):
    """(U, V), the obstacle's force lambda and the step's force with Laursen-Love's update
    (`force`), the LCP's unknowns and active set, the gaps at t_n and t_{n+1}, the load,
    scratch (`target`: the values the held contact dofs are put on)."""

    U: np.ndarray
    V: np.ndarray
    g0: np.ndarray
    g1: np.ndarray
    force: np.ndarray
    lam: np.ndarray
    mu: np.ndarray
    active: np.ndarray
    was: np.ndarray
    qg: np.ndarray
    rhs: np.ndarray
    X: np.ndarray
    w: np.ndarray
    work: np.ndarray
    y: np.ndarray
    Fn: np.ndarray
    vals: np.ndarray
    target: np.ndarray


@uncounted_inline
def midpoint_step(o, s, step):  # pragma: no cover - compiled
    """The midpoint step with the contact condition `o.mode` (module docstring); F is the
    load at the midpoint t_{n+1/2}. Compiled without reference counting
    (`contact_bench.core.refcount`): it allocates nothing (the held targets in `s.target`)."""
    U, V, X, rhs, w, work, qg, target = s.U, s.V, s.X, s.rhs, s.w, s.work, s.qg, s.target
    mu, lam, kick, active, y, g0, g1 = s.mu, s.lam, s.force, s.active, s.y, s.g0, s.g1
    was, vals, Fn = s.was, s.vals, s.Fn
    M, K, F0, fac, ct, load, at_contact = o.M, o.K, o.F, o.fac, o.ct, o.load, o.at_contact
    mfac, Y, keep_y, dt, mode, tol = o.mfac, o.Y, o.keep_y, o.dt, o.mode, o.tol
    sel, W, G = ct.sel, ct.W, ct.G
    n = U.size
    nc = sel.size
    q = 0.25 * dt * dt
    to_force = 2.0 / (dt * dt)
    F = force_at(load, F0, (step - 0.5) * dt, vals, Fn)
    for i in range(n):
        w[i] = U[i] + dt * V[i]
    matvec(M, w, rhs)
    matvec(K, U, w)
    for i in range(n):
        rhs[i] += q * (2.0 * F[i] - w[i])
    lu(fac, rhs, X, work)
    gaps(ct, U, g0)
    gaps(ct, X, g1)
    pen = False
    for j in range(nc):
        d = sel[j]
        if mode == PERSISTENCY:  # the increment on the points closed at t_n, else free
            if g0[j] <= tol:
                qg[j] = X[d] - U[d] if d >= 0 else g1[j] - g0[j]
            else:
                qg[j] = np.inf
        else:  # the gap at t_{n+1}
            qg[j] = g1[j]
        pen = pen or qg[j] < 0.0
    if pen:
        for j in range(nc):
            active[j] = active[j] and qg[j] < np.inf  # a free point is never active
        lcp_solve(W, qg, mu, active, tol, was[0])
        push(ct, fac, mu, X, (rhs, w, work))
        # exactly: no increment (persistency), or gap 0 (Signorini)
        for j in range(nc):
            target[j] = U[max(sel[j], 0)] if mode == PERSISTENCY else at_contact[j]
        hold(ct, active, X, target)
    else:
        mu[:] = 0.0
    was[0] = pen
    loss = 0.0  # lambda . (g0 - g1): the energy the contact took this step
    for j in range(nc):
        lam[j] = to_force * mu[j]
        if g0[j] > tol:  # arrived from an open gap (beyond round-off)
            d = sel[j]
            loss += lam[j] * ((U[d] - X[d]) if d >= 0 else (row_dot(G, j, U)
                                                            - row_dot(G, j, X)))
    for i in range(n):
        V[i] = (X[i] - U[i]) * (2.0 / dt) - V[i]
        U[i] = X[i]
    for j in range(nc):
        kick[j] = lam[j]
    if mode == SIGNORINI_VELOCITY_UPDATE and loss > 0.0:
        # y = M^-1 G^T lambda; a = 1/2 lambda.D_M.lambda; b = lambda.(G V1)
        if keep_y:
            for i in range(n):
                acc = 0.0
                for j in range(nc):
                    acc += Y[i, j] * lam[j]
                y[i] = acc
        else:
            spread(ct, lam, rhs)
            lu(mfac, rhs, y, work)
        a = 0.0
        b = 0.0
        for j in range(nc):
            d = sel[j]
            a += 0.5 * lam[j] * (y[d] if d >= 0 else row_dot(G, j, y))
            b += lam[j] * (V[d] if d >= 0 else row_dot(G, j, V))
        if a > 0.0:
            # the root s >= 0: the obstacle's impulse pushes (lambda >= 0)
            root = np.sqrt(b * b + 4.0 * a * loss)
            sv = 2.0 * loss / (b + root) if b > 0.0 else (root - b) / (2.0 * a)
            for i in range(n):
                V[i] += sv * y[i]
            for j in range(nc):
                kick[j] += sv * lam[j] / dt
    return OK


@njit(cache=True)
def midpoint_sample(o, s):  # pragma: no cover - compiled
    """The energy, the stress of every contact force the step applied (Laursen-Love's:
    the obstacle's lambda and its energy-restoring kick spread over the step) and V."""
    e = csr_energy(o.M, o.K, o.F, s.U, s.V, o.offset, s.w)
    return e, -s.force.sum() / o.weights.sum(), s.V


@njit(cache=True)
def midpoint_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `midpoint_step`."""
    return drive(midpoint_step, midpoint_sample, ops, st, rec, nsteps, stride)


class MidpointContactStepper(LoopStepper):
    """The midpoint step with the contact condition `mode` (module docstring) prepared:
    S = M + dt^2 / 4 K factored with its Delassus matrix and, for the velocity update,
    M factored (M^-1 C^T kept when Z is). ValueError for a mass with massless dofs (the midpoint
    velocity and the update's M^-1 need inertia on every dof)."""

    adds_time_load = True
    any_gap_operator = True
    follows_curved = True
    loop = staticmethod(midpoint_loop)

    def __init__(self, p: SparseProblem, dt: float, mode: int) -> None:
        if mode not in MODES:
            raise ValueError(f"mode = {mode!r}: not one of {MODES}")
        if np.any(p.massless):
            raise ValueError("the midpoint contact step needs a mass on every dof "
                             "(no massless dofs)")
        super().__init__(p, dt)
        dt = self.dt
        n = p.nfree
        G = sp.csr_matrix(p.contact.gap_operator(n))
        gap0 = np.asarray(p.contact.gap0, float)
        fac = Factor.of(p.M + (0.25 * dt * dt) * p.K)
        curved = p.contact.obstacle
        ct = contact_ops(fac, G, gap0, obstacle=curved)
        # M^-1 G^T kept for a fixed G; a curved obstacle's moving normals take a solve
        keep_y = mode == SIGNORINI_VELOCITY_UPDATE and ct.keep_z and curved is None
        Y, marrays = np.zeros((1, 1)), fac.arrays
        if mode == SIGNORINI_VELOCITY_UPDATE:  # M^-1 G^T kept, or a solve per update
            mfac = Factor.of(sp.csr_matrix(p.M))
            marrays = mfac.arrays
            if keep_y:
                Y = contact_ops(mfac, G, gap0, keep=True).Z
        self.initial = (p.U0.astype(float).copy(), p.V0.astype(float).copy())
        tol = 1e-13 * max(float(np.max(np.abs(p.U0))),
                          float(np.max(np.abs(p.contact.gap0), initial=0.0)), 1e-300)
        self.ops = MidpointOps(csr_arrays(p.M), csr_arrays(p.K), np.asarray(p.F, float),
                               fac.arrays, ct, -gap0, np.asarray(p.contact.weights, float),
                               marrays, np.ascontiguousarray(Y), keep_y, dt, int(mode),
                               float(p.energy_offset), tol, load_ops(p))

    def new_state(self) -> MidpointState:
        n, nc = self.problem.nfree, self.ops.at_contact.size
        U, V = (a.copy() for a in self.initial)
        vals, Fn = load_scratch(self.ops.load, n)
        return MidpointState(U, V, np.empty(nc), np.empty(nc), np.zeros(nc), np.zeros(nc),
                             np.zeros(nc), np.zeros(nc, np.bool_), np.zeros(1, np.bool_),
                             np.empty(nc), np.empty(n), np.empty(n), np.empty(n), np.empty(n),
                             np.empty(n), Fn, vals, np.empty(nc))


def prepare_midpoint_contact(p: SparseProblem, dt: float, mode: int) -> MidpointContactStepper:
    """The midpoint rule with Laursen-Chawla's persistency (`PERSISTENCY`) or Laursen-Love's
    exact contact and velocity update (`SIGNORINI_VELOCITY_UPDATE`) on a problem of the
    general form (module docstring)."""
    return MidpointContactStepper(p, dt, mode)
