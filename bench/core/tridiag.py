"""Symmetric tridiagonal machinery in numba: products, quadratic forms, LDL^T solves.

Tridiagonal symmetric matrices travel as (diag, off). Factorisations are done by LAPACK
through scipy (`dpttrf`: A = L D L^T) outside the hot loop; compiled loops only apply
them. The bottom layer: it imports nothing of the project but its error type.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit
from scipy.linalg import lapack

from contact_bench.core.errors import BenchError


class Bar(NamedTuple):
    """The bar's operators as the compiled kernels take them: the symmetric tridiagonal
    mass M = (Md, Me) and stiffness K = (Kd, Ke) (diagonal, off-diagonal), the load F."""

    Md: np.ndarray
    Me: np.ndarray
    Kd: np.ndarray
    Ke: np.ndarray
    F: np.ndarray


class Implicit(NamedTuple):
    """An implicit step's system S: its L D L^T factors (Sd, Se: `factor_pt`) and w the
    response S^-1 q to the contact's unit force (q = e0 for the contact node)."""

    Sd: np.ndarray
    Se: np.ndarray
    w: np.ndarray


class BarState(NamedTuple):
    """The bar's state that a second-order kernel advances in place: U, V, A."""

    U: np.ndarray
    V: np.ndarray
    A: np.ndarray


class NewmarkCoef(NamedTuple):
    """Newmark's weights beta, gamma, and whether the contact node is massless (its
    velocity the backward difference, its acceleration 0)."""

    beta: float
    gamma: float
    massless: bool


@njit(cache=True)
def tri_matvec(d, e, x, out):
    """out = A x for the symmetric tridiagonal A = (d, e) (out must not be x).

    Row i is (d[i] x[i] + e[i-1] x[i-1]) + e[i] x[i+1], in that order: the sums of the
    former loop `out[i] += e[i] x[i+1]; out[i + 1] += e[i] x[i]` over out = d x, bit
    for bit, written as a stencil (each row once: no store-to-load chain through out,
    and the loop vectorises)."""
    n = d.size
    if n <= 1:  # 0 rows: nothing, as the loops wrote nothing
        if n == 1:
            out[0] = d[0] * x[0]
        return
    out[0] = d[0] * x[0] + e[0] * x[1]
    for i in range(1, n - 1):
        out[i] = (d[i] * x[i] + e[i - 1] * x[i - 1]) + e[i] * x[i + 1]
    out[n - 1] = d[n - 1] * x[n - 1] + e[n - 2] * x[n - 2]


@njit(cache=True, inline="always")
def tri_row(d, e, x, i, n):  # pragma: no cover - compiled
    """Row i of A x for the symmetric tridiagonal A = (d, e) of size n, summed as
    `tri_matvec` sums it (the same bits): for kernels that fuse it into a sweep."""
    if i == 0:
        return d[0] * x[0] + e[0] * x[1] if n > 1 else d[0] * x[0]
    if i == n - 1:
        return d[i] * x[i] + e[i - 1] * x[i - 1]
    return (d[i] * x[i] + e[i - 1] * x[i - 1]) + e[i] * x[i + 1]


@njit(cache=True)
def newmark_update(rhs, mu, w, pin0, Ut, state, dt, coef):  # pragma: no cover - compiled
    """The end of an implicit Newmark-family step in one pass over the nodes: U1 = rhs +
    mu w (node 0 set to 0 if pin0: an active exact contact), A1 = (U1 - U~) / (beta
    dt^2), V += dt ((1 - gamma) A + gamma A1), a massless node 0's velocity the backward
    difference and its acceleration 0; the `BarState` (U, V, A) overwritten, `coef` the
    `NewmarkCoef`."""
    U, V, A = state
    beta, gamma, massless = coef
    bdt2 = beta * dt * dt
    for i in range(U.size):
        u1 = rhs[i] + mu * w[i]
        if i == 0 and pin0:
            u1 = 0.0
        a1 = (u1 - Ut[i]) / bdt2
        v = V[i] + dt * ((1.0 - gamma) * A[i] + gamma * a1)
        if i == 0 and massless:
            v = (u1 - U[0]) / dt
            a1 = 0.0
        V[i] = v
        U[i] = u1
        A[i] = a1


#: a row sum of a symmetric tridiagonal below this fraction of the row's absolute sum
#: (|d_i| + |e_{i-1}| + |e_i|) is the rounding of an exact zero (`tri_quad`)
ROWSUM_RTOL = 16 * 2.0**-52
#: terms per partial sum in `tri_quad`: the error of a sum of n terms grows like
#: (QUAD_BLOCK + n / QUAD_BLOCK) eps instead of n eps
QUAD_BLOCK = 256


@njit(cache=True, inline="always")
def snap_row_sum(r, a):  # pragma: no cover - compiled
    """A row sum r, or 0 when it is at the rounding level of the row (|r| <= ROWSUM_RTOL a,
    a = the row's absolute sum)."""
    return r if abs(r) > ROWSUM_RTOL * a else 0.0


@njit(cache=True, inline="always")
def _inner_term(d, e, x, i):  # pragma: no cover - compiled
    """Row i's term r_i x_i^2 - e_i (x_{i+1} - x_i)^2 for 0 < i < n - 1, branch-free."""
    r = snap_row_sum((d[i] + e[i - 1]) + e[i], (abs(d[i]) + abs(e[i - 1])) + abs(e[i]))
    xi = x[i]
    dx = x[i + 1] - xi
    return r * xi * xi - e[i] * dx * dx


