"""The contact solve of the compiled schemes, for any gap operator G.

The contact points' gaps are g = gap0 + G U (G n_c x n sparse: one row per contact
point, the obstacle's normal on that point's dofs; a plane normal to an axis makes each
row the selection of one dof, a slanted plane or a curved obstacle a general row, two
bodies a row with -n on one body's node and +n on the other's). A step's contact
subproblem, with X_f the step's contact-free solution of S X = b (S factored once), is

    X = X_f + S^-1 G^T mu,   g = (gap0 + G X_f) + W mu,   W = G S^-1 G^T (n_c x n_c),

with a law per contact point: exact Signorini (g >= 0, mu >= 0, g . mu = 0: an LCP on W,
`lcp_solve`), a spring (mu = c max(0, -g): `penalty_solve`), or the same LCP on
velocities with restitution (the impact schemes build their q). `lcp_solve` is
principal pivoting: block pivots (every violator changes side) while they reduce the
number of violators, then Murty's least-index rule, which terminates for a P-matrix
(W is symmetric positive definite for a factored SPD S and G of full row rank); started
from the previous step's active set it usually needs no pivot, and each active set's
system is solved exactly, so the gaps of the active points are zero to round-off, not
to an iteration tolerance (projected Gauss-Seidel would leave them at its tolerance).
`penalty_solve` is the same active-set iteration on the piecewise-linear spring law.

`ContactOps` holds G (and G^T) as CSR, the gaps' origin, the Delassus matrix and the
response Z = S^-1 G^T (kept when it fits in `KEEP_Z_ENTRIES` values; else the correction
is one more solve with G^T mu); `contact_ops` builds it. A selection row keeps the exact
arithmetic of the dof-by-dof kernels (its gap is gap0 + X[dof], an active one is put on
the obstacle exactly: `hold`); a general row's gap is its CSR product.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit

from contact_bench.kernels.csr import CSR, csr_arrays
from contact_bench.kernels.linalg import Factor, lu
from contact_bench.kernels.solvers import coulomb_solve, lcp_solve

#: largest n x n_c response matrix Z = S^-1 G^T kept (values); beyond, a second solve
KEEP_Z_ENTRIES = 10_000_000


class ContactOps(NamedTuple):
    """A gap operator with a factored S: G and G^T (CSR), gap0, `sel` (per row: the dof
    it selects, or -1 for a general row), W = G S^-1 G^T, Z = S^-1 G^T when `keep_z`."""

    G: CSR
    GT: CSR
    gap0: np.ndarray
    sel: np.ndarray
    W: np.ndarray
    Z: np.ndarray
    keep_z: bool


def selection_rows(G: sp.csr_matrix) -> np.ndarray:
    """Per row of G: the dof it selects (one entry, equal to 1), else -1."""
    G = sp.csr_matrix(G)
    one = np.diff(G.indptr) == 1
    out = np.full(G.shape[0], -1, np.int64)
    rows = np.flatnonzero(one)
    first = G.indptr[rows]
    unit = G.data[first] == 1.0
    out[rows[unit]] = G.indices[first[unit]]
    return out


def is_selection(G: sp.csr_matrix) -> bool:
    """Whether every row of G selects one dof (a plane normal to an axis)."""
    return bool(np.all(selection_rows(G) >= 0))


def contact_ops(fac: Factor, G: sp.spmatrix, gap0: np.ndarray,
                keep: bool | None = None) -> ContactOps:
    """`ContactOps` of the gap operator G (n_c x n) with S's factor `fac`: W = G S^-1 G^T
    (symmetrised) from n_c solves in blocks, Z kept when `keep` (default: when n n_c <=
    `KEEP_Z_ENTRIES`). A selection G is solved with unit right-hand sides and W read off
    Z's rows (the numbers of the dof-by-dof kernels)."""
    G = sp.csr_matrix(G, dtype=float)
    n, nc = fac.n, G.shape[0]
    keep = n * nc <= KEEP_Z_ENTRIES if keep is None else bool(keep)
    sel = selection_rows(G)
    GT = sp.csc_matrix(G.T)
    Z = np.empty((n, nc)) if keep else np.zeros((1, 1))
    W = np.empty((nc, nc))
    for j0, j1, X in fac.solve_blocks(GT):
        if keep:
            Z[:, j0:j1] = X
        W[:, j0:j1] = X[sel] if np.all(sel >= 0) else G @ X
    return ContactOps(csr_arrays(G), csr_arrays(G.T), np.asarray(gap0, float), sel,
                      np.ascontiguousarray(0.5 * (W + W.T)), np.ascontiguousarray(Z), keep)


@njit(cache=True)
def row_dot(G, j, X):  # pragma: no cover - compiled
    """G_j X for row j of G (CSR arrays)."""
    Gp, Gi, Gx = G
    acc = 0.0
    for kk in range(Gp[j], Gp[j + 1]):
        acc += Gx[kk] * X[Gi[kk]]
    return acc


@njit(cache=True)
def gaps(ct, X, out):  # pragma: no cover - compiled
    """out = gap0 + G X; True if a gap is negative."""
    pen = False
    for j in range(ct.gap0.size):
        d = ct.sel[j]
        if d >= 0:
            out[j] = ct.gap0[j] + X[d]
        else:
            out[j] = ct.gap0[j] + row_dot(ct.G, j, X)
        pen = pen or out[j] < 0.0
    return pen


