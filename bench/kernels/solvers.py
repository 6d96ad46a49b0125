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


# ------------------------------------------------------------------ Coulomb friction

#: sweeps of `coulomb_solve` before it stops without meeting its tolerance
COULOMB_MAX_SWEEPS = 2000
#: `coulomb_solve` stops when a sweep changes no reaction by more than this times the
#: largest reaction (or when the 2D status finish is consistent)
COULOMB_RTOL = 1e-13
#: angles scanned for the slip direction of a 3D contact point's local problem
COULOMB_ANGLES = 64

#: a contact point's status in `coulomb_solve`: apart, stuck, sliding (+ / - tangent)
APART, STICK, SLIDE_PLUS, SLIDE_MINUS = 0, 1, 2, 3


@njit(cache=True)
def _coulomb_point(Wl, ql, mu, thr, rl):  # pragma: no cover - compiled
    """One contact point's Coulomb problem, exactly (2D; 3D: the slip direction to
    round-off): rl = (r_n, r_t...) with u = ql + Wl rl, 0 <= u_n _|_ r_n >= 0,
    |r_t| <= thr + mu r_n, u_t = 0 where inside, r_t = -(thr + mu r_n) u_t / |u_t| on the
    boundary. Returns its status (APART, STICK, SLIDE_PLUS / SLIDE_MINUS: the slip's
    sign along the first tangent)."""
    k = ql.size
    if ql[0] >= 0.0:
        rl[:] = 0.0
        return APART
    sol = np.linalg.solve(Wl, -ql)  # stuck
    bound = thr + mu * sol[0]
    tn = 0.0
    for a in range(1, k):
        tn += sol[a] * sol[a]
    if sol[0] >= 0.0 and np.sqrt(tn) <= bound:
        rl[:] = sol
        return STICK
    if k == 2:
        for s in (1.0, -1.0):  # sliding with u_t of sign s: r_t = -s (thr + mu r_n)
            den = Wl[0, 0] - s * mu * Wl[0, 1]
            rn = (-ql[0] + s * thr * Wl[0, 1]) / den if den > 0.0 else -1.0
            if rn >= 0.0:
                rt = -s * (thr + mu * rn)
                ut = ql[1] + Wl[1, 0] * rn + Wl[1, 1] * rt
                if s * ut >= 0.0:
                    rl[0], rl[1] = rn, rt
                    return SLIDE_PLUS if s > 0.0 else SLIDE_MINUS
        # no consistent case (round-off at a boundary): slide along the free slip
        s = 1.0 if ql[1] >= 0.0 else -1.0
        rn = max(0.0, -ql[0] / Wl[0, 0])
        rl[0], rl[1] = rn, -s * (thr + mu * rn)
        return SLIDE_PLUS if s > 0.0 else SLIDE_MINUS
    # 3D: r_t = -(thr + mu r_n) d on the circular cone, d = (cos a, sin a) the slip's
    # direction: u_n = 0 gives r_n(a), and u_t(a) must be a positive multiple of d. The
    # cross product u_t x d is scanned over `COULOMB_ANGLES` angles and each sign change
    # bisected to round-off; the root with u_t . d >= 0 and r_n >= 0 is taken.
    best = -1.0
    lo = 0.0
    c_lo = _slip_cross(Wl, ql, mu, thr, 0.0, rl)
    for m in range(1, COULOMB_ANGLES + 1):
        hi = 2.0 * np.pi * m / COULOMB_ANGLES
        c_hi = _slip_cross(Wl, ql, mu, thr, hi, rl)
        if (c_lo <= 0.0) != (c_hi <= 0.0):
            a0, a1, f0 = lo, hi, c_lo
            for _ in range(80):
                am = 0.5 * (a0 + a1)
                fm = _slip_cross(Wl, ql, mu, thr, am, rl)
                if (fm <= 0.0) == (f0 <= 0.0):
                    a0, f0 = am, fm
                else:
                    a1 = am
                if a1 - a0 <= 1e-16 * (1.0 + abs(a0)):
                    break
            am = 0.5 * (a0 + a1)
            _slip_cross(Wl, ql, mu, thr, am, rl)
            if rl[0] >= 0.0 and _slip_along(Wl, ql, rl, am) >= 0.0:
                best = am
                break
        lo, c_lo = hi, c_hi
    if best < 0.0:  # no consistent root (round-off at a boundary): slide along the free slip
        best = np.arctan2(ql[2], ql[1]) if ql[1] != 0.0 or ql[2] != 0.0 else 0.0
        _slip_cross(Wl, ql, mu, thr, best, rl)
        rl[0] = max(rl[0], 0.0)
    else:
        _slip_cross(Wl, ql, mu, thr, best, rl)
    b = thr + mu * rl[0]
    rl[1], rl[2] = -b * np.cos(best), -b * np.sin(best)
    return SLIDE_PLUS if np.cos(best) >= 0.0 else SLIDE_MINUS


@njit(cache=True)
def _slip_cross(Wl, ql, mu, thr, a, rl):  # pragma: no cover - compiled
    """3D sliding along d = (cos a, sin a): rl = (r_n, -(thr + mu r_n) d) with u_n = 0;
    returns u_t x d."""
    c, s = np.cos(a), np.sin(a)
    wd = Wl[0, 1] * c + Wl[0, 2] * s
    den = Wl[0, 0] - mu * wd
    rn = (-ql[0] + thr * wd) / den if den > 0.0 else -1.0
    b = thr + mu * rn
    rl[0], rl[1], rl[2] = rn, -b * c, -b * s
    u1 = ql[1] + Wl[1, 0] * rl[0] + Wl[1, 1] * rl[1] + Wl[1, 2] * rl[2]
    u2 = ql[2] + Wl[2, 0] * rl[0] + Wl[2, 1] * rl[1] + Wl[2, 2] * rl[2]
    return u1 * s - u2 * c


