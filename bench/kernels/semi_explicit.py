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
`contact_bench.kernels.sparse.lcp_solve`). The contact stress is -sum(lambda) / area.

The stability limit is lumped central differences' on the mass with the massless dofs
eliminated, in the stiffest contact state (the massless contact dofs held on the obstacle,
the others statically condensed): dt < 2 / omega_max (`bar_limit`, `body_limit`); on a
uniform bar about h / c.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.linalg import eigh_tridiagonal

from contact_bench.api.plugin import Semidiscrete, Stepper, Trajectory
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.contact_stats import impulse_update, new_stats, stats_update
from contact_bench.core.sampling import blown_up, energy_rows, is_sample, record_sample, row_sums
from contact_bench.core.tridiag import eliminate_contact_node, tri_matvec
from contact_bench.kernels.common import allocate, trajectory
from contact_bench.kernels.csr import csr_arrays, csr_matvec
from contact_bench.kernels.linalg import Factor, lu_solve
from contact_bench.kernels.recording import SampleBuffers, csr_energy, smallest_gap, write_sample
from contact_bench.kernels.sparse import lcp_solve

# ------------------------------------------------------------------------------ the bar


@njit(cache=True)
def bar_kernel(m, Kd, Ke, F, U, V, dt, nsteps, stride, offset, t_out, U_out, V_out, cu_out,
               s_out, E_out):  # pragma: no cover - compiled
    """The bar (module docstring): m the lumped mass (m[0] = 0), K's bands; U, V advanced
    in place. Returns (samples, steps, smallest u_0, blow-up step or -1)."""
    n = U.size
    h = 0.5 * dt
    A = np.zeros(n)
    KU = np.empty(n)
    Me = np.zeros(n - 1)
    rK = row_sums(Kd, Ke)
    # sample 0 is the given initial state; the scheme starts from it with the massless
    # node at its static position (the first element's strain energy released)
    E0 = energy_rows(m, Me, rK, Ke, F, U, V, offset)
    record_sample(0, 0.0, U, V, 0.0, E0, t_out, U_out, V_out, cu_out, s_out, E_out)
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
            record_sample(k, step * dt, U, V, -lam, energy, t_out, U_out, V_out, cu_out,
                          s_out, E_out)
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
        np.asarray(semi.M.diag, float), semi.K.diag, semi.K.off, semi.F, U, V, float(dt),
        int(nsteps), int(stride), float(semi.energy_offset), out["t"], out["U"], out["V"],
        out["cu"], out["s"], out["E"])
    return trajectory(out, k, done, min_u0, blow, dt)


# ----------------------------------------------------------------------------- a body


