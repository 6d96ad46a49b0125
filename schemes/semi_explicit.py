"""Doyen, Ern and Piperno's semi-explicit modified mass method (SIAM J. Sci. Comput. 33,
2011, and their semi-explicit paper).

The modified mass takes the inertia off the contact dofs (the suite's redistributed
masses, `variant`). The dofs with mass advance by the central difference, explicitly;
the massless ones are then solved at t_{n+1} from their own rows,
K_mm U_m = F_m - K_mh U_h + C^T lambda, with the contact exact: a small complementarity
problem on the contact dofs (Delassus matrix C K_mm^-1 C^T, computed once). The step
limit is the central difference's on the mass with massless contact dofs.

Reading: the central difference in its Newmark(0, 1/2) form (same displacements), on the
suite's redistributed masses; the paper lumps the interior mass, the suite has no lumped
redistributed mass, so the interior mass is solved with its factor. Algebraically this
is `redistributed[beta=0]` (the bar's banded kernel, a body's `prepare_quasistatic`);
the scheme names the published method and its class. Details: docs/schemes.md.
"""

from __future__ import annotations

from contact_bench.api.fem import MASS_ALIASES, REDISTRIBUTED_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import CallStepper, Contact, Energy, Family, Scheme, Stepper, Traits
from contact_bench.api.problem import banded
from contact_bench.kernels.common import massless_drift_bound
from contact_bench.kernels.newmark import newmark_limit, run_newmark
from contact_bench.kernels.sparse import prepare_quasistatic
from contact_bench.kernels.sparse_family import massless_ode_omega


class SemiExplicit(Scheme):
    name = "semi_explicit"
    summary = ("modified mass, central differences, massless contact dofs solved by an LCP "
               "(Doyen-Ern-Piperno)")
    params = {
        "variant": Param("first_element_massless", "the modified (redistributed) mass",
                         choices=REDISTRIBUTED_KINDS, aliases=MASS_ALIASES),
    }

    def mass_kind(self) -> str:
        return self.variant

    def traits(self, problem=None) -> Traits:
        return Traits(implicit=False, massless_contact_node=True, contact=Contact.EXACT,
                      energy=Energy.CONSERVED, order=2, family=Family.MODIFIED_MASS)

    def stability_limit(self, problem) -> float | None:
        if banded(problem) is None:
            # a body: 2 / omega_max of the mass with the massless dofs eliminated, in the
            # stiffest contact state (`massless_ode_omega`)
            return float(2.0 / massless_ode_omega(problem))
        return newmark_limit(0.0, 0.5, problem.hmin, problem.c_max, lumped=False,
                             first_element_massless=self.variant == "first_element_massless")

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        semi = banded(problem)
        return None if semi is None else massless_drift_bound(semi, dt,
                                                              self.stability_limit(problem))

    def prepare(self, problem, dt: float) -> Stepper:
        semi = banded(problem)
        if semi is not None:
            return CallStepper(lambda n, s: run_newmark(semi, dt, n, s, 0.0, 0.5))
        return prepare_quasistatic(problem, dt, 0.5)

