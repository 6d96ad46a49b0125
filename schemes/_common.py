"""Numba building blocks shared by the stepping kernels, and the Python glue around them.

Kernels are plain `@njit(cache=True)` functions over numpy arrays. Tridiagonal
symmetric matrices travel as (diag, off). Factorisations are done by LAPACK through
scipy (`dpttrf`: A = L D L^T) outside the hot loop; the loop only applies them.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numba import njit
from scipy.linalg import lapack

from bench.errors import BenchError
from bench.fem import MASSLESS_KINDS
from bench.plugin import Scheme, Semidiscrete, Trajectory

BLOWUP_FACTOR = 1e3  # energy above this multiple of E(0) counts as a blow-up


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
def newmark_update(rhs, mu, w, pin0, Ut, U, V, A, dt, bdt2, gamma, massless
                   ):  # pragma: no cover - compiled
    """The end of an implicit Newmark-family step in one pass over the nodes: U1 = rhs +
    mu w (node 0 set to 0 if pin0: an active exact contact), A1 = (U1 - U~) / (beta
    dt^2), V += dt ((1 - gamma) A + gamma A1), a massless node 0's velocity the backward
    difference and its acceleration 0; U, V, A overwritten."""
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


@njit(cache=True)
def tri_quad(d, e, x):
    """x^T A x."""
    s = 0.0
    n = d.size
    for i in range(n):
        s += d[i] * x[i] * x[i]
    for i in range(n - 1):
        s += 2.0 * e[i] * x[i] * x[i + 1]
    return s


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


@njit(cache=True)
def energy_of(Md, Me, Kd, Ke, F, U, V, offset):
    """1/2 V.M.V + 1/2 U.K.U - F.U + offset."""
    s = 0.0
    for i in range(U.size):
        s -= F[i] * U[i]
    return 0.5 * tri_quad(Md, Me, V) + 0.5 * tri_quad(Kd, Ke, U) + s + offset


@njit(cache=True)
def record_sample(k, t, U, V, stress, energy, t_out, U_out, V_out, cu_out, s_out, E_out):
    """Write sample k: time, nodal U and V, u(0, t), contact stress, energy."""
    t_out[k] = t
    U_out[k, :] = U
    V_out[k, :] = V
    cu_out[k] = U[0]
    s_out[k] = stress
    E_out[k] = energy


@njit(cache=True)
def is_sample(step, nsteps, stride):
    return step % stride == 0 or step == nsteps


@njit(cache=True)
def blown_up(energy, energy0):
    if not np.isfinite(energy):
        return True
    return abs(energy) > BLOWUP_FACTOR * max(abs(energy0), 1e-300)


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


def n_samples(nsteps: int, stride: int) -> int:
    return nsteps // stride + 1 + (1 if nsteps % stride else 0)


def allocate(semi: Semidiscrete, nsteps: int, stride: int) -> dict[str, np.ndarray]:
    """Output buffers of a kernel; memory grows with nfree x samples only."""
    k = n_samples(nsteps, stride)
    n = semi.nfree
    return {
        "t": np.zeros(k), "U": np.zeros((k, n)), "V": np.zeros((k, n)),
        "cu": np.zeros(k), "s": np.zeros(k), "E": np.zeros(k),
    }


def trajectory(out: dict[str, np.ndarray], nsample: int, steps_done: int, min_u0: float,
               blowup_step: int, dt: float, **extra) -> Trajectory:
    """Wrap kernel buffers (trimmed to the samples actually written)."""
    k = nsample
    return Trajectory(
        t=out["t"][:k], U=out["U"][:k], V=out["V"][:k], contact_u=out["cu"][:k],
        stress=out["s"][:k], energy=out["E"][:k], min_contact_u=float(min_u0),
        steps_done=int(steps_done),
        blowup_time=None if blowup_step < 0 else float(blowup_step * dt), extra=extra,
    )


def initial_acceleration(semi: Semidiscrete) -> np.ndarray:
    """Solve M A0 = F - K U0 (on nodes 1.. when the contact node is massless)."""
    r = semi.F - semi.K.matvec(semi.U0)
    A = np.zeros(semi.nfree)
    first = 1 if semi.massless else 0
    df, ef = factor_pt(semi.M.diag[first:], semi.M.off[first:])
    b = r[first:].copy()
    pt_solve(df, ef, b)
    A[first:] = b
    return A


def velocity_scale(semi: Semidiscrete) -> float:
    """A speed the data can give the contact node: max|v0| + c max|u0'| + sqrt(2 g H).

    d'Alembert bounds |u_t| by max|v0| + c max|u0_x| without gravity; a free fall from
    the highest initial point H adds sqrt(2 g H). Schemes that allow a penetration of
    O(dt x impact speed) use it (times a safety factor) in `penetration_bound`.
    """
    U = semi.full(semi.U0)
    slope = float(np.max(np.abs(np.diff(U) / semi.h))) if U.size > 1 else 0.0
    v = float(np.max(np.abs(semi.V0))) + semi.c_max * slope
    n = semi.nfree
    if n >= 3:
        i = n // 2  # an interior row: its mass row sum is complete
        row = semi.M.matvec(np.ones(n))[i]
        g = max(0.0, -float(semi.F[i]) / row) if row > 0 else 0.0
        v += float(np.sqrt(2.0 * g * max(0.0, float(np.max(U)))))
    return v


# fastmath=False explicitly: a numba callee with no fastmath setting takes its caller's, and
# a contracted K00 u0 + K01 u1 - F0 leaves a round-off lambda != 0 on a free node
@njit(cache=True, fastmath=False)
def eliminate_contact_node(Kd, Ke, F, U, p1=1):
    """Set U[0] = max(0, (F0 - K01 u1) / K00), the massless node of (P_U^mod); return lambda.

    u1 = U[p1] (node 1's position: 1 in node order, another in the interleaved layout
    of `schemes._spike`). lambda = K00 u0 + K01 u1 - F0 >= 0 is the obstacle's force
    (the contact stress is -lambda); it is 0 when the node is free.
    """
    u1 = U[p1]
    u0 = (F[0] - Ke[0] * u1) / Kd[0]
    U[0] = u0 if u0 > 0.0 else 0.0
    return Kd[0] * U[0] + Ke[0] * u1 - F[0]


def central_difference_excess(dt: float, limit: float | None) -> float:
    """Largest relative excess of 1/2 V.M.V + 1/2 U.K.U over its initial value that a
    central-difference (Newmark beta = 0, gamma = 1/2) run may show with no contact.

    The scheme conserves E~ = 1/2 V.(M - dt^2/4 K).V + 1/2 U.K.U exactly, and
    dt^2/8 V.K.V <= r^2 1/2 V.M.V with r = dt / limit (limit = 2 / omega_max), so
    E(t) <= E(0) / (1 - r^2): the excess is at most r^2 / (1 - r^2).
    """
    if limit is None:
        return 0.0
    r = dt / limit
    return float("inf") if r >= 1.0 else r * r / (1.0 - r * r)


class MassiveContactNodeScheme(Scheme):
    """A scheme whose impact law needs inertia at the contact node.

    Its `mass` parameter refuses the massless kinds at construction (one-line
    BenchError with `massless_reason`), and `integrate` refuses a massless problem.
    """

    massless_reason: ClassVar[str] = ""

    def validate(self) -> None:
        if self.mass in MASSLESS_KINDS:
            raise BenchError(f"{self.spec}: {self.massless_reason}")

    def mass_kind(self) -> str:
        return self.mass

    def check_massive(self, semi: Semidiscrete) -> None:
        if semi.massless:
            raise BenchError(self.massless_reason)
