"""Newmark(beta, gamma) with the contact enforced exactly at t_{n+1}.

Shared by `standard` (consistent mass) and `redistributed` (massless contact node).

Implicit (beta > 0), displacement form: S U^{n+1} = M U~ + beta dt^2 (F + lambda e0)
with S = M + beta dt^2 K factored once (`contact_bench.core.spike`, on LAPACK dpttrf; small
problems: plain LDL^T factors and the serial kernels of `newmark_serial`, `kernel_form`) and the
predictor U~ = U^n + dt V^n + (1/2 - beta) dt^2 A^n. The response to a unit contact
force, w = S^{-1} e0, is known from the factors: when the contact-free solution U_f
penetrates, U^{n+1} = U_f + mu w with mu = -U_f[0] / w[0], folded into the solve's
spike correction, so an active contact costs no second solve. The obstacle's force is
lambda = mu / (beta dt^2) >= 0 and the contact stress is -lambda (E u_x(0) <= 0 in
compression).

Explicit (beta = 0), only with a massless contact node (P_U^mod of Dabaghi, Petrov,
Pousin, Renard 2014): the other nodes are advanced by central differences, then
u0 = max(0, (F0 - K01 u1) / K00) and lambda = K00 u0 + K01 u1 - F0.

A massless node has no inertia, so its Newmark acceleration is meaningless: its
velocity is taken as the backward difference (u0^{n+1} - u0^n) / dt.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from contact_bench.api.params import Param
from contact_bench.api.plugin import Semidiscrete, Trajectory
from contact_bench.core.config import FASTMATH
from contact_bench.core.errors import BenchError
from contact_bench.core.sampling import Samples, energy_of
from contact_bench.core.spike import L, Spike, SpikeFactors, lane_zeros, spike_factor, stencil_solve
from contact_bench.core.tridiag import eliminate_contact_node, factor_pt, pt_solve
from contact_bench.kernels.common import (
    allocate,
    bar_ops,
    initial_acceleration,
    run_spec,
    trajectory,
)
from contact_bench.kernels.newmark_serial import (
    ThomasExplicit,
    ThomasImplicit,
    XQCoef,
    XQState,
    serial_explicit,
    serial_implicit,
)
from contact_bench.kernels.newmark_vec import LaneOps, explicit_kernel, implicit_kernel

BETA = Param(0.25, "Newmark beta (0: explicit central difference)", low=0.0, high=0.5)
GAMMA = Param(0.5, "Newmark gamma", low=0.5, high=1.0)
#: omega_max h / c of the first_element_massless mass in contact (see `newmark_limit`)
EDGE_MODE_OMEGA = float(np.sqrt(6.0 + 4.0 * np.sqrt(3.0)))


def newmark_limit(beta: float, gamma: float, h: float, c: float, lumped: bool,
                  first_element_massless: bool = False) -> float | None:
    """Largest stable dt of undamped Newmark on P1 elements (None: unconditionally stable).

    Stable iff omega_max dt <= 1 / sqrt(gamma/2 - beta) when 2 beta < gamma, with
    omega_max = 2 c / h (lumped mass) or 2 sqrt(3) c / h (consistent, or a massless
    contact node with the getfem or conservative mass): the central difference limits
    h / c and h / (c sqrt 3).

    `first_element_massless`: that mass (Dabaghi et al.'s M^mod) takes the first
    element's mass away from node 1, and
    while the contact node sits on the obstacle (u0 = 0) node 1 keeps its full
    stiffness 2 E / h with mass rho h / 3 only. That gives an edge mode u_j ~ r^j,
    r = 1 - sqrt 3, above the interior band: omega_max^2 = (6 + 4 sqrt 3) c^2 / h^2
    (`EDGE_MODE_OMEGA`; from node 1's row, 6 (2 - r) = w (2 + r), and the interior rows,
    6 (2 - r - 1/r) = w (4 + r + 1/r), w = omega^2 h^2 / c^2), so the central
    difference limit is 0.556 h / c, not 0.577 h / c (tests/test_schemes_extra.py
    checks it against the generalized eigenvalues of both contact states).
    """
    if 2.0 * beta >= gamma:
        return None
    factor = 2.0 if lumped else (EDGE_MODE_OMEGA if first_element_massless else 2.0 * np.sqrt(3.0))
    omega_max = factor * c / h
    return float(1.0 / (np.sqrt(gamma / 2.0 - beta) * omega_max))


# ---------------------------------------------------------------------------- kernels
#
# The stepping kernels are generated (`contact_bench.kernels.newmark_codegen` writes
# `contact_bench.kernels.newmark_vec`): they work in the lane-interleaved layout of
# `contact_bench.core.spike`
# (node i = c m + j at position j L + c, L = LANES = 16), solving the system by 16
# blocks at once, one row of all blocks per pair of `<8 x double>` vector operations
# (`contact_bench.core.simd`), with the sweep recurrences carried in registers. The state is
# (X, Q): X the next solve's predictor, Q = dt V + dt^2 (1 - gamma) A; V is formed on
# sample steps only. Each step is two passes over the state: the backward sweep, then
# one pass that finishes row j + 1 (spike correction, Newmark update) and starts row j
# of the next step (right-hand side, forward sweep). They compile with
# `contact_bench.core.config.FASTMATH` (FMA contraction only).
#: rows per lane block the vector kernels need (smaller systems are padded)
MIN_ROWS = 3
#: systems with fewer unknowns step with the serial Thomas kernels
#: (`contact_bench.kernels.newmark_serial`), larger ones with the SPIKE vector kernels:
#: the crossover of their cost per dof-step, measured on the project's machine
#: (docs/performance-small-grids.md)
SERIAL_BELOW = 64
#: ... and runs of fewer dof-steps (unknowns x steps) stay serial whatever their size:
#: the SPIKE form's set-up (its factors, the reduced system, the interleaved layout) costs
#: about as much as this many dof-steps save (docs/performance-small-grids.md)
SPIKE_MIN_DOF_STEPS = 250_000
#: the same crossover for the kernel pairs with one solve with M per step (`ode_verlet`:
#: `contact_bench.kernels.massless_ode`, `taylor_flanagan`:
#: `contact_bench.kernels.taylor_flanagan`): below this many unknowns (or
#: `SPIKE_MIN_DOF_STEPS` dof-steps) their natural-order kernel, a plain serial sweep, is
#: faster than the SPIKE form and its set-up (docs/performance-small-grids.md)
EXPLICIT_SERIAL_BELOW = 160
#: the kernel forms `run_newmark` can be asked for (None: chosen by size)
FORMS = ("serial", "spike")


def kernel_form(n: int, nsteps: int | None = None, form: str | None = None,
                serial_below: int = SERIAL_BELOW) -> str:
    """The form that steps n unknowns over nsteps steps: `form` if given; else "serial"
    below `serial_below` unknowns (the crossover of a kernel pair, `SERIAL_BELOW` for
    Newmark's) or `SPIKE_MIN_DOF_STEPS` dof-steps, "spike" above. The serial form needs
    n >= 3 (smaller systems always take the SPIKE form)."""
    if form is not None:
        if form not in FORMS:
            raise ValueError(f"kernel form must be one of {FORMS}, got {form!r}")
        return form if n >= 3 else "spike"
    if n < 3:
        return "spike"
    if n < serial_below or (nsteps is not None and n * nsteps < SPIKE_MIN_DOF_STEPS):
        return "serial"
    return "spike"


@njit(cache=True, fastmath=FASTMATH)
def massless_acceleration(Kd, Ke, F, lanes, p1, U, z, coef):
    """The ODE (P_U^mod) of Dabaghi et al. 2014 in the interleaved layout: U[0] <- u0(u1)
    (node 1 at position p1), z <- A = M_r^-1 (F - K U) on nodes 1.. and A[0] = 0; returns lambda.

    (Kd, Ke), F: K and the load in node order; lanes: the `LaneStiffness` (K, F in the
    interleaved layout and fac = `Spike.factors()` of M_r with node 0 decoupled: an
    identity row, lo = 0 at node 1), so the right-hand side of node 0 only reaches z[0],
    which is set to 0.
    """
    Kdl, Klo, Fl, fac = lanes
    lam = eliminate_contact_node(Kd, Ke, F, U, p1)
    stencil_solve(Kdl, Klo, U, Fl, -1.0, fac, z, coef)
    z[0] = 0.0
    return lam


class LaneStiffness(NamedTuple):
    """The explicit SPIKE kernels' operators in the interleaved layout: K's diagonal Kdl
    and lower band Klo, the load Fl, and fac = `Spike.factors()` of the mass."""

    Kdl: np.ndarray
    Klo: np.ndarray
    Fl: np.ndarray
    fac: SpikeFactors


def _load_to_lanes(sp: Spike, F: np.ndarray, scale: float) -> np.ndarray:
    """scale * F in the interleaved layout; a zero load is np.zeros, whose pages the
    kernel only reads, so it costs no resident memory at large n."""
    return sp.to_lanes(scale * F) if np.any(F) else sp.zeros()


def h_diagonals(sp: Spike) -> tuple[np.ndarray, ...]:
    """The reduced-system map H of `sp` as vector diagonals, for the vector kernels.

    Rows 0..L-1 of H give A, rows L..2L-1 give B; its columns are the interface values
    s (row 0 of every lane) and t (row m-1), which the kernels keep at ibuf[L:2L] and
    ibuf[2L:3L] between zeros. The entries coupling lane c of (A or B) to lane c + d of
    (s or t) form one diagonal: Dg[k] (L values), read against ibuf[Dsrc[k]:Dsrc[k]+L]
    into A (Ddst[k] = 0) or B (1). Row 2L (the free x[0]) stays as (X0pos, X0val) pairs.
    """
    m = sp.m
    cols = np.where(sp.Hpos < L, sp.Hpos, sp.Hpos - (m - 1) * L + L)  # 0..2L-1: (s, t)
    rows = np.asarray(sp.Hrow, np.int64)
    at_x0 = rows == 2 * L
    x0pos = (L + cols[at_x0]).astype(np.int64)
    x0val = np.asarray(sp.Hval[at_x0], float)
    r, c, v = rows[~at_x0], cols[~at_x0], sp.Hval[~at_x0]
    dst, lane = np.divmod(r, L)
    src, col_lane = np.divmod(c, L)
    d = col_lane - lane
    # one diagonal per (dst, src, d), in that (sorted) order: an integer key sorts alike
    key = (dst * 2 + src) * (2 * L) + (d + L)
    keys, which = np.unique(key, return_inverse=True)
    Dg = lane_zeros(L * keys.size)
    Dg[which * L + lane] = v
    kd = keys % (2 * L) - L
    ks = (keys // (2 * L)) % 2
    Dsrc = (L + L * ks + kd).astype(np.int64)
    Ddst = (keys // (4 * L)).astype(np.int64)
    return Dg, Dsrc, Ddst, x0pos, x0val


def run_newmark(semi: Semidiscrete, dt: float, nsteps: int, stride: int,
                beta: float, gamma: float, form: str | None = None) -> Trajectory:
    """Factor outside the loop, then call the kernel of the form `kernel_form` picks:
    the serial Thomas kernel on small systems, the SPIKE vector kernel on large ones
    (interleaved factors; its state lives only in the interleaved layout, nothing in node
    order is kept alive while it steps beyond the problem and the sample buffers).
    """
    M, K, F = semi.M, semi.K, semi.F
    n = semi.nfree
    dt, beta, gamma = float(dt), float(beta), float(gamma)
    U, V = semi.U0, semi.V0
    if beta == 0.0:
        if not semi.massless:
            raise ValueError("explicit Newmark (beta = 0) here needs a massless contact node")
        if n < 2:
            raise ValueError("explicit Newmark needs at least one node besides the contact node")
    out = allocate(semi, nsteps, stride)
    out.U[0], out.V[0], out.cu[0] = U, V, U[0]
    out.energy[0] = energy_of(M.diag, M.off, K.diag, K.off, F, U, V, semi.energy_offset)
    A = initial_acceleration(semi)
    dt2 = dt * dt
    if kernel_form(n, nsteps, form) == "serial":
        res = _run_serial(semi, dt, nsteps, stride, beta, gamma, A, out)
        return trajectory(out, *res, dt)
    if beta > 0.0:
        bdt2 = beta * dt2
        if not (bdt2 > 0.0 and math.isfinite(1.0 / bdt2)):
            raise BenchError(f"Newmark beta = {beta!r} with dt = {dt!r}: 1 / (beta dt^2) "
                             "overflows; allowed: a larger beta or dt")
        sp = spike_factor(M.diag + bdt2 * K.diag, M.off + bdt2 * K.off, MIN_ROWS)
        # S X + G = M U~ + beta dt^2 F; X = U~ = U + dt V + (1/2 - beta) dt^2 A
        Sd, Slo, G = sp.to_lanes(M.diag), sp.lower_to_lanes(M.off), _load_to_lanes(sp, F, bdt2)
        X = sp.to_lanes(U + dt * V + (0.5 - beta) * dt2 * A)
        k1, k2, kv = (gamma + 0.5 - beta) / beta, 1.0 / beta, gamma / (beta * dt)
        kernel = implicit_kernel
    else:
        d, e = M.diag.copy(), M.off.copy()
        d[0], e[0] = 1.0, 0.0  # node 0 decoupled: M_r on nodes 1.. plus an identity row
        sp = spike_factor(d, e, MIN_ROWS)
        del d, e
        # S X + G = dt^2 (F - K X); X = U + dt V + dt^2 / 2 A (node 0 set by the kernel)
        Sd, Slo = sp.to_lanes(-dt2 * K.diag), sp.lower_to_lanes(-dt2 * K.off)
        G = _load_to_lanes(sp, F, dt2)
        X = sp.to_lanes(U + dt * V + 0.5 * dt2 * A)
        k1, k2, kv = gamma + 0.5, 1.0, gamma / dt
        kernel = explicit_kernel
    Q = sp.to_lanes(dt * V + dt2 * (1.0 - gamma) * A)
    del A
    SloN = lane_zeros(L)  # S[i, i-1] of row 0's next lane, for row m-1
    SloN[: L - 1] = Slo[1:L]
    Dg, Dsrc, Ddst, X0pos, X0val = h_diagonals(sp)
    hw = lane_zeros(2 * L)
    hw[:] = sp.hw
    lanes = LaneOps(Sd, Slo, SloN, G, bool(np.any(F)), sp.factors(), Dg, Dsrc, Ddst, X0pos,
                    X0val, hw, float(sp.w0))
    upd = XQCoef(float(U[0]), k1, k2, kv, 1.0 / (beta * dt2) if beta > 0.0 else 0.0,
                 bool(semi.massless))
    k, done, min_u0, blow = kernel(
        bar_ops(semi), lanes, XQState(X, Q, sp.zeros(), sp.zeros()), np.zeros(2 * L),
        lane_zeros(4 * L), upd, run_spec(semi, dt, nsteps, stride), out)
    return trajectory(out, k, done, min_u0, blow, dt)


def _run_serial(semi: Semidiscrete, dt: float, nsteps: int, stride: int, beta: float,
                gamma: float, A: np.ndarray, out: Samples) -> tuple:
    """The serial kernels' factors (LAPACK dpttrf) and state (X, Q) in node order; returns
    the kernel's (samples, steps, min u0, blow-up step)."""
    bar, run = bar_ops(semi), run_spec(semi, dt, nsteps, stride)
    M, K, F = semi.M, semi.K, semi.F
    U, V = semi.U0, semi.V0
    dt2 = dt * dt
    Q = dt * V + dt2 * (1.0 - gamma) * A
    z, Vs = np.zeros(semi.nfree), np.zeros(semi.nfree)
    if beta > 0.0:
        bdt2 = beta * dt2
        df, ef = factor_pt(M.diag + bdt2 * K.diag, M.off + bdt2 * K.off)
        w = np.zeros(semi.nfree)
        w[0] = 1.0
        pt_solve(df, ef, w)
        X = U + dt * V + (0.5 - beta) * dt2 * A
        upd = XQCoef(float(U[0]), (gamma + 0.5 - beta) / beta, 1.0 / beta, gamma / (beta * dt),
                     1.0 / bdt2, bool(semi.massless))
        return serial_implicit(bar, ThomasImplicit(bdt2 * F, ef, 1.0 / df, w, float(w[0])),
                               XQState(X, Q, z, Vs), upd, run, out)
    d, e = M.diag.copy(), M.off.copy()
    d[0], e[0] = 1.0, 0.0  # node 0 decoupled: M_r on nodes 1.. plus an identity row
    df, ef = factor_pt(d, e)
    X = U + dt * V + 0.5 * dt2 * A
    solve = ThomasExplicit(-dt2 * K.diag, -dt2 * K.off, dt2 * F, ef, 1.0 / df)
    upd = XQCoef(float(U[0]), gamma + 0.5, 1.0, gamma / dt, 0.0, True)
    return serial_explicit(bar, solve, XQState(X, Q, z, Vs), upd, run, out)
