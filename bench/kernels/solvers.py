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

from contact_bench.core.refcount import counted

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


@counted
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

#: a contact point's status in `coulomb_solve`: NORMAL_* + TANGENT_* (apart: r_n = 0,
#: u_n >= 0; in contact: u_n = 0, r_n >= 0; stuck: u_t = 0 inside the bound; sliding:
#: r_t on the bound against the slip, + / - along the first tangent)
APART, CONTACT = 0, 3
STICK, SLIDE_PLUS, SLIDE_MINUS = 0, 1, 2


@njit(cache=True)
def _case_2d(Wl, ql, mu, thr, st, rl):  # pragma: no cover - compiled
    """2D: the reactions rl of one point's status `st` (its two linear equations) and
    how far they break its inequalities (<= 0: consistent)."""
    contact = st >= CONTACT
    tst = st - CONTACT if contact else st
    A = np.zeros((2, 2))
    b = np.zeros(2)
    if contact:
        A[0, 0], A[0, 1], b[0] = Wl[0, 0], Wl[0, 1], -ql[0]
    else:
        A[0, 0] = 1.0
    if tst == STICK:
        A[1, 0], A[1, 1], b[1] = Wl[1, 0], Wl[1, 1], -ql[1]
    else:
        sg = 1.0 if tst == SLIDE_PLUS else -1.0
        A[1, 0], A[1, 1], b[1] = sg * mu, 1.0, -sg * thr
    det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    if det == 0.0:
        return np.inf
    rl[0] = (b[0] * A[1, 1] - A[0, 1] * b[1]) / det
    rl[1] = (A[0, 0] * b[1] - b[0] * A[1, 0]) / det
    un = ql[0] + Wl[0, 0] * rl[0] + Wl[0, 1] * rl[1]
    ut = ql[1] + Wl[1, 0] * rl[0] + Wl[1, 1] * rl[1]
    bad = -rl[0] if contact else -un
    if tst == STICK:
        bad = max(bad, abs(rl[1]) - (thr + mu * rl[0]))
    else:
        bad = max(bad, -(1.0 if tst == SLIDE_PLUS else -1.0) * ut)
    return bad