@njit(cache=True)
def body_kernel(Mp, Mi, Mx, Kp, Ki, Kx, m, F, hv, mv, cl, Khp, Khi, Khx, Kmp, Kmi, Kmx, mfac,
                W, Z, gap0, weights, load, Bp, Bi, Bx, BX, bcodes, U, V, A, dt, nsteps, stride,
                offset, t_out, U_out, V_out, cu_out, s_out, E_out, stats,
                tol):  # pragma: no cover - compiled
    """A body (module docstring): hv the dofs with mass (their lumped mass m[hv]), mv the
    massless ones, cl the contact dofs' positions in mv; Kh = K[hv] (all columns), Kmh
    = K[mv] without the massless columns, K_mm factored (`mfac`), W and Z its Delassus
    and response matrices; `load` None, or a time-dependent load's density (a cfunc) with
    its B (CSR), points BX and codes: the load at t_{n+1} is F + B v(t_{n+1})
    (`contact_bench.api.sparse.TimeLoad`). U, V, A (A on hv, at t = 0) advanced in place;
    the massless dofs of U are solved at t = 0 by the caller (sample 0, written by the
    caller, is the given initial state). Returns (samples, steps, smallest gap,
    blow-up step or -1)."""
    n = U.size
    nh, nm, nc = hv.size, mv.size, cl.size
    h = 0.5 * dt
    rm = np.empty(nm)
    um = np.empty(nm)
    wm = np.empty(nm)
    rh = np.empty(nh)
    w = np.empty(n)
    gf = np.empty(nc)
    mu = np.zeros(nc)
    active = np.zeros(nc, np.bool_)
    status = np.zeros(nc, np.bool_)
    area = weights.sum()
    E0 = E_out[0]
    gdofs = np.empty(nc, np.int64)
    for j in range(nc):
        gdofs[j] = mv[cl[j]]
    min_gap = smallest_gap(gap0, U, gdofs)
    Fn = F.copy()  # the load at the step's end (F plus the time-dependent one)
    vals = np.empty(bcodes.size)
    was = False
    k = 1
    for step in range(1, nsteps + 1):
        if load is not None:
            tl = step * dt
            for j in range(bcodes.size):
                vals[j] = load(BX[0, j], BX[1, j], BX[2, j], tl, bcodes[j])
            csr_matvec(Bp, Bi, Bx, vals, Fn)
            for i in range(n):
                Fn[i] += F[i]
        for a in range(nh):
            i = hv[a]
            V[i] += h * A[i]
            U[i] += dt * V[i]
        csr_matvec(Kmp, Kmi, Kmx, U, rm)  # K_mh U_h
        for b in range(nm):
            rm[b] = Fn[mv[b]] - rm[b]
        lu_solve(mfac[0], mfac[1], mfac[2], mfac[3], mfac[4], mfac[5], mfac[6], mfac[7],
                 rm, um, wm)
        pen = False
        for j in range(nc):
            gf[j] = gap0[j] + um[cl[j]]
            pen = pen or gf[j] < 0.0
        if pen:
            lcp_solve(W, gf, mu, active, tol, was)
            for b in range(nm):
                s = 0.0
                for j in range(nc):
                    s += Z[b, j] * mu[j]
                um[b] += s
            for j in range(nc):
                if active[j]:
                    um[cl[j]] = -gap0[j]  # exactly on the obstacle
        else:
            mu[:] = 0.0
        was = pen
        for b in range(nm):
            i = mv[b]
            V[i] = (um[b] - U[i]) / dt
            U[i] = um[b]
        csr_matvec(Khp, Khi, Khx, U, rh)  # (K U)_h
        for a in range(nh):
            i = hv[a]
            A[i] = (Fn[i] - rh[a]) / m[i]
            V[i] += h * A[i]
        stats_update(stats, status, mu, step, dt)
        impulse_update(stats, mu, dt, 0.5)
        min_gap = smallest_gap(gap0, U, gdofs, min_gap)
        if step % stride == 0 or step == nsteps:
            e = csr_energy(Mp, Mi, Mx, Kp, Ki, Kx, F, U, V, offset, w)
            blown = write_sample(k, step * dt, U, V, gap0, gdofs, -mu.sum() / area, e, E0,
                                 t_out, U_out, V_out, cu_out, s_out, E_out, stats)
            k += 1
            if blown:
                return k, step, min_gap, step
    return k, nsteps, min_gap, -1


