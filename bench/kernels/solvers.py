"""The one compiled solver of the contact subproblem: an LCP on the Delassus matrix.

`lcp_solve`: mu >= 0, g = q + W mu >= 0, mu . g = 0 (exact Signorini on gaps, or Newton's
impact law on velocities: the scheme builds q) by principal pivoting; `penalty_solve`:
the spring law mu = c max(0, -g), g = q + W mu, by the same active-set iteration. Both
solve each active set's linear system exactly (module docstring of
`contact_bench.kernels.contact`, which applies them for any gap operator).
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: pivoting steps of `lcp_solve` before it gives up (a multiple of n_c)
LCP_MAX_PIVOTS = 50


@njit(cache=True)
def _solve_active(W, q, active, mu):  # pragma: no cover - compiled
    idx = np.flatnonzero(active)
    mu[:] = 0.0
    if idx.size:
        sub = np.empty((idx.size, idx.size))
        rhs = np.empty(idx.size)
        for a in range(idx.size):
            rhs[a] = -q[idx[a]]
            for b in range(idx.size):
                sub[a, b] = W[idx[a], idx[b]]
        sol = np.linalg.solve(sub, rhs)
        for a in range(idx.size):
            mu[idx[a]] = sol[a]


@njit(cache=True)
def lcp_solve(W, q, mu, active, tol, warm=False):  # pragma: no cover - compiled
    """mu >= 0 with g = q + W mu >= 0 and mu.g = 0 (W symmetric positive definite).

    Principal pivoting from the active set {q < 0} (`warm`: from the given `active`, the
    previous step's, usually the answer already): block pivots (every violator
    changes side) while they reduce the number of violators, then Murty's least-index
    rule (one pivot at a time, finite for a P-matrix). `tol` is the gap violation
    ignored (round-off, a length); mu's is tol / max W_ii. Returns the number of pivots
    (-1 if it gave up).
    """
    n = q.size
    wmax = 0.0
    for i in range(n):
        wmax = max(wmax, W[i, i])
    tol_mu = tol / wmax if wmax > 0.0 else tol
    if not warm:
        for i in range(n):
            active[i] = q[i] < 0.0
    best = n + 1
    murty = False
    for it in range(LCP_MAX_PIVOTS * (n + 1)):
        _solve_active(W, q, active, mu)
        g = q + W @ mu
        nviol = 0
        first = -1
        for i in range(n):
            bad = (mu[i] < -tol_mu) if active[i] else (g[i] < -tol)
            if bad:
                nviol += 1
                if first < 0:
                    first = i
        if nviol == 0:
            for i in range(n):
                if mu[i] < 0.0:
                    mu[i] = 0.0
            return it
        if not murty and nviol < best:
            best = nviol
            for i in range(n):
                if (mu[i] < -tol_mu) if active[i] else (g[i] < -tol):
                    active[i] = not active[i]
        else:
            murty = True
            active[first] = not active[first]
    return -1


@njit(cache=True)
def penalty_solve(W, q, c, mu, active):  # pragma: no cover - compiled
    """mu = c max(0, -g) with g = q + W mu (penalty springs of stiffness c on the
    contact dofs, W symmetric positive definite): the piecewise-linear system solved by
    active-set iteration from {q < 0} (each set's linear system exactly). Returns the
    number of iterations (-1 if it gave up)."""
    n = q.size
    for i in range(n):
        active[i] = q[i] < 0.0
    for it in range(LCP_MAX_PIVOTS * (n + 1)):
        idx = np.flatnonzero(active)
        mu[:] = 0.0
        if idx.size:
            sub = np.empty((idx.size, idx.size))
            rhs = np.empty(idx.size)
            for a in range(idx.size):  # (I + W_AA C_A) g_A = q_A
                rhs[a] = q[idx[a]]
                for b in range(idx.size):
                    sub[a, b] = W[idx[a], idx[b]] * c[idx[b]] + (1.0 if a == b else 0.0)
            gA = np.linalg.solve(sub, rhs)
            for a in range(idx.size):
                mu[idx[a]] = -c[idx[a]] * gA[a]
        g = q + W @ mu
        same = True
        for i in range(n):
            if (g[i] < 0.0) != active[i]:
                same = False
                active[i] = g[i] < 0.0
        if same:
            return it
    return -1