@njit(cache=True)
def _coulomb_point(Wl, ql, mu, thr, rl):  # pragma: no cover - compiled
    """One contact point's problem: rl = (r_n, r_t...) with u = ql + Wl rl, 0 <= u_n _|_
    r_n >= 0, |r_t| <= thr + mu r_n, u_t = 0 inside the bound, r_t = -(thr + mu r_n)
    u_t / |u_t| on it. 2D: the six statuses tried in turn, apart first, each two linear
    equations solved exactly, the first consistent one taken (the least inconsistent
    one when round-off leaves none). 3D: stuck (a 3 x 3 solve) or sliding on the circular
    cone along the direction found by bisection to round-off (`_slip_cross`). Returns
    its status."""
    k = ql.size
    if k == 2:
        best, worst = -1, np.inf
        tmp = np.empty(2)
        for st in (APART + SLIDE_PLUS, APART + SLIDE_MINUS, APART + STICK,
                   CONTACT + STICK, CONTACT + SLIDE_PLUS, CONTACT + SLIDE_MINUS):
            if st == APART + STICK and thr == 0.0:
                continue  # no tangential reaction apart under Coulomb
            bad = _case_2d(Wl, ql, mu, thr, st, tmp)
            if bad < worst:
                best, worst = st, bad
                rl[0], rl[1] = tmp[0], tmp[1]
            if bad <= 0.0:
                break
        rl[0] = max(rl[0], 0.0)
        return best
    # 3D
    if ql[0] >= 0.0 and thr == 0.0:
        rl[:] = 0.0
        return APART + SLIDE_PLUS
    for apart in (True, False):
        if apart:  # stuck apart: u_t = 0 with r_n = 0
            sol = np.zeros(k)
            sol[1:] = np.linalg.solve(Wl[1:, 1:], -ql[1:])
        else:
            sol = np.linalg.solve(Wl, -ql)
        un = ql[0] + Wl[0] @ sol
        tn = np.sqrt(np.sum(sol[1:] * sol[1:]))
        if (un >= 0.0 if apart else sol[0] >= 0.0) and tn <= thr + mu * sol[0]:
            rl[:] = sol
            return (APART if apart else CONTACT) + STICK
        # sliding: r_t = -(thr + mu r_n) d, d = (cos a, sin a); u_t(a) a positive
        # multiple of d: the cross product u_t x d scanned over `COULOMB_ANGLES` angles,
        # each sign change bisected to round-off
        lo = 0.0
        c_lo = _slip_cross(Wl, ql, mu, thr, 0.0, rl, apart)
        for m in range(1, COULOMB_ANGLES + 1):
            hi = 2.0 * np.pi * m / COULOMB_ANGLES
            c_hi = _slip_cross(Wl, ql, mu, thr, hi, rl, apart)
            if (c_lo <= 0.0) != (c_hi <= 0.0):
                a0, a1, f0 = lo, hi, c_lo
                for _ in range(80):
                    am = 0.5 * (a0 + a1)
                    fm = _slip_cross(Wl, ql, mu, thr, am, rl, apart)
                    if (fm <= 0.0) == (f0 <= 0.0):
                        a0, f0 = am, fm
                    else:
                        a1 = am
                    if a1 - a0 <= 1e-16 * (1.0 + abs(a0)):
                        break
                am = 0.5 * (a0 + a1)
                _slip_cross(Wl, ql, mu, thr, am, rl, apart)
                un = ql[0] + Wl[0] @ rl
                ok = un >= 0.0 if apart else rl[0] >= 0.0
                if ok and _slip_along(Wl, ql, rl, am) >= 0.0:
                    return ((APART if apart else CONTACT)
                            + (SLIDE_PLUS if np.cos(am) >= 0.0 else SLIDE_MINUS))
            lo, c_lo = hi, c_hi
    # no consistent root (round-off at a boundary): slide along the free slip
    am = np.arctan2(ql[2], ql[1]) if ql[1] != 0.0 or ql[2] != 0.0 else 0.0
    _slip_cross(Wl, ql, mu, thr, am, rl, False)
    if rl[0] < 0.0:
        _slip_cross(Wl, ql, mu, thr, am, rl, True)
    return CONTACT + (SLIDE_PLUS if np.cos(am) >= 0.0 else SLIDE_MINUS)


@njit(cache=True)
def _slip_cross(Wl, ql, mu, thr, a, rl, apart):  # pragma: no cover - compiled
    """3D sliding along d = (cos a, sin a): rl = (r_n, -(thr + mu r_n) d) with r_n = 0
    (`apart`) or u_n = 0; returns u_t x d."""
    c, s = np.cos(a), np.sin(a)
    wd = Wl[0, 1] * c + Wl[0, 2] * s
    den = Wl[0, 0] - mu * wd
    if apart:
        rn = 0.0
    else:
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
    """2D: the linear system of the statuses found (`_case_2d`'s equations, every point
    at once) solved exactly; True (and r set) when its solution satisfies every
    status's inequalities to the round-off tolerances."""
    nc = mu.size
    n = 2 * nc
    A = np.zeros((n, n))
    b = np.zeros(n)
    for j in range(nc):
        t = nc + j
        contact = status[j] >= CONTACT
        tst = status[j] - CONTACT if contact else status[j]
        if contact:
            A[j, :] = W[j, :]
            b[j] = -q[j]
        else:
            A[j, j] = 1.0
        if tst == STICK:
            A[t, :] = W[t, :]
            b[t] = -q[t]
        else:
            sg = 1.0 if tst == SLIDE_PLUS else -1.0
            A[t, t] = 1.0
            A[t, j] = sg * mu[j]
            b[t] = -sg * thr[j]
    x = np.linalg.solve(A, b)
    u = q + W @ x
    for j in range(nc):
        t = nc + j
        contact = status[j] >= CONTACT
        tst = status[j] - CONTACT if contact else status[j]
        if contact and x[j] < -tol_r:
            return False
        if not contact and u[j] < -tol:
            return False
        if tst == STICK:
            if abs(x[t]) > thr[j] + mu[j] * x[j] + tol_r:
                return False
        elif (1.0 if tst == SLIDE_PLUS else -1.0) * u[t] < -tol:
            return False
    r[:] = x
    for j in range(nc):
        if r[j] < 0.0:
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