def split(p: SparseProblem) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(m, hv, mv, cl): the lumped mass's diagonal, the dofs with mass, the massless ones
    and the contact dofs' positions among them. ValueError unless the mass is diagonal,
    the contact dofs are massless and some dof has mass."""
    M = sp.csr_matrix(p.M)
    m = np.asarray(M.diagonal(), float)
    if M.nnz != np.count_nonzero(m) or np.any(m < 0.0):
        raise ValueError("the semi-explicit scheme needs a diagonal (lumped) mass")
    hv, mv = np.flatnonzero(m > 0.0), np.flatnonzero(m == 0.0)
    cd = p.contact.selected_dofs("the semi-explicit scheme")
    pos = np.full(p.nfree, -1)
    pos[mv] = np.arange(mv.size)
    if hv.size == 0 or np.any(pos[cd] < 0):
        raise ValueError("the semi-explicit scheme needs massless contact dofs and dofs "
                         "with mass")
    return m, hv, mv, np.asarray(pos[cd], np.int64)


def body_limit(p: SparseProblem) -> float:
    """2 / omega_max of lumped central differences on the dofs with mass, the massless
    contact dofs held and the other massless dofs condensed (their rows solved): the
    largest eigenvalue of D^-1/2 S D^-1/2, S the Schur complement, D the lumped mass."""
    from scipy.sparse.linalg import LinearOperator, eigsh

    m, hv, mv, cl = split(p)
    free = np.ones(mv.size, bool)
    free[cl] = False
    iv = mv[free]
    K = sp.csr_matrix(p.K)
    s = 1.0 / np.sqrt(m[hv])
    Khh = sp.diags(s) @ sp.csr_matrix(K[hv][:, hv]) @ sp.diags(s)
    if iv.size:
        KIh = sp.csr_matrix(K[iv][:, hv]) @ sp.diags(s)
        fac = Factor.of(K[iv][:, iv])

        def op(x: np.ndarray) -> np.ndarray:
            x = np.ravel(x)
            return Khh @ x - KIh.T @ fac.solve(KIh @ x)
    else:
        def op(x: np.ndarray) -> np.ndarray:
            return Khh @ np.ravel(x)
    if hv.size <= 2:
        raise ValueError("the semi-explicit scheme needs more than two dofs with mass")
    lam = eigsh(LinearOperator((hv.size, hv.size), matvec=op, dtype=float), k=1, which="LA",
                tol=1e-10, return_eigenvectors=False,
                v0=np.random.default_rng(0).standard_normal(hv.size))  # the same each call
    return float(2.0 / np.sqrt(lam[0]))


class BodyStepper(Stepper):
    """`body_kernel` prepared: K_mm factored, the Delassus and response matrices, the
    massless dofs solved at t = 0 and the initial acceleration, once."""

    def __init__(self, p: SparseProblem, dt: float) -> None:
        self.problem, self.dt = p, float(dt)
        ld = getattr(p, "load", None)
        m, hv, mv, cl = split(p)
        K = sp.csr_matrix(p.K)
        fac = Factor.of(K[mv][:, mv])
        sel = sp.csc_matrix((np.ones(cl.size), (cl, np.arange(cl.size))),
                            shape=(mv.size, cl.size))
        Z = np.ascontiguousarray(fac.solve_many(sel))
        W = np.ascontiguousarray(0.5 * (Z[cl] + Z[cl].T))
        keep = np.ones(p.nfree)
        keep[mv] = 0.0
        Kmh = sp.csr_matrix(K[mv] @ sp.diags(keep))
        Kmh.eliminate_zeros()
        gap0 = np.asarray(p.contact.gap0, float)
        tol = 1e-13 * max(float(np.max(np.abs(p.U0))), float(np.max(np.abs(gap0), initial=0.0)),
                          1e-300)
        U = np.asarray(p.U0, float).copy()
        F0 = np.asarray(p.F, float) + (0.0 if ld is None else ld.at(0.0))  # the load at t = 0
        um = fac.solve(F0[mv] - Kmh @ U)  # the massless dofs at t = 0, exact contact
        gf = gap0 + um[cl]
        mu = np.zeros(cl.size)
        if np.any(gf < 0.0):
            lcp_solve(W, gf, mu, np.zeros(cl.size, np.bool_), tol)
            um += Z @ mu
        U[mv] = um
        A = np.zeros(p.nfree)
        A[hv] = (F0[hv] - K[hv] @ U) / m[hv]
        self.U0, self.A0, self.V0 = U, A, np.asarray(p.V0, float).copy()
        self.operators = (*csr_arrays(p.M), *csr_arrays(K), m, np.asarray(p.F, float), hv, mv,
                          cl, *csr_arrays(K[hv]), *csr_arrays(Kmh), fac.arrays, W, Z, gap0,
                          np.asarray(p.contact.weights, float),
                          *((None, np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros(0),
                             np.zeros((3, 0)), np.zeros(0, np.int64)) if ld is None else
                            (ld.density, *csr_arrays(ld.B), np.ascontiguousarray(ld.points, float),
                             np.asarray(ld.codes, np.int64))))
        self.tol = tol

    def run(self, nsteps: int, stride: int) -> Trajectory:
        p = self.problem
        out = SampleBuffers(p, nsteps, stride)  # sample 0: the given initial state
        stats = new_stats(0.0, out.size)
        k, done, min_gap, blow = body_kernel(
            *self.operators, self.U0.copy(), self.V0.copy(), self.A0.copy(), self.dt,
            int(nsteps), int(stride), float(p.energy_offset), *out.arrays(), stats, self.tol)
        return out.trajectory(k, done, min_gap, blow, self.dt, stats)


def prepare_body(p: SparseProblem, dt: float) -> BodyStepper:
    """The semi-explicit scheme on a body's problem (module docstring)."""
    return BodyStepper(p, dt)
