"""Doyen, Ern and Piperno's semi-explicit modified mass scheme, compiled: the bar and the
2D/3D body.

The mass is lumped (diagonal) with massless contact dofs, the total mass kept
(`contact_bench.api.fem.LUMPED_MASSLESS`, `contact_bench.api.fem_nd.lumped_massless`). On a
body a time-dependent load (`contact_bench.api.sparse.TimeLoad`) is added at each step's end.
A step is central differences in velocity-Verlet form on the dofs with mass h, one
division by their lumped mass each, no mass solve:

    V_h += dt/2 A_h;  U_h += dt V_h
    K_mm U_m = F_m - K_mh U_h + C^T lambda,  g = gap0 + C U_m >= 0, lambda >= 0, g.lambda = 0
    A_h = (F_h - (K U)_h) / m_h;  V_h += dt/2 A_h

then the massless dofs' velocity is their backward difference (they carry no kinetic
energy). On the bar the static solve is one node: u_0 = max(0, (F_0 - K_01 u_1) / K_00),
lambda = K_00 u_0 + K_01 u_1 - F_0 (`contact_bench.core.tridiag.eliminate_contact_node`).
On a body K_mm is factored once and the contact is exact on the contact dofs among the
massless ones: the contact-free solution corrected by Z mu, Z = K_mm^-1 C^T, mu from the
complementarity problem on the Delassus matrix W = C K_mm^-1 C^T (computed once;
`contact_bench.kernels.solvers.lcp_solve`). The contact stress is -sum(lambda) / area.

The stability limit is lumped central differences' on the mass with the massless dofs
eliminated, in the stiffest contact state (the massless contact dofs held on the obstacle,
the others statically condensed): dt < 2 / omega_max (`bar_limit`, `body_limit`); on a
uniform bar about h / c.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.linalg import eigh_tridiagonal

from contact_bench.api.plugin import Semidiscrete, Trajectory
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.loop import OK, drive
from contact_bench.core.sampling import (
    Run,
    blown_up,
    energy_rows,
    is_sample,
    record_sample,
    row_sums,
)
from contact_bench.core.tridiag import eliminate_contact_node, tri_matvec
from contact_bench.kernels.common import allocate, trajectory
from contact_bench.kernels.contact import (
    ContactOps,
    contact_ops,
    gaps,
    is_curved,
    restrict,
)
from contact_bench.kernels.csr import CSR, csr_arrays, matvec
from contact_bench.kernels.linalg import LU, Factor
from contact_bench.kernels.recording import plain_sample
from contact_bench.kernels.solvers import lcp_solve
from contact_bench.kernels.sparse import massless_solve
from contact_bench.kernels.sparse_family import condensed_stiffness
from contact_bench.kernels.stepper import LoopStepper
from contact_bench.kernels.time_load import (
    LoadOps,
    NoLoad,
    force_at,
    initial_load,
    load_ops,
    load_scratch,
)

# ------------------------------------------------------------------------------ the bar


@njit(cache=True)
def bar_kernel(bar, U, V, run, out):  # pragma: no cover - compiled
    """The bar (module docstring): bar = (m, Kd, Ke, F), the lumped mass (m[0] = 0), K's
    bands and the load; U, V advanced in place; run a `Run`; out the `Samples`. Returns
    (samples, steps, smallest u_0, blow-up step or -1)."""
    m, Kd, Ke, F = bar
    dt, nsteps, stride, offset = run
    n = U.size
    h = 0.5 * dt
    A = np.zeros(n)
    KU = np.empty(n)
    Me = np.zeros(n - 1)
    rK = row_sums(Kd, Ke)
    # sample 0 is the given initial state; the scheme starts from it with the massless
    # node at its static position (the first element's strain energy released)
    E0 = energy_rows(m, Me, rK, Ke, F, U, V, offset)
    record_sample(0, 0.0, U, V, 0.0, E0, out)
    min_u0 = U[0]
    eliminate_contact_node(Kd, Ke, F, U)
    tri_matvec(Kd, Ke, U, KU)
    for i in range(1, n):
        A[i] = (F[i] - KU[i]) / m[i]
    k = 1
    for step in range(1, nsteps + 1):
        for i in range(1, n):
            V[i] += h * A[i]
            U[i] += dt * V[i]
        u0 = U[0]
        lam = eliminate_contact_node(Kd, Ke, F, U)
        V[0] = (U[0] - u0) / dt
        tri_matvec(Kd, Ke, U, KU)
        for i in range(1, n):
            A[i] = (F[i] - KU[i]) / m[i]
            V[i] += h * A[i]
        if U[0] < min_u0:
            min_u0 = U[0]
        if is_sample(step, nsteps, stride):
            energy = energy_rows(m, Me, rK, Ke, F, U, V, offset)
            record_sample(k, step * dt, U, V, -lam, energy, out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1


def bar_limit(semi: Semidiscrete) -> float:
    """2 / omega_max of the interior (nodes 1..) with node 0 held: the generalized
    eigenvalue of (K_11, diag(m)), a symmetric tridiagonal problem solved for its largest
    eigenvalue alone (LAPACK's bisection, O(n))."""
    m = np.asarray(semi.M.diag[1:], float)
    if m.size < 1 or np.any(m <= 0.0) or np.any(semi.M.off != 0.0) or semi.M.diag[0] != 0.0:
        raise ValueError("the semi-explicit bar needs a lumped mass with a massless node 0")
    s = 1.0 / np.sqrt(m)
    d = semi.K.diag[1:] * s * s
    if m.size == 1:
        return float(2.0 / np.sqrt(d[0]))
    e = semi.K.off[1:] * s[:-1] * s[1:]
    top = eigh_tridiagonal(d, e, eigvals_only=True, select="i",
                           select_range=(m.size - 1, m.size - 1), lapack_driver="stebz")
    return float(2.0 / np.sqrt(top[0]))


def run_bar(semi: Semidiscrete, dt: float, nsteps: int, stride: int) -> Trajectory:
    """`bar_kernel` from the initial state; memory: the samples only."""
    bar_limit(semi)  # the mass's shape checked (a one-line ValueError)
    U, V = semi.U0.astype(float).copy(), semi.V0.astype(float).copy()
    out = allocate(semi, nsteps, stride)
    k, done, min_u0, blow = bar_kernel(
        (np.asarray(semi.M.diag, float), semi.K.diag, semi.K.off, semi.F), U, V,
        Run(float(dt), int(nsteps), int(stride), float(semi.energy_offset)), out)
    return trajectory(out, k, done, min_u0, blow, dt)


# ----------------------------------------------------------------------------- a body


class BodyOps(NamedTuple):
    """A body's semi-explicit step: M, K (the energy), the lumped mass's diagonal m, F,
    the dofs with mass (hv) and the massless ones (mv), K's rows Kh = K[hv] and Km =
    K[mv] (massless columns dropped), K_mm's factor, the gaps restricted to the massless
    dofs (`ContactOps`, with K_mm's factor), the time load."""

    M: CSR
    K: CSR
    m: np.ndarray
    F: np.ndarray
    hv: np.ndarray
    mv: np.ndarray
    Kh: CSR
    Km: CSR
    mfac: LU
    ct: ContactOps
    at_contact: np.ndarray  # -gap0
    weights: np.ndarray
    load: LoadOps | NoLoad  # the time load (`contact_bench.kernels.time_load`)
    dt: float
    offset: float
    tol: float


class BodyState(NamedTuple):
    """(U, V, A), the obstacle's forces and active set, the load at the step's end,
    scratch."""

    U: np.ndarray
    V: np.ndarray
    A: np.ndarray
    force: np.ndarray
    active: np.ndarray
    was: np.ndarray
    Fn: np.ndarray
    vals: np.ndarray
    rm: np.ndarray
    um: np.ndarray
    wm: np.ndarray
    rh: np.ndarray
    w: np.ndarray
    gf: np.ndarray


@njit(cache=True)
def body_step(o, s, step):  # pragma: no cover - compiled
    """One step on a body (module docstring)."""
    U, V, A, rh = s.U, s.V, s.A, s.rh
    hv, mv, dt, m = o.hv, o.mv, o.dt, o.m
    nh, nm = hv.size, mv.size
    h = 0.5 * dt
    Fn = force_at(o.load, o.F, step * dt, s.vals, s.Fn)  # the load at the step's end
    for a in range(nh):
        i = hv[a]
        V[i] += h * A[i]
        U[i] += dt * V[i]
    for b in range(nm):  # the massless dofs' old positions, kept in V until solved
        V[mv[b]] = U[mv[b]]
    s.was[0] = massless_solve(o, Fn, U, s.force, s.active, s.was[0],
                              (s.rm, s.um, s.wm, s.gf))  # exactly on the obstacle
    for b in range(nm):  # their backward difference
        i = mv[b]
        V[i] = (U[i] - V[i]) / dt
    matvec(o.Kh, U, rh)  # (K U)_h
    for a in range(nh):
        i = hv[a]
        A[i] = (Fn[i] - rh[a]) / m[i]
        V[i] += h * A[i]
    return OK


@njit(cache=True)
def body_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `body_step`."""
    return drive(body_step, plain_sample, ops, st, rec, nsteps, stride)


def split(p: SparseProblem) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(m, hv, mv, held): the lumped mass's diagonal, the dofs with mass, the massless
    ones and, among these, the positions of those in a contact row. ValueError unless the
    mass is diagonal, every dof in a contact row is massless and some dof has mass."""
    M = sp.csr_matrix(p.M)
    m = np.asarray(M.diagonal(), float)
    if M.nnz != np.count_nonzero(m) or np.any(m < 0.0):
        raise ValueError("the semi-explicit scheme needs a diagonal (lumped) mass")
    hv, mv = np.flatnonzero(m > 0.0), np.flatnonzero(m == 0.0)
    G = sp.csr_matrix(p.contact.gap_operator(p.nfree))
    pos = np.full(p.nfree, -1)
    pos[mv] = np.arange(mv.size)
    held = pos[np.unique(G.indices)]
    if hv.size == 0 or np.any(held < 0):
        raise ValueError("the semi-explicit scheme needs massless contact dofs and dofs "
                         "with mass")
    return m, hv, mv, np.asarray(held, np.int64)


def body_limit(p: SparseProblem) -> float:
    """2 / omega_max of lumped central differences on the dofs with mass, the massless
    contact dofs held and the other massless dofs condensed (their rows solved): the
    largest eigenvalue of D^-1/2 S D^-1/2, S the Schur complement, D the lumped mass."""
    from scipy.sparse.linalg import eigsh

    m, hv, mv, cl = split(p)
    free = np.ones(mv.size, bool)
    free[cl] = False
    op = condensed_stiffness(sp.csr_matrix(p.K), hv, mv[free], 1.0 / np.sqrt(m[hv]))
    if hv.size <= 2:
        raise ValueError("the semi-explicit scheme needs more than two dofs with mass")
    lam = eigsh(op, k=1, which="LA", tol=1e-10, return_eigenvectors=False,
                v0=np.random.default_rng(0).standard_normal(hv.size))  # the same each call
    return float(2.0 / np.sqrt(lam[0]))


class BodyStepper(LoopStepper):
    """`body_step` prepared: K_mm factored, the Delassus and response matrices, the
    massless dofs solved at t = 0 and the initial acceleration, once."""

    adds_time_load = True
    any_gap_operator = True
    follows_curved = True
    loop = staticmethod(body_loop)

    def __init__(self, p: SparseProblem, dt: float) -> None:
        super().__init__(p, dt)
        m, hv, mv, _ = split(p)
        K = sp.csr_matrix(p.K)
        fac = Factor.of(K[mv][:, mv])
        G = sp.csr_matrix(p.contact.gap_operator(p.nfree))[:, mv]
        gap0 = np.asarray(p.contact.gap0, float)
        ct = contact_ops(fac, G, gap0, keep=True,
                         obstacle=restrict(p.contact.obstacle, mv, p.nfree))
        keep = np.ones(p.nfree)
        keep[mv] = 0.0
        Kmh = sp.csr_matrix(K[mv] @ sp.diags(keep))
        Kmh.eliminate_zeros()
        tol = 1e-13 * max(float(np.max(np.abs(p.U0))), float(np.max(np.abs(gap0), initial=0.0)),
                          1e-300)
        U = np.asarray(p.U0, float).copy()
        F0 = initial_load(p)  # the load at t = 0
        um = fac.solve(F0[mv] - Kmh @ U)  # the massless dofs at t = 0, exact contact
        gf = gap0 + G @ um
        if is_curved(ct):  # a curved obstacle: its exact gaps, its tangent at um
            gaps(ct, um, gf)
        mu = np.zeros(gap0.size)
        if np.any(gf < 0.0):
            lcp_solve(ct.W, gf, mu, np.zeros(gap0.size, np.bool_), tol)
            um += ct.Z @ mu
        U[mv] = um
        A = np.zeros(p.nfree)
        A[hv] = (F0[hv] - K[hv] @ U) / m[hv]
        self.initial = (U, np.asarray(p.V0, float).copy(), A)
        self.gamma = 0.5
        self.ops = BodyOps(
            csr_arrays(p.M), csr_arrays(K), m, np.asarray(p.F, float), hv, mv,
            csr_arrays(K[hv]), csr_arrays(Kmh), fac.arrays, ct, -gap0,
            np.asarray(p.contact.weights, float), load_ops(p), self.dt,
            float(p.energy_offset), tol)

    def new_state(self) -> BodyState:
        o = self.ops
        n, nh, nm, nc = self.problem.nfree, o.hv.size, o.mv.size, o.at_contact.size
        U, V, A = (a.copy() for a in self.initial)
        vals, Fn = load_scratch(o.load, n)
        return BodyState(U, V, A, np.zeros(nc), np.zeros(nc, np.bool_), np.zeros(1, np.bool_),
                         Fn, vals, np.empty(nm), np.empty(nm),
                         np.empty(nm), np.empty(nh), np.empty(n), np.empty(nc))


def prepare_body(p: SparseProblem, dt: float) -> BodyStepper:
    """The semi-explicit scheme on a body's problem (module docstring)."""
    return BodyStepper(p, dt)