@njit(cache=True)
def _slip_along(Wl, ql, rl, a):  # pragma: no cover - compiled
    """u_t . (cos a, sin a) at the reactions rl."""
    u1 = ql[1] + Wl[1, 0] * rl[0] + Wl[1, 1] * rl[1] + Wl[1, 2] * rl[2]
    u2 = ql[2] + Wl[2, 0] * rl[0] + Wl[2, 1] * rl[1] + Wl[2, 2] * rl[2]
    return u1 * np.cos(a) + u2 * np.sin(a)


@njit(cache=True)
def _coulomb_finish(W, q, mu, thr, status, r, tol, tol_r):  # pragma: no cover - compiled
    """2D: the linear system of the statuses found (apart: r = 0; stuck: u_n = u_t = 0;
    sliding with sign s: u_n = 0, r_t = -s (thr + mu r_n)) solved exactly; True (and r
    set) when its solution satisfies every status's inequalities."""
    nc = mu.size
    n = 2 * nc
    A = np.zeros((n, n))
    b = np.zeros(n)
    for j in range(nc):
        t = nc + j
        st = status[j]
        if st == APART:
            A[j, j] = 1.0
            A[t, t] = 1.0
        else:
            A[j, :] = W[j, :]
            b[j] = -q[j]
            if st == STICK:
                A[t, :] = W[t, :]
                b[t] = -q[t]
            else:
                s = 1.0 if st == SLIDE_PLUS else -1.0
                A[t, t] = 1.0
                A[t, j] = s * mu[j]
                b[t] = -s * thr[j]
    x = np.linalg.solve(A, b)
    u = q + W @ x
    for j in range(nc):
        t = nc + j
        st = status[j]
        if st == APART:
            if u[j] < -tol:
                return False
        elif x[j] < -tol_r:
            return False
        elif st == STICK:
            if abs(x[t]) > thr[j] + mu[j] * x[j] + tol_r:
                return False
        else:
            s = 1.0 if st == SLIDE_PLUS else -1.0
            if s * u[t] < -tol:
                return False
    r[:] = x
    for j in range(nc):  # the exact zeros of the statuses
        if status[j] == APART:
            r[j] = 0.0
            r[nc + j] = 0.0
        elif r[j] < 0.0:
            r[j] = 0.0
    return True


@njit(cache=True)
def coulomb_solve(W, q, mu, thr, r, status, tol):  # pragma: no cover - compiled
    """Signorini and Coulomb (or Tresca) friction on the Delassus matrix W of the rows
    [normals; tangents] (n_c normal rows, then n_t = W's size / n_c - 1 tangent rows per
    contact point, point by point): r = (r_n, r_t) with u = q + W r,

        0 <= u_n _|_ r_n >= 0,  |r_t| <= thr + mu r_n,
        u_t = 0 inside the bound, r_t = -(thr + mu r_n) u_t / |u_t| on it

    (mu: Coulomb's coefficient per point, thr: Tresca's threshold; the exact circular
    cone in 3D). Nonsmooth block Gauss-Seidel (Siconos' NSGS): each point's local
    problem solved in turn (`_coulomb_point`) from the others' latest reactions, r (in:
    a warm start, out: the answer) and `status` (out) updated, until a sweep changes no
    reaction by more than `COULOMB_RTOL` of the largest one; in 2D, after each sweep, the
    statuses found are tried as an exact linear system (`_coulomb_finish`, as
    `lcp_solve`'s active sets), which usually ends it with the gaps and the stuck slips
    zero to round-off. A sliding point's tangential reaction is on the bound exactly, at
    every sweep. `tol` is the violation of u ignored (round-off). Returns the sweeps
    made (-1 when `COULOMB_MAX_SWEEPS` passed: r is the last sweep's)."""
    nc = mu.size
    n = q.size
    nt = n // nc - 1
    k = nt + 1
    u = q + W @ r
    wmax = 0.0
    for i in range(n):
        wmax = max(wmax, W[i, i])
    tol_r = tol / wmax if wmax > 0.0 else tol
    idx = np.empty(k, np.int64)
    Wl = np.empty((k, k))
    ql = np.empty(k)
    rl = np.empty(k)
    for sweep in range(COULOMB_MAX_SWEEPS):
        dmax = 0.0
        rmax = 0.0
        for j in range(nc):
            idx[0] = j
            for a in range(nt):
                idx[a + 1] = nc + j * nt + a
            for a in range(k):
                acc = u[idx[a]]
                for b in range(k):
                    Wl[a, b] = W[idx[a], idx[b]]
                    acc -= Wl[a, b] * r[idx[b]]
                ql[a] = acc
            status[j] = _coulomb_point(Wl, ql, mu[j], thr[j], rl)
            for a in range(k):
                dr = rl[a] - r[idx[a]]
                if dr != 0.0:
                    for i in range(n):
                        u[i] += W[i, idx[a]] * dr
                    r[idx[a]] = rl[a]
                    dmax = max(dmax, abs(dr))
                rmax = max(rmax, abs(rl[a]))
        if nt == 1 and _coulomb_finish(W, q, mu, thr, status, r, tol, tol_r):
            return sweep + 1
        if dmax <= COULOMB_RTOL * rmax:
            return sweep + 1
    return -1