@njit(cache=True)
def apply_gt(ct, mu, out):  # pragma: no cover - compiled
    """out = G^T mu (n values)."""
    Tp, Ti, Tx = ct.GT
    for i in range(out.size):
        acc = 0.0
        for kk in range(Tp[i], Tp[i + 1]):
            acc += Tx[kk] * mu[Ti[kk]]
        out[i] = acc


@njit(cache=True)
def add_response(Z, mu, X):  # pragma: no cover - compiled
    """X += Z mu over the nonzero entries of mu (the contact points that push; Z's rows
    contiguous)."""
    on = np.flatnonzero(mu)
    for i in range(X.size):
        acc = 0.0
        for j in on:
            acc += Z[i, j] * mu[j]
        X[i] += acc


@njit(cache=True)
def push(ct, fac, mu, X, scr):  # pragma: no cover - compiled
    """X += S^-1 G^T mu: Z mu if Z is kept, else one solve with S's factor `fac` (scr:
    (rhs, w, work), scratch of X's size)."""
    if ct.keep_z:
        add_response(ct.Z, mu, X)
        return
    rhs, w, work = scr
    if np.all(ct.sel >= 0):
        rhs[:] = 0.0
        for j in range(ct.sel.size):
            rhs[ct.sel[j]] = mu[j]
    else:
        apply_gt(ct, mu, rhs)
    lu(fac, rhs, w, work)
    for i in range(X.size):
        X[i] += w[i]


@njit(cache=True)
def hold(ct, active, X, target):  # pragma: no cover - compiled
    """Put each active selection row's dof exactly on `target` (its gap's value there:
    -gap0 for a gap of zero); a general row's gap is the LCP's, zero to round-off."""
    for j in range(ct.sel.size):
        if active[j] and ct.sel[j] >= 0:
            X[ct.sel[j]] = target[j]


@njit(cache=True)
def signorini(ct, fac, X, mu, active, warm, tol, scr):  # pragma: no cover - compiled
    """Exact Signorini at the step's end: X (the contact-free solution in, the step's
    out) corrected by S^-1 G^T mu with the LCP on W; mu, active (in: the previous
    step's, a warm start when `warm`) out. scr: (gf, rhs, w, work). True when some gap
    of X_f was negative (the LCP ran); else mu = 0."""
    gf = scr[0]
    pen = gaps(ct, X, gf)
    if pen:
        lcp_solve(ct.W, gf, mu, active, tol, warm)
        push(ct, fac, mu, X, (scr[1], scr[2], scr[3]))
        hold(ct, active, X, -ct.gap0)
    else:
        mu[:] = 0.0
    return pen


# ------------------------------------------------------------------ friction
# (separate from the frictionless path above: mu = 0 never reaches it)


class Friction(NamedTuple):
    """Frictional contact with a factored S: `ContactOps` of the stacked rows H = [G; T]
    (the n_c normal rows, then the n_t tangent rows of each point, point by point; their
    W = H S^-1 H^T, gap0 zero on the tangents), Coulomb's mu and Tresca's threshold per
    point, n_t."""

    ct: ContactOps
    mu: np.ndarray
    thr: np.ndarray
    nt: int


def friction_ops(fac: Factor, contact, n: int, keep: bool | None = None) -> Friction:
    """`Friction` of a `ContactSet` with tangents (`ContactSet.frictional`), S's factor
    `fac`: the stacked operator's W and Z as `contact_ops` builds them (Z kept under the
    same `KEEP_Z_ENTRIES` rule)."""
    nc = contact.size
    T = sp.csr_matrix(contact.tangents, dtype=float)
    H = sp.vstack([sp.csr_matrix(contact.gap_operator(n), dtype=float), T], format="csr")
    gap0 = np.concatenate([np.asarray(contact.gap0, float), np.zeros(T.shape[0])])
    mu = np.zeros(nc) if contact.friction is None else np.asarray(contact.friction, float)
    thr = np.zeros(nc) if contact.tresca is None else np.asarray(contact.tresca, float)
    return Friction(contact_ops(fac, H, gap0, keep), mu.copy(), thr.copy(), T.shape[0] // nc)


@njit(cache=True)
def row_value(ct, i, X):  # pragma: no cover - compiled
    """H_i X for row i of a `ContactOps` (a selection row: X at its dof)."""
    d = ct.sel[i]
    return X[d] if d >= 0 else row_dot(ct.G, i, X)


@njit(cache=True)
def coulomb(fr, pts, q, r, tol):  # pragma: no cover - compiled
    """The frictional subproblem of the contact points `pts` (the others carry no
    reaction): r (all rows of H: in, the previous step's, a warm start; out) with
    u = q + W r obeying Signorini and Coulomb / Tresca on those points
    (`coulomb_solve`); q: all rows of H (normals: gaps or velocities; tangents: slips
    in the normals' units). Returns `coulomb_solve`'s sweeps."""
    nc = fr.mu.size
    nt = fr.nt
    m = pts.size
    k = m * (1 + nt)
    rows = np.empty(k, np.int64)
    for a in range(m):
        rows[a] = pts[a]
        for b in range(nt):
            rows[m + a * nt + b] = nc + pts[a] * nt + b
    Ws = np.empty((k, k))
    qs = np.empty(k)
    rs = np.empty(k)
    for a in range(k):
        qs[a] = q[rows[a]]
        rs[a] = r[rows[a]]
        for b in range(k):
            Ws[a, b] = fr.ct.W[rows[a], rows[b]]
    status = np.empty(m, np.int64)
    sweeps = coulomb_solve(Ws, qs, fr.mu[pts], fr.thr[pts], rs, status, tol)
    r[:] = 0.0
    for a in range(k):
        r[rows[a]] = rs[a]
    return sweeps
