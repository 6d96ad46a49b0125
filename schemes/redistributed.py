"""The mass redistribution method (Dabaghi, Petrov, Pousin, Renard 2014).

The contact node carries no inertia, so the semi-discrete problem is the Lipschitz
ODE (P_U^mod): u0 = max(0, (F0 - K01 u1) / K00) and no impact law is needed. Time
integration is Newmark(beta, gamma); beta = 0 is the explicit central difference.

Variants of the mass (`variant`, see `contact_bench.api.fem`): `seed` (the paper's M^mod, the
first element has no mass), `getfem` (GetFEM's demo: M11 += M00 + M01) and
`conservative` (M11 += M00 + 2 M01, total mass kept).

Energy. When the initial contact node is not in equilibrium with node 1 (the clamped
bar: a strained first element), the first step moves the massless node there and
releases the first element's strain energy, h/8 on the clamped bar (a relative drop
of h; measured (1 + O(CFL^2)) h/8). After that, with beta = 1/4, gamma = 1/2, the
energy is constant to round-off between switches of the contact status; at a switch
the Crank-Nicolson balance E^{n+1} - E^n = (u0^{n+1} lam^n - u0^n lam^{n+1}) / 2 is
not zero. Measured on clamped_bar, T = 12 (max |E - E(dt)| / E(dt), getfem variant):
1.3e-4 at nx = 80, dt = 0.002; 3.2e-5 at dt = 0.001; below 1e-4 for CFL <= 0.1 at
nx = 40 ... 320 (tests/test_foundation.py checks CFL 0.08).
"""

from __future__ import annotations

from contact_bench.api.params import Param
from contact_bench.api.plugin import Scheme, Semidiscrete, Traits, Trajectory
from contact_bench.kernels.common import massless_drift_bound
from contact_bench.kernels.newmark import BETA, GAMMA, newmark_limit, run_newmark
from contact_bench.kernels.sparse import newmark_sparse, quasistatic_sparse


class Redistributed(Scheme):
    name = "redistributed"
    summary = "massless contact node (mass redistribution), Newmark, exact contact"
    params = {
        "variant": Param("seed", "where the first element's mass goes",
                         choices=("seed", "getfem", "conservative")),
        "beta": BETA,
        "gamma": GAMMA,
    }

    def mass_kind(self) -> str:
        return self.variant

    def traits(self) -> Traits:
        return Traits(implicit=self.beta > 0, massless_contact_node=True, contact="exact",
                      energy="dissipated" if self.gamma > 0.5 else "conserved",
                      order=2 if self.gamma == 0.5 else 1)

    def stability_limit(self, h: float, c: float) -> float | None:
        return newmark_limit(self.beta, self.gamma, h, c, lumped=False)

    def energy_drift_bound(self, semi: Semidiscrete, dt: float) -> float | None:
        return massless_drift_bound(semi, dt, self.stability_limit(semi.hmin, semi.c_max))

    def integrate(self, semi: Semidiscrete, dt: float, nsteps: int, stride: int) -> Trajectory:
        return run_newmark(semi, dt, nsteps, stride, self.beta, self.gamma)

    # the general sparse problem: the same Newmark step, exact contact on every contact
    # dof through the Delassus matrix (`contact_bench.kernels.sparse.newmark_sparse`)
    forms = frozenset({"banded1d", "sparse"})

    def integrate_sparse(self, problem, dt: float, nsteps: int, stride: int) -> Trajectory:
        if self.beta == 0.0:  # massless contact dofs solved from their rows
            return quasistatic_sparse(problem, dt, nsteps, stride, self.gamma)
        return newmark_sparse(problem, dt, nsteps, stride, self.beta, self.gamma)