@njit(cache=True)
def _penalty_case_2d(Wl, ql, mu, c, rho, st, rl):  # pragma: no cover - compiled
    """2D, penalty springs of stiffness c (normal and tangential) with Coulomb's bound: the
    reactions rl of one point's status `st` and how far they break its inequalities.
    Apart: r_n = 0 (u_n >= 0); in contact: r_n = -c u_n (u_n <= 0). Stuck: r_t = rho - c
    u_t (the previous tangential reaction plus the spring's, inside mu r_n); sliding with
    sign s: r_t = s mu r_n, the trial rho - c u_t beyond the bound on that side."""
    contact = st >= CONTACT
    if not contact:  # no spring acts
        rl[0], rl[1] = 0.0, 0.0
        return -ql[0]
    tst = st - CONTACT
    A = np.zeros((2, 2))
    b = np.zeros(2)
    if contact:  # r_n + c (q_n + W_nn r_n + W_nt r_t) = 0
        A[0, 0], A[0, 1], b[0] = 1.0 + c * Wl[0, 0], c * Wl[0, 1], -c * ql[0]
    else:
        A[0, 0] = 1.0
    if tst == STICK:  # r_t + c (q_t + W_tn r_n + W_tt r_t) = rho
        A[1, 0], A[1, 1], b[1] = c * Wl[1, 0], 1.0 + c * Wl[1, 1], rho - c * ql[1]
    else:
        sg = 1.0 if tst == SLIDE_PLUS else -1.0
        A[1, 0], A[1, 1] = -sg * mu, 1.0
    det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    if det == 0.0:
        return np.inf
    rl[0] = (b[0] * A[1, 1] - A[0, 1] * b[1]) / det
    rl[1] = (A[0, 0] * b[1] - b[0] * A[1, 0]) / det
    un = ql[0] + Wl[0, 0] * rl[0] + Wl[0, 1] * rl[1]
    ut = ql[1] + Wl[1, 0] * rl[0] + Wl[1, 1] * rl[1]
    bad = un if contact else -un
    if tst == STICK:
        bad = max(bad, abs(rl[1]) - mu * rl[0])
    else:
        sg = 1.0 if tst == SLIDE_PLUS else -1.0
        bad = max(bad, mu * rl[0] - sg * (rho - c * ut))
    return bad


@njit(cache=True)
def _penalty_point_2d(Wl, ql, mu, c, rho, rl, tmp):  # pragma: no cover - compiled
    """2D: one point's penalty problem, its statuses tried in turn (`_penalty_case_2d`),
    the first consistent one taken (the least inconsistent when round-off leaves none)."""
    worst = np.inf
    for st in (APART + SLIDE_PLUS, CONTACT + STICK, CONTACT + SLIDE_PLUS,
               CONTACT + SLIDE_MINUS):
        bad = _penalty_case_2d(Wl, ql, mu, c, rho[0], st, tmp)
        if bad < worst:
            worst = bad
            rl[0], rl[1] = tmp[0], tmp[1]
        if bad <= 0.0:
            break


@njit(cache=True)
def _penalty_slide_3d(Wl, ql, mu, c, rho, a, rl):  # pragma: no cover - compiled
    """3D penalty sliding along d = (cos a, sin a): rl = (r_n, mu r_n d) with r_n = -c
    u_n; returns (z x d, z . d - mu r_n) for the trial z = rho - c u_t (the slide is
    consistent where the first is zero and the second >= 0)."""
    cs, sn = np.cos(a), np.sin(a)
    den = 1.0 + c * (Wl[0, 0] + mu * (Wl[0, 1] * cs + Wl[0, 2] * sn))
    rn = -c * ql[0] / den if den > 0.0 else -1.0
    rl[0], rl[1], rl[2] = rn, mu * rn * cs, mu * rn * sn
    z1 = rho[0] - c * (ql[1] + Wl[1, 0] * rl[0] + Wl[1, 1] * rl[1] + Wl[1, 2] * rl[2])
    z2 = rho[1] - c * (ql[2] + Wl[2, 0] * rl[0] + Wl[2, 1] * rl[1] + Wl[2, 2] * rl[2])
    return z1 * sn - z2 * cs, z1 * cs + z2 * sn - mu * rn


