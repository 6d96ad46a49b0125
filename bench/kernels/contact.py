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
response Z = S^-1 G^T: all of it when it fits in `KEEP_Z_ENTRIES` values; else the
columns of the contact patch (`patch_rows`: the rows of smallest initial gap, as many as
a bound proportional to n and to the factor's size allows; `zcol` maps a row to its
column), so that a step whose pushing rows lie in the patch costs its one contact-free
solve plus Z's columns times mu (`push`); a step pushing outside the patch makes one more
solve with G^T mu. The columns come from the set-up's solves for W: keeping them costs
no solve. `contact_ops` builds it. Lazy operators (`contact_ops`' `first`, the implicit
Newmark step's) compute W's columns only for the rows near contact at set-up and the
others in the loop when a row is needed (`contact_lcp`): a candidate row that never
comes near the obstacle costs no solve (docs/sparse.md, "Lazy contact operators"). A
selection row keeps the exact arithmetic of the dof-by-dof kernels (its gap is gap0 +
X[dof], an active one is put on the obstacle exactly: `hold`); a general row's gap is its
CSR product.

A curved obstacle (`contact_bench.core.obstacle.Sphere`: gap_j = |x_j + U_j - c| - R,
nonlinear) keeps its tangent in the same `ContactOps` (`Curve`): `gaps(ct, X, out)`
writes the exact gaps of X and first re-linearises there (`relinearise`): row j of G
becomes the normal n_j = (x_j + X_j - c) / |...| on the point's d dofs, gap0 so that
gap0 + G X is the exact gap at X, and W and Z follow the normals without a solve,
W_ij = n_i^T B_ij n_j and Z_:j = Zd_:j n_j from B = S_d S^-1 S_d^T and Zd = S^-1 S_d^T,
computed once for the d dofs of every contact point (S_d their selection). A scheme calls
`gaps` on the step's contact-free prediction X_f before its contact solve, so the solve
(the LCP, the spring law, a velocity law on G V) sees the tangent at X_f
(docs/contact.md: the choice, its cost and its limits).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit
from numba.extending import overload

from contact_bench.core.numba_types import is_tuple_type
from contact_bench.core.obstacle import Sphere, point_u
from contact_bench.core.refcount import counted, uncounted, uncounted_inline
from contact_bench.core.timers import phase
from contact_bench.kernels.csr import CSR, INDEX, csr_arrays
from contact_bench.kernels.linalg import (
    MANY_BLOCK_COLUMNS,
    MANY_BLOCK_ENTRIES,
    Factor,
    lu,
    lu_solve_many,
)
from contact_bench.kernels.solvers import coulomb_solve, lcp_solve

#: largest n x n_c response matrix Z = S^-1 G^T kept whole (values); beyond, the patch's
KEEP_Z_ENTRIES = 10_000_000
#: the patch's response may hold this multiple of L's entries in values (at least
#: `KEEP_Z_ENTRIES`; 3 x L is 1.5 x SuperLU's L and U, whichever the loops keep): its
#: memory stays of the factor's order; docs/sparse.md, "One solve a step", says why
PATCH_SHARE = 3.0
#: no patch: the response is kept whole or not at all
NO_PATCH = np.zeros(0, np.int64)
#: W complete from the set-up (no column computed in the loop)
ALL_KNOWN = np.zeros(0, np.bool_)
#: the count of a lazy `ContactOps`' patch rows in use; unused (never written) otherwise
NO_COUNT = np.zeros(1, np.int64)
#: the steps whose closing the lazy operators' first columns cover (`near_rows`)
NEAR_STEPS = 10


class Curve(NamedTuple):
    """A curved obstacle's tangent, updated in place by `relinearise` (module
    docstring); a fixed G has `FLAT` instead."""

    ob: Sphere
    gpos: np.ndarray  # (n_c, d) int64: where normal component a of row j sits in G.data
    tpos: np.ndarray  # (n_c, d) int64: the same in G^T's data
    B: np.ndarray  # (n_c d, n_c d): S_d S^-1 S_d^T
    Zd: np.ndarray  # (n, n_c d): S^-1 S_d^T when Z is kept, else (1, 1)
    nrm: np.ndarray  # (n_c, d): the normals of the current tangent


class Flat(NamedTuple):
    """No curved obstacle: G fixed for the run (`FLAT`). A type of its own without arrays:
    numba counts references to every array of a typed tuple each time the tuple is passed
    or read, so a fixed G's `ContactOps` carries none of a tangent's arrays, and the
    tangent's update (`tangent_at`, dispatched on the type) compiles to nothing."""


#: no curved obstacle: G fixed for the run
FLAT = Flat()


class ContactOps(NamedTuple):
    """A gap operator with a factored S: G and G^T (CSR), gap0, `sel` (per row: the dof
    it selects, or -1 for a general row), W = G S^-1 G^T, Z = S^-1 G^T when `keep_z`,
    a curved obstacle's tangent data (`cv`, `FLAT` for a fixed G), and `zcol`: with a
    patch (not `keep_z`), per row where its column of S^-1 G^T is stored in Z (k x n:
    the patch's columns as rows), or -1 (`NO_PATCH`: no patch).

    Lazy operators (`contact_ops`' `first`): `known` (per row: W's column computed) and
    `nz` (Z's rows in use, of the patch's k); the other columns of W (and of Z while
    the patch has room) are computed in the loop when their row is needed
    (`contact_lcp`, `add_columns`). `ALL_KNOWN` (size 0): W complete."""

    G: CSR
    GT: CSR
    gap0: np.ndarray
    sel: np.ndarray
    W: np.ndarray
    Z: np.ndarray
    keep_z: bool
    cv: Curve | Flat = FLAT
    zcol: np.ndarray = NO_PATCH
    known: np.ndarray = ALL_KNOWN
    nz: np.ndarray = NO_COUNT


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


def gap_rows(G: sp.csr_matrix, sel: np.ndarray, X: np.ndarray) -> np.ndarray:
    """G X for a block X of n-vectors: X's rows `sel` where every row of G is a selection
    (`selection_rows`: the same numbers, no product), else the sparse product."""
    return X[sel] if np.all(sel >= 0) else G @ X


def is_selection(G: sp.csr_matrix) -> bool:
    """Whether every row of G selects one dof (a plane normal to an axis)."""
    return bool(np.all(selection_rows(G) >= 0))


def patch_rows(n: int, nc: int, l_entries: int) -> int:
    """How many columns of Z = S^-1 G^T the contact patch keeps when Z is not kept whole:
    n x k values within max(`KEEP_Z_ENTRIES`, `PATCH_SHARE` x L's entries), at most n_c."""
    budget = max(KEEP_Z_ENTRIES, int(PATCH_SHARE * l_entries))
    return int(min(nc, budget // max(n, 1)))


def near_rows(G: sp.spmatrix, gap0: np.ndarray, U: np.ndarray, V: np.ndarray,
              A: np.ndarray, dt: float, steps: int = NEAR_STEPS) -> np.ndarray:
    """The rows that can come into contact in the first `steps` steps of dt (a mask):
    those whose gap gap0 + G U is within the reach of the smallest, reach = h max |G V|
    + h^2 / 2 max |G A| with h = steps dt (the state U, V, A at t = 0): what the body
    closes in that time at its initial velocity and acceleration. The first columns of
    lazy contact operators (`contact_ops`' `first`)."""
    G = sp.csr_matrix(G)
    g = np.asarray(gap0, float) + G @ U
    if g.size == 0:
        return np.zeros(0, np.bool_)
    h = steps * dt
    reach = h * float(np.max(np.abs(G @ V))) + 0.5 * h * h * float(np.max(np.abs(G @ A)))
    return g <= g.min() + reach


@phase("contact")
def contact_ops(fac: Factor, G: sp.spmatrix, gap0: np.ndarray,
                keep: bool | None = None, obstacle: Sphere | None = None,
                rank: np.ndarray | None = None, first: np.ndarray | None = None
                ) -> ContactOps:
    """`ContactOps` of the gap operator G (n_c x n) with S's factor `fac`: W = G S^-1 G^T
    (symmetrised) from n_c solves in blocks, Z kept whole when `keep` (default: when n
    n_c <= `KEEP_Z_ENTRIES`), else the patch's columns (`patch_rows` of them; the rows
    first in `rank`, default gap0: the smallest initial gaps; `keep` False: no patch). A
    selection G is solved with unit right-hand sides and W read off Z's rows (the numbers
    of the dof-by-dof kernels). With a curved `obstacle` (its dofs numbered as S's), G
    and gap0 are its tangent at X = 0 (`curved_ops`).

    `first` (a mask of rows, e.g. `near_rows`) makes the operators lazy where Z is not
    kept whole (by default): W's columns of those rows only, and Z's (the patch, as
    many as `patch_rows` allows, in the order the rows come); every other column is
    computed in the loop when its row is needed (`contact_lcp`). W's entries are those
    of the complete W (symmetrised pairwise as they become known)."""
    if obstacle is not None:
        return curved_ops(fac, obstacle, keep)
    G = sp.csr_matrix(G, dtype=float)
    n, nc = fac.n, G.shape[0]
    auto = keep is None
    keep = n * nc <= KEEP_Z_ENTRIES if auto else bool(keep)
    sel = selection_rows(G)
    GT = sp.csc_matrix(G.T)
    k = patch_rows(n, nc, fac.l_entries) if auto and not keep else 0
    if first is not None and auto and not keep:
        # np.zeros: pages untouched until a column is stored there (memory as used)
        ct = ContactOps(csr_arrays(G), csr_arrays(G.T), np.asarray(gap0, float), sel,
                        np.zeros((nc, nc)), np.zeros((k, n)) if k else np.zeros((1, 1)),
                        False, FLAT, np.full(nc, -1, np.int64) if k else NO_PATCH,
                        np.zeros(nc, np.bool_), np.zeros(1, np.int64))
        add_columns(ct, fac.arrays, np.asarray(first, np.bool_))
        return ct
    zcol = NO_PATCH
    if k:
        order = np.argsort(np.asarray(gap0 if rank is None else rank, float), kind="stable")
        zcol = np.full(nc, -1, np.int64)
        zcol[order[:k]] = np.arange(k)
    # the patch's columns stored as rows (k x n): a step reads only the pushing ones
    Z = np.empty((n, nc)) if keep else np.zeros((k, n)) if k else np.zeros((1, 1))
    W = np.empty((nc, nc))
    for j0, j1, X in fac.solve_blocks(GT):
        if keep:
            Z[:, j0:j1] = X
        elif k:
            cols = zcol[j0:j1]
            mine = cols >= 0
            Z[cols[mine], :] = X[:, mine].T
        W[:, j0:j1] = gap_rows(G, sel, X)
    return ContactOps(csr_arrays(G), csr_arrays(G.T), np.asarray(gap0, float), sel,
                      np.ascontiguousarray(0.5 * (W + W.T)), np.ascontiguousarray(Z), keep,
                      FLAT, zcol)


@njit(cache=True)
def add_columns(ct, fac, need):  # pragma: no cover - compiled
    """Lazy operators (`ContactOps`): W's columns of the rows `need` marks that are not
    known yet, from solves with G_j^T in blocks of `MANY_BLOCK_COLUMNS` (`lu_solve_many`,
    one solve counted per column in `fac.solves`); each stored as a row of Z while the
    patch has room. W_ij for a known row i is the symmetrised (W_ij + W_ji) / 2, the
    complete W's value; for the other rows the column's own value. Returns the columns
    added."""
    known, W = ct.known, ct.W
    Gp, Gi, Gx = ct.G
    nc = known.size
    n = ct.GT[0].size - 1
    rows = np.flatnonzero(need & ~known)
    width = max(1, min(MANY_BLOCK_COLUMNS, MANY_BLOCK_ENTRIES // max(n, 1)))
    for a0 in range(0, rows.size, width):
        blk = rows[a0:a0 + width]
        k = blk.size
        B = np.zeros((n, k))
        for a in range(k):
            for kk in range(Gp[blk[a]], Gp[blk[a] + 1]):
                B[Gi[kk], a] = Gx[kk]
        X = np.empty((n, k))
        lu_solve_many(fac, B, X, np.empty((n, k)))
        fac.solves[0] += k
        col = np.empty(n)
        for a in range(k):
            j = blk[a]
            for i in range(n):
                col[i] = X[i, a]
            for i in range(nc):
                d = ct.sel[i]
                wij = col[d] if d >= 0 else row_dot(ct.G, i, col)
                if known[i]:  # W_ji holds column i's value
                    v = 0.5 * (wij + W[j, i])
                    W[i, j] = v
                    W[j, i] = v
                else:
                    W[i, j] = wij
            if ct.zcol.size and ct.nz[0] < ct.Z.shape[0]:
                ct.Z[ct.nz[0], :] = col
                ct.zcol[j] = ct.nz[0]
                ct.nz[0] += 1
            known[j] = True
    return rows.size


@njit(cache=True)
def contact_lcp(ct, fac, q, mu, active, tol, warm):  # pragma: no cover - compiled
    """`lcp_solve` on W with the gaps q (mu, active in and out as there), for lazy
    operators on the known rows: the rows with q < 0 get their columns first
    (`add_columns`), the LCP is solved on the known rows, and a row outside them that the
    solution pushes below -tol gets its column and the LCP runs again, warm, until none
    does. W positive definite: the solution is the complete W's. Returns the pivots."""
    if ct.known.size == 0:
        return lcp_solve(ct.W, q, mu, active, tol, warm)
    known, W = ct.known, ct.W
    nc = q.size
    need = np.zeros(nc, np.bool_)
    for j in range(nc):
        need[j] = q[j] < 0.0 or (warm and active[j])
    add_columns(ct, fac, need)
    total = 0
    while True:
        idx = np.flatnonzero(known)
        m = idx.size
        Wk = np.empty((m, m))
        qk = np.empty(m)
        mk = np.zeros(m)
        ak = np.empty(m, np.bool_)
        for a in range(m):
            qk[a] = q[idx[a]]
            ak[a] = active[idx[a]]
            for b in range(m):
                Wk[a, b] = W[idx[a], idx[b]]
        it = lcp_solve(Wk, qk, mk, ak, tol, warm)
        if it < 0:
            return it
        total += it
        mu[:] = 0.0
        active[:] = False
        for a in range(m):
            mu[idx[a]] = mk[a]
            active[idx[a]] = ak[a]
        on = np.flatnonzero(mu)
        more = False
        for i in range(nc):
            need[i] = False
            if not known[i]:
                g = q[i]
                for j in on:
                    g += W[i, j] * mu[j]
                if g < -tol:
                    need[i] = True
                    more = True
        if not more:
            return total
        add_columns(ct, fac, need)
        warm = True


def restrict(ob: Sphere | None, cols: np.ndarray, n: int) -> Sphere | None:
    """A curved obstacle with its dofs renumbered among `cols` (the unknowns of a
    reduced system, e.g. the massless dofs); None stays None. ValueError when a contact
    point's dof is not among them."""
    if ob is None:
        return None
    pos = np.full(n, -1, np.int64)
    pos[np.asarray(cols, np.int64)] = np.arange(len(cols))
    dofs = np.where(ob.dofs >= 0, pos[np.maximum(ob.dofs, 0)], -1)
    lost = (ob.dofs >= 0) & (dofs < 0)
    if lost.any():
        raise ValueError(f"dof {int(ob.dofs[lost][0])} of the curved obstacle's contact "
                         "points is not among the reduced system's unknowns")
    return ob._replace(dofs=np.ascontiguousarray(dofs))


def curved_ops(fac: Factor, ob: Sphere, keep: bool | None = None) -> ContactOps:
    """`ContactOps` of a curved obstacle (module docstring): B = S_d S^-1 S_d^T and, when
    `keep` (default: when n n_c d <= `KEEP_Z_ENTRIES`), Zd = S^-1 S_d^T from n_c d solves
    in blocks; G (a row of the free components per contact point), G^T, gap0, W and Z
    then set to the tangent at X = 0. A component whose dof is -1 is held at zero (a
    point on a symmetry axis): no entry, zero rows in B and Zd. A ValueError names a dof
    that two contact points share."""
    nc, dim = ob.dofs.shape
    n = fac.n
    flat = ob.dofs.ravel()
    free = flat >= 0
    used = flat[free]
    if np.unique(used).size != used.size or (used.size and used.max() >= n):
        raise ValueError(f"the curved obstacle's dofs {used.tolist()[:8]}...: each contact "
                         "point needs its own free dofs")
    keep = n * nc * dim <= KEEP_Z_ENTRIES if keep is None else bool(keep)
    cols = np.flatnonzero(free)
    Sd = sp.csc_matrix((np.ones(used.size), (used, cols)), shape=(n, flat.size))
    Zd = np.zeros((n, flat.size)) if keep else np.zeros((1, 1))
    B = np.zeros((flat.size, flat.size))
    for j0, j1, X in fac.solve_blocks(Sd):
        if keep:
            Zd[:, j0:j1] = X
        B[cols, j0:j1] = X[used]
    gpos = np.full(flat.size, -1, np.int64)
    gpos[free] = np.arange(used.size)
    ix = INDEX
    G = CSR(np.concatenate([[0], np.cumsum(free.reshape(nc, dim).sum(axis=1))]).astype(ix),
            used.astype(ix), np.zeros(used.size))
    order = np.argsort(used, kind="stable")  # G^T: one entry in each contact dof's row
    counts = np.zeros(n + 1, ix)
    counts[used + 1] = 1
    GT = CSR(np.cumsum(counts).astype(ix), (cols[order] // dim).astype(ix),
             np.zeros(used.size))
    tpos = np.full(flat.size, -1, np.int64)
    tpos[cols[order]] = np.arange(used.size)
    cv = Curve(ob, gpos.reshape(nc, dim), tpos.reshape(nc, dim),
               np.ascontiguousarray(0.5 * (B + B.T)), np.ascontiguousarray(Zd),
               np.zeros((nc, dim)))
    ct = ContactOps(G, GT, np.zeros(nc), np.full(nc, -1, np.int64), np.zeros((nc, nc)),
                    np.zeros((n, nc)) if keep else np.zeros((1, 1)), keep, cv)
    relinearise(ct, np.zeros(n), np.zeros(nc))
    return ct


@uncounted
def relinearise(ct, X, out):  # pragma: no cover - compiled
    """The curved obstacle's tangent at X (module docstring): G's and G^T's normals,
    gap0, W and (kept) Z updated in place; out = the exact gaps of X."""
    cv = ct.cv
    ob, nrm = cv.ob, cv.nrm
    nc, dim = nrm.shape
    for j in range(nc):
        l2 = 0.0
        for a in range(dim):
            d = ob.points[j, a] + point_u(ob, j, a, X) - ob.centre[a]
            nrm[j, a] = d
            l2 += d * d
        ln = np.sqrt(l2)
        gx = 0.0
        for a in range(dim):
            nrm[j, a] /= ln
            if cv.gpos[j, a] >= 0:
                ct.G.data[cv.gpos[j, a]] = nrm[j, a]
                ct.GT.data[cv.tpos[j, a]] = nrm[j, a]
                gx += nrm[j, a] * X[ob.dofs[j, a]]
        out[j] = ln - ob.radius
        ct.gap0[j] = out[j] - gx
    for i in range(nc):
        for j in range(i, nc):
            acc = 0.0
            for a in range(dim):
                for b in range(dim):
                    acc += nrm[i, a] * cv.B[i * dim + a, j * dim + b] * nrm[j, b]
            ct.W[i, j] = acc
            ct.W[j, i] = acc
    if ct.keep_z:
        Z, Zd = ct.Z, cv.Zd
        for r in range(Z.shape[0]):
            for j in range(nc):
                acc = 0.0
                for a in range(dim):
                    acc += Zd[r, j * dim + a] * nrm[j, a]
                Z[r, j] = acc


def _is_flat(ct) -> bool:
    """Whether `ct`, the numba type of a `ContactOps`, has a fixed G (its `cv` `Flat`)."""
    return is_tuple_type(ct.types[ct.fields.index("cv")], Flat)


def is_curved(ct):  # pragma: no cover - compiled through its overload
    """Whether `ct` (a `ContactOps`) follows a curved obstacle (its `cv` a `Curve`, not
    `FLAT`): a constant of its type in compiled code."""
    return isinstance(ct.cv, Curve)


@overload(is_curved)
def _is_curved_compiled(ct):  # pragma: no cover - compiled
    if _is_flat(ct):
        return lambda ct: False
    return lambda ct: True


def tangent_at(ct, X, out):  # pragma: no cover - compiled through its overload
    """`relinearise` for a curved obstacle; nothing for a fixed G (`Flat`)."""


@overload(tangent_at)
def _tangent_at_compiled(ct, X, out):  # pragma: no cover - compiled
    if _is_flat(ct):
        return lambda ct, X, out: None
    return lambda ct, X, out: relinearise(ct, X, out)


@njit(cache=True)
def follow(ct, X, out):  # pragma: no cover - compiled
    """A curved obstacle's tangent moved to X (out: its exact gaps there), for a step
    whose contact law reads G without the gaps of a prediction (a velocity law); nothing
    for a fixed G."""
    tangent_at(ct, X, out)


@uncounted
def row_dot(G, j, X):  # pragma: no cover - compiled
    """G_j X for row j of G (CSR arrays)."""
    Gp, Gi, Gx = G
    acc = 0.0
    for kk in range(Gp[j], Gp[j + 1]):
        acc += Gx[kk] * X[Gi[kk]]
    return acc


@uncounted_inline
def gaps(ct, X, out):  # pragma: no cover - compiled
    """out = gap0 + G X; True if a gap is negative. A curved obstacle's: its exact gaps
    at X, its tangent moved to X first (`relinearise`)."""
    pen = False
    if is_curved(ct):
        tangent_at(ct, X, out)
        for j in range(out.size):
            pen = pen or out[j] < 0.0
        return pen
    for j in range(ct.gap0.size):
        d = ct.sel[j]
        if d >= 0:
            out[j] = ct.gap0[j] + X[d]
        else:
            out[j] = ct.gap0[j] + row_dot(ct.G, j, X)
        pen = pen or out[j] < 0.0
    return pen


@uncounted
def apply_gt(ct, mu, out):  # pragma: no cover - compiled
    """out = G^T mu (n values)."""
    Tp, Ti, Tx = ct.GT
    for i in range(out.size):
        acc = 0.0
        for kk in range(Tp[i], Tp[i + 1]):
            acc += Tx[kk] * mu[Ti[kk]]
        out[i] = acc


@uncounted
def spread(ct, mu, out):  # pragma: no cover - compiled
    """out = G^T mu (n values): mu scattered onto the selected dofs where every row is a
    selection, else `apply_gt`."""
    for j in range(ct.sel.size):
        if ct.sel[j] < 0:
            apply_gt(ct, mu, out)
            return
    out[:] = 0.0
    for j in range(ct.sel.size):
        out[ct.sel[j]] = mu[j]


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
def in_patch(zcol, mu):  # pragma: no cover - compiled
    """Whether every row that pushes (mu != 0) has its column in the patch (`zcol`)."""
    if zcol.size == 0:
        return False
    for j in range(mu.size):
        if mu[j] != 0.0 and zcol[j] < 0:
            return False
    return True


@njit(cache=True)
def add_patch(Zt, zcol, mu, X, acc):  # pragma: no cover - compiled
    """X += S^-1 G^T mu over the rows that push, row j's column of S^-1 G^T stored as
    Zt[zcol[j]] (contiguous: only the pushing ones are read); acc: scratch of X's size.
    Each X[i] gets `add_response`'s sum, in its order."""
    on = np.flatnonzero(mu)
    acc[:] = 0.0
    for a in range(on.size):
        z, m = Zt[zcol[on[a]]], mu[on[a]]
        for i in range(X.size):
            acc[i] += z[i] * m
    for i in range(X.size):
        X[i] += acc[i]


@counted
def push(ct, fac, mu, X, scr):  # pragma: no cover - compiled
    """X += S^-1 G^T mu: Z mu if Z is kept or the pushing rows lie in the patch, else one
    solve with S's factor `fac` (scr: (rhs, w, work), scratch of X's size)."""
    if ct.keep_z:
        add_response(ct.Z, mu, X)
        return
    rhs, w, work = scr
    if in_patch(ct.zcol, mu):
        add_patch(ct.Z, ct.zcol, mu, X, w)
        return
    spread(ct, mu, rhs)
    lu(fac, rhs, w, work)
    for i in range(X.size):
        X[i] += w[i]


@uncounted
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
        contact_lcp(ct, fac, gf, mu, active, tol, warm)
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
    nt = T.shape[0] // nc
    g0 = np.asarray(contact.gap0, float)  # a point's tangent rows ranked with its normal
    rank = np.concatenate([g0, np.repeat(g0, nt)])
    return Friction(contact_ops(fac, H, gap0, keep, rank=rank), mu.copy(), thr.copy(), nt)


def law_ops(fac: Factor, P: sp.spmatrix, Q: sp.spmatrix, y0: np.ndarray,
            keep: bool | None = None) -> ContactOps:
    """`ContactOps` of a contact law on y = P X + y0 whose force on the dofs is Q^T r
    (Nitsche's rows: P != Q unless theta = 1) with S's factor `fac`: W = P S^-1 Q^T (not
    symmetrised) from solves in blocks, Z = S^-1 Q^T kept under `contact_ops`' rule
    (else the correction is one more solve with Q^T r); every row general (G = P, G^T =
    Q^T)."""
    P, Q = sp.csr_matrix(P, dtype=float), sp.csr_matrix(Q, dtype=float)
    n, k = fac.n, P.shape[0]
    keep = n * k <= KEEP_Z_ENTRIES if keep is None else bool(keep)
    Z = np.empty((n, k)) if keep else np.zeros((1, 1))
    W = np.empty((k, k))
    for j0, j1, X in fac.solve_blocks(sp.csc_matrix(Q.T)):
        if keep:
            Z[:, j0:j1] = X
        W[:, j0:j1] = P @ X
    return ContactOps(csr_arrays(P), csr_arrays(sp.csr_matrix(Q.T)), np.asarray(y0, float),
                      np.full(k, -1, np.int64), np.ascontiguousarray(W),
                      np.ascontiguousarray(Z), keep)


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
    return coulomb_bound(fr, pts, q, r, fr.thr, tol)


@njit(cache=True)
def coulomb_bound(fr, pts, q, r, thr, tol):  # pragma: no cover - compiled
    """`coulomb` with the step's threshold `thr` (one value per contact point) in place
    of Tresca's `fr.thr`: |r_t| <= thr + mu r_n (a scheme whose step applies a normal
    impulse outside r_n adds its friction bound there: `contact_bench.kernels.kane`)."""
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
    sweeps = coulomb_solve(Ws, qs, fr.mu[pts], thr[pts], rs, status, tol)
    r[:] = 0.0
    for a in range(k):
        r[rows[a]] = rs[a]
    return sweeps