@njit(cache=True)
def tri_quad(d, e, x):
    """x^T A x for the symmetric tridiagonal A = (d, e), without cancellation.

    Summed as sum_i r_i x_i^2 - sum_i e_i (x_{i+1} - x_i)^2, r_i = d_i + e_{i-1} + e_i
    the row sums (an identity for every symmetric tridiagonal). For a stiffness, -e_i
    is the element stiffness and r_i vanishes inside the bar (a rigid translation
    strains nothing), so every term is >= 0 and the strain energy of a smooth U comes
    from differences, not from d_i u_i^2 terms that cancel to O(n^2 eps). The
    assembled diagonal is a rounded sum of two element stiffnesses, so an interior row
    sum is not 0 but a rounding of it (up to half an ulp of d_i, random in sign); such
    row sums (below ROWSUM_RTOL of the row's
    absolute sum) are taken as 0, which keeps the energy the one of the bar rather
    than of its rounding (docs/energy-summation.md). The remainder of a clamped end
    (r = the eliminated element's stiffness) and of a mass matrix (r_i the node's mass)
    is kept. Rows 1 .. n-2 go in blocks of QUAD_BLOCK, each summed in four interleaved
    partial sums: independent chains (no wait on one accumulator) in a fixed order (the
    same bits on every machine, unlike a reassociated sum).
    """
    n = d.size
    if n == 0:
        return 0.0
    if n == 1:
        return snap_row_sum(d[0], abs(d[0])) * x[0] * x[0]
    dx = x[1] - x[0]
    total = (snap_row_sum(d[0] + e[0], abs(d[0]) + abs(e[0])) * x[0] * x[0] - e[0] * dx * dx
             + snap_row_sum(d[n - 1] + e[n - 2], abs(d[n - 1]) + abs(e[n - 2]))
             * x[n - 1] * x[n - 1])
    i = 1
    while i < n - 1:
        end = min(i + QUAD_BLOCK, n - 1)
        s0 = s1 = s2 = s3 = 0.0
        while i + 4 <= end:
            s0 += _inner_term(d, e, x, i)
            s1 += _inner_term(d, e, x, i + 1)
            s2 += _inner_term(d, e, x, i + 2)
            s3 += _inner_term(d, e, x, i + 3)
            i += 4
        while i < end:
            s0 += _inner_term(d, e, x, i)
            i += 1
        total += (s0 + s1) + (s2 + s3)
    return total


@njit(cache=True)
def pt_solve(df, ef, b):
    """Solve L D L^T x = b in place (factors from LAPACK dpttrf).

    Forward: y[i] = b[i] - ef[i-1] y[i-1], carried in a register, and b[i] = y[i] /
    df[i] stored at once; backward: b[i] -= ef[i] b[i+1]. The operations of three
    separate sweeps (L, then D, then L^T), bit for bit, in two passes over b."""
    n = df.size
    if n == 0:
        return
    y = b[0]
    b[0] = y / df[0]
    for i in range(1, n):
        y = b[i] - ef[i - 1] * y
        b[i] = y / df[i]
    pt_backward(ef, b)


@njit(cache=True)
def pt_backward(ef, b):
    """The backward sweep of `pt_solve` in place, b[i] -= ef[i] b[i+1] from the last row
    up: for kernels that fuse the forward sweep into another pass."""
    for i in range(b.size - 2, -1, -1):
        b[i] -= ef[i] * b[i + 1]


def factor_pt(d: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """LDL^T factors of a symmetric positive definite tridiagonal matrix (LAPACK dpttrf)."""
    d, e = np.ascontiguousarray(d, float), np.ascontiguousarray(e, float)
    if d.size == 1:  # scipy's dpttrf wrapper rejects the empty e of a 1 x 1 matrix
        if not d[0] > 0.0:
            raise BenchError(f"system matrix not positive definite (1 x 1: {d[0]!r})")
        return d.copy(), e.copy()
    df, ef, info = lapack.dpttrf(d, e)
    if info != 0:
        raise BenchError(f"system matrix not positive definite (LAPACK dpttrf info={info})")
    return df, ef


# fastmath=False explicitly: a numba callee with no fastmath setting takes its caller's, and
# a contracted K00 u0 + K01 u1 - F0 leaves a round-off lambda != 0 on a free node
@njit(cache=True, fastmath=False)
def eliminate_contact_node(Kd, Ke, F, U, p1=1):
    """Set U[0] = max(0, (F0 - K01 u1) / K00), the massless node of (P_U^mod); return lambda.

    u1 = U[p1] (node 1's position: 1 in node order, another in the interleaved layout
    of `contact_bench.core.spike`). lambda = K00 u0 + K01 u1 - F0 >= 0 is the obstacle's force
    (the contact stress is -lambda); it is 0 when the node is free.
    """
    u1 = U[p1]
    u0 = (F[0] - Ke[0] * u1) / Kd[0]
    U[0] = u0 if u0 > 0.0 else 0.0
    return Kd[0] * U[0] + Ke[0] * u1 - F[0]
