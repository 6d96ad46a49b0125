"""Python glue shared by the scheme plugins: output buffers, the trajectory, the initial
acceleration, velocity scales and the energy bounds that schemes declare.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from contact_bench.api.fem import MASSLESS_KINDS
from contact_bench.api.plugin import Scheme, Semidiscrete, Trajectory
from contact_bench.core.errors import BenchError
from contact_bench.core.sampling import Run, Samples, n_samples
from contact_bench.core.tridiag import Bar, factor_pt, pt_solve


def allocate(semi: Semidiscrete, nsteps: int, stride: int) -> Samples:
    """Output buffers of a kernel; memory grows with nfree x samples only."""
    k = n_samples(nsteps, stride)
    n = semi.nfree
    return Samples(t=np.zeros(k), U=np.zeros((k, n)), V=np.zeros((k, n)), cu=np.zeros(k),
                   stress=np.zeros(k), energy=np.zeros(k))


def bar_ops(semi: Semidiscrete) -> Bar:
    """The bar's tridiagonal M, K and load F, as the compiled kernels take them."""
    M, K = semi.M, semi.K
    return Bar(M.diag, M.off, K.diag, K.off, semi.F)


def run_spec(semi: Semidiscrete, dt: float, nsteps: int, stride: int) -> Run:
    """A kernel's `Run`: dt, nsteps, stride (typed as the kernels are compiled for) and
    the bar's energy offset."""
    return Run(float(dt), int(nsteps), int(stride), float(semi.energy_offset))


def trajectory(out: Samples, nsample: int, steps_done: int, min_u0: float,
               blowup_step: int, dt: float, **extra) -> Trajectory:
    """Wrap kernel buffers (trimmed to the samples actually written)."""
    k = nsample
    return Trajectory(
        t=out.t[:k], U=out.U[:k], V=out.V[:k], contact_u=out.cu[:k],
        stress=out.stress[:k], energy=out.energy[:k], min_contact_u=float(min_u0),
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


def massless_drift_bound(semi: Semidiscrete, dt: float, limit: float | None = None) -> float:
    """Declared bound on max |E(t) - E(0)| / |E(0)| with a massless contact node.

    Three parts. (1) The first step moves the massless node to equilibrium with node 1
    and releases the first element's initial strain energy (computed exactly here),
    up to a factor 1 + O(CFL^2). (2) At each switch of the contact status the
    Crank-Nicolson balance is off by (u0^{n+1} lam^n - u0^n lam^{n+1}) / 2; declared:
    4 c dt / L, an empirical bound (how it was measured: docs/schemes.md) that grows
    with the number of impacts in the run. (3) For the explicit variant (`limit`
    given), the central difference's own excess r^2 / (1 - r^2), r = dt / limit
    (`central_difference_excess`).
    """
    U0, V0 = semi.U0, semi.V0
    e0 = abs(0.5 * semi.M.quad(V0) + 0.5 * semi.K.quad(U0) - semi.F @ U0 + semi.energy_offset)
    release = 0.5 * (-semi.K.off[0]) * (U0[1] - U0[0]) ** 2 / max(e0, 1e-300)
    cfl = semi.c_max * dt / semi.hmin
    length = float(semi.x[-1] - semi.x[0])
    return float(release * (1.0 + cfl**2) + 4.0 * semi.c_max * dt / length
                 + central_difference_excess(dt, limit))