@njit(cache=True)
def _penalty_point_3d(Wl, ql, mu, c, rho, rl):  # pragma: no cover - compiled
    """3D: one point's penalty problem with the circular cone. Apart (q_n >= 0: no
    spring acts); stuck: (I + c Wl) rl = (-c q_n, rho - c q_t), inside the cone; else
    sliding: r_t = mu r_n d, d = (cos a, sin a) the trial's direction, found as
    `_coulomb_point` finds a slip direction (the cross product z x d scanned over
    `COULOMB_ANGLES` angles, each sign change bisected to round-off)."""
    if ql[0] >= 0.0:
        rl[:] = 0.0
        return
    A = c * Wl.copy()
    for i in range(3):
        A[i, i] += 1.0
    b = np.empty(3)
    b[0], b[1], b[2] = -c * ql[0], rho[0] - c * ql[1], rho[1] - c * ql[2]
    sol = np.linalg.solve(A, b)
    if sol[0] >= 0.0 and np.sqrt(sol[1] * sol[1] + sol[2] * sol[2]) <= mu * sol[0]:
        rl[:] = sol
        return
    best, best_a = np.inf, 0.0
    lo = 0.0
    x_lo = _penalty_slide_3d(Wl, ql, mu, c, rho, 0.0, rl)[0]
    for m in range(1, COULOMB_ANGLES + 1):
        hi = 2.0 * np.pi * m / COULOMB_ANGLES
        x_hi = _penalty_slide_3d(Wl, ql, mu, c, rho, hi, rl)[0]
        if (x_lo <= 0.0) != (x_hi <= 0.0):
            a0, a1, f0 = lo, hi, x_lo
            for _ in range(80):
                am = 0.5 * (a0 + a1)
                fm = _penalty_slide_3d(Wl, ql, mu, c, rho, am, rl)[0]
                if (fm <= 0.0) == (f0 <= 0.0):
                    a0, f0 = am, fm
                else:
                    a1 = am
                if a1 - a0 <= 1e-16 * (1.0 + abs(a0)):
                    break
            am = 0.5 * (a0 + a1)
            along = _penalty_slide_3d(Wl, ql, mu, c, rho, am, rl)[1]
            if rl[0] >= 0.0 and along >= 0.0:
                return
            if -along < best:  # the least inconsistent, kept for round-off
                best, best_a = -along, am
        lo, x_lo = hi, x_hi
    _penalty_slide_3d(Wl, ql, mu, c, rho, best_a, rl)
    rl[0] = max(rl[0], 0.0)


@njit(cache=True)
def penalty_coulomb_solve(W, q, mu, c, rho, r):  # pragma: no cover - compiled
    """Penalty contact with Coulomb friction on the Delassus matrix of [normals;
    tangents] (`coulomb_solve`'s layout, n_t = 1 or 2 tangents per point): per point r_n
    = c max(0, -u_n) and the tangential spring's return map r_t = proj(rho - c u_t) onto
    the disc |r_t| <= mu r_n (an interval in 2D; rho: the previous step's r_t), u = q + W
    r. Nonsmooth block Gauss-Seidel as `coulomb_solve`, each point's problem solved
    exactly (2D: its statuses in turn, `_penalty_case_2d`; 3D: `_penalty_point_3d`),
    until a sweep changes no reaction by more than `COULOMB_RTOL` of the largest; a
    sliding point's r_t is on the bound exactly. Returns the sweeps (-1 after
    `COULOMB_MAX_SWEEPS`)."""
    nc = mu.size
    n = q.size
    nt = n // nc - 1
    k = nt + 1
    u = q + W @ r
    idx = np.empty(k, np.int64)
    Wl = np.empty((k, k))
    ql = np.empty(k)
    rl = np.empty(k)
    tmp = np.empty(2)
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
            if nt == 1:
                _penalty_point_2d(Wl, ql, mu[j], c[j], rho[j:j + 1], rl, tmp)
            else:
                _penalty_point_3d(Wl, ql, mu[j], c[j], rho[nt * j:nt * j + nt], rl)
            for a in range(k):
                i = idx[a]
                dr = rl[a] - r[i]
                if dr != 0.0:
                    for m in range(n):
                        u[m] += W[m, i] * dr
                    r[i] = rl[a]
                    dmax = max(dmax, abs(dr))
                rmax = max(rmax, abs(rl[a]))
        if dmax <= COULOMB_RTOL * rmax:
            return sweep + 1
    return -1
