"""Hilber-Hughes-Taylor (HHT-alpha) with the contact enforced exactly at t_{n+1}.

    M A1 + (1 + alpha) K U1 - alpha K U0 = F + lambda e0,   U1[0] >= 0 _|_ lambda >= 0
    U1 = U0 + dt V0 + dt^2 ((1/2 - beta) A0 + beta A1),  V1 = V0 + dt ((1 - gamma) A0 + gamma A1)

with alpha in [-1/3, 0], beta = (1 - alpha)^2 / 4, gamma = 1/2 - alpha (alpha = 0 is
Crank-Nicolson, the `standard` scheme). S = M + (1 + alpha) beta dt^2 K is factored
once and the contact uses w = S^-1 e0 as in `contact_bench.kernels.newmark`; the
sampled stress is -lambda. Unconditionally stable for the linear problem, with
numerical damping of the high frequencies that grows with |alpha|.

Energy: dissipated with a massless contact node (the default mass); with a massive one
the exact contact at t_{n+1} is an inelastic shock of that node, as in `standard`, and
the energy may grow at impacts despite the damping.

On the general sparse problem the same step with exact contact on every contact dof
through the Delassus matrix (`contact_bench.kernels.sparse.newmark_sparse` with
`alpha`); the redistributed masses map to the scene's massless contact dofs.
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.fem import MASS_ALIASES, MASS_KINDS, MASSLESS_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import (
    CallStepper,
    Contact,
    Energy,
    Scheme,
    Stepper,
    Traits,
    Trajectory,
)
from contact_bench.api.problem import banded
from contact_bench.core.tridiag import BarState, Implicit, NewmarkCoef, factor_pt, pt_solve
from contact_bench.kernels.common import (
    allocate,
    bar_ops,
    initial_acceleration,
    massless_drift_bound,
    run_spec,
    trajectory,
)
from contact_bench.kernels.hht import hht_kernel
from contact_bench.kernels.sparse import prepare_newmark


class HHT(Scheme):
    name = "hht"
    summary = "Hilber-Hughes-Taylor alpha (dissipative Newmark family), exact contact"
    params = {
        "alpha": Param(-0.1, "HHT alpha: beta = (1-alpha)^2/4, gamma = 1/2 - alpha",
                       low=-1.0 / 3.0, high=0.0),
        "mass": Param("first_element_massless", "mass matrix (contact_bench.api.fem)",
                      choices=MASS_KINDS, aliases=MASS_ALIASES),
    }

    @property
    def beta(self) -> float:
        return (1.0 - self.alpha) ** 2 / 4.0

    @property
    def gamma(self) -> float:
        return 0.5 - self.alpha

    def mass_kind(self) -> str:
        return self.mass

    def traits(self, problem=None) -> Traits:
        massless = self.mass in MASSLESS_KINDS
        return Traits(implicit=True, massless_contact_node=massless, contact=Contact.EXACT,
                      energy=Energy.DISSIPATED if massless and self.alpha < 0 else
                      (Energy.CONSERVED if massless else Energy.MAY_GROW),
                      order=2)

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        semi = banded(problem)
        return (massless_drift_bound(semi, dt)
                if self.mass in MASSLESS_KINDS and semi is not None else None)

    def adds_time_load(self) -> bool:
        return True  # the sparse Newmark stepper adds it

    def follows_curved_obstacle(self) -> bool:
        return True  # its sparse stepper re-linearises the gaps every step

    def prepare(self, problem, dt: float) -> Stepper:
        # a body: `contact_bench.kernels.sparse.newmark_sparse` with alpha
        semi = banded(problem)
        if semi is not None:
            return CallStepper(lambda n, s: self.run_bar(semi, dt, n, s))
        return prepare_newmark(problem, dt, self.beta, self.gamma, alpha=float(self.alpha))

    def run_bar(self, semi, dt: float, nsteps: int, stride: int) -> Trajectory:
        """The bar's HHT step on the tridiagonal bands (`hht_kernel`)."""
        M, K = semi.M, semi.K
        dt = float(dt)
        beta, gamma, alpha = self.beta, self.gamma, float(self.alpha)
        s = (1.0 + alpha) * beta * dt * dt
        Sd, Se = factor_pt(M.diag + s * K.diag, M.off + s * K.off)
        w = np.zeros(semi.nfree)
        w[0] = 1.0
        pt_solve(Sd, Se, w)
        U, V = semi.U0.copy(), semi.V0.copy()
        A = initial_acceleration(semi)
        out = allocate(semi, nsteps, stride)
        k, done, min_u0, blow = hht_kernel(
            bar_ops(semi), Implicit(Sd, Se, w), BarState(U, V, A), alpha,
            NewmarkCoef(beta, gamma, bool(semi.massless)), run_spec(semi, dt, nsteps, stride),
            out)
        return trajectory(out, k, done, min_u0, blow, dt)

