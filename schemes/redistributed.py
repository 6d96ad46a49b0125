"""The mass redistribution method (Dabaghi, Petrov, Pousin, Renard 2014).

The contact node carries no inertia, so the semi-discrete problem is the Lipschitz ODE
(P_U^mod): u0 = max(0, (F0 - K01 u1) / K00), and no impact law is needed. Time
integration is Newmark(beta, gamma); beta = 0 is the explicit central difference.

`variant` says where the first element's mass goes (`contact_bench.api.fem`):
`first_element_massless` (the paper's M^mod: the first element has no mass), `getfem`
(GetFEM's demo: M11 += M00 + M01) or `mass_conserving` (M11 += M00 + 2 M01, total mass
kept). The first step releases the first element's strain energy when node 0 starts out
of equilibrium; after that the energy moves only at switches of the contact status
(`massless_drift_bound`; measurements in docs/schemes.md).
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.fem import MASS_ALIASES, REDISTRIBUTED_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import Contact, Energy, Scheme, Semidiscrete, Traits, Trajectory
from contact_bench.kernels.common import massless_drift_bound
from contact_bench.kernels.newmark import BETA, GAMMA, newmark_limit, run_newmark
from contact_bench.kernels.sparse import newmark_sparse, quasistatic_sparse
from contact_bench.kernels.sparse_family import massless_ode_omega


class Redistributed(Scheme):
    name = "redistributed"
    summary = "massless contact node (mass redistribution), Newmark, exact contact"
    params = {
        "variant": Param("first_element_massless", "where the first element's mass goes",
                         choices=REDISTRIBUTED_KINDS, aliases=MASS_ALIASES),
        "beta": BETA,
        "gamma": GAMMA,
    }

    def mass_kind(self) -> str:
        return self.variant

    def traits(self) -> Traits:
        return Traits(implicit=self.beta > 0, massless_contact_node=True, contact=Contact.EXACT,
                      energy=Energy.DISSIPATED if self.gamma > 0.5 else Energy.CONSERVED,
                      order=2 if self.gamma == 0.5 else 1)

    def stability_limit(self, h: float, c: float) -> float | None:
        return newmark_limit(self.beta, self.gamma, h, c, lumped=False,
                             first_element_massless=self.variant == "first_element_massless")

    def energy_drift_bound(self, semi: Semidiscrete, dt: float) -> float | None:
        return massless_drift_bound(semi, dt, self.stability_limit(semi.hmin, semi.c_max))

    def newmark_parameters(self) -> tuple[float, float] | None:
        return self.beta, self.gamma

    def integrate(self, semi: Semidiscrete, dt: float, nsteps: int, stride: int) -> Trajectory:
        return run_newmark(semi, dt, nsteps, stride, self.beta, self.gamma)

    # the general sparse problem: the same Newmark step, exact contact on every contact
    # dof through the Delassus matrix (`contact_bench.kernels.sparse.newmark_sparse`)
    forms = frozenset({"banded1d", "sparse"})

    def sparse_stability_limit(self, problem) -> float | None:
        if self.beta > 0.0:
            return self.stability_limit(problem.hmin, problem.c_max)
        # explicit: the massless-contact ODE's own largest frequency, as ode_verlet's (the
        # 1D formula at the problem's hmin is too large in 2D and 3D: docs/sparse.md)
        return float(1.0 / (np.sqrt(self.gamma / 2.0) * massless_ode_omega(problem)))

    def integrate_sparse(self, problem, dt: float, nsteps: int, stride: int) -> Trajectory:
        if self.beta == 0.0:  # massless contact dofs solved from their rows
            return quasistatic_sparse(problem, dt, nsteps, stride, self.gamma)
        return newmark_sparse(problem, dt, nsteps, stride, self.beta, self.gamma)
