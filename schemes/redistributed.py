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
from contact_bench.api.plugin import CallStepper, Contact, Energy, Scheme, Stepper, Traits
from contact_bench.api.problem import banded
from contact_bench.kernels.common import massless_drift_bound
from contact_bench.kernels.newmark import BETA, GAMMA, newmark_limit, run_newmark
from contact_bench.kernels.sparse import prepare_newmark, prepare_quasistatic
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

    def traits(self, problem=None) -> Traits:
        return Traits(implicit=self.beta > 0, massless_contact_node=True, contact=Contact.EXACT,
                      energy=Energy.DISSIPATED if self.gamma > 0.5 else Energy.CONSERVED,
                      order=2 if self.gamma == 0.5 else 1, friction=self.beta > 0)

    def stability_limit(self, problem) -> float | None:
        if self.beta == 0.0 and banded(problem) is None:
            # explicit on a body: the massless-contact ODE's own largest frequency, as
            # ode_verlet's (the 1D formula at the problem's hmin is too large in 2D and
            # 3D: docs/sparse.md)
            return float(1.0 / (np.sqrt(self.gamma / 2.0) * massless_ode_omega(problem)))
        return newmark_limit(self.beta, self.gamma, problem.hmin, problem.c_max, lumped=False,
                             first_element_massless=self.variant == "first_element_massless")

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        semi = banded(problem)
        return None if semi is None else massless_drift_bound(semi, dt,
                                                              self.stability_limit(problem))

    def newmark_parameters(self) -> tuple[float, float] | None:
        return self.beta, self.gamma

    def adds_time_load(self) -> bool:
        # the body's steppers add it: Newmark's equation at t_{n+1} (beta > 0: with the
        # predictor, the trapezoidal mean of t_n and t_{n+1}); beta = 0, at t_{n+1}
        return True

    def follows_curved_obstacle(self) -> bool:
        return True  # its sparse stepper re-linearises the gaps every step

    def prepare(self, problem, dt: float) -> Stepper:
        # the bar: the banded Newmark kernel; a body: the same Newmark step, exact contact
        # on every contact dof through the Delassus matrix, or (beta = 0) the massless
        # contact dofs solved from their rows (`contact_bench.kernels.sparse`)
        semi = banded(problem)
        if semi is not None:
            return CallStepper(lambda n, s: run_newmark(semi, dt, n, s, self.beta, self.gamma))
        if self.beta == 0.0:
            return prepare_quasistatic(problem, dt, self.gamma)
        return prepare_newmark(problem, dt, self.beta, self.gamma)
