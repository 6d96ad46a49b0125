"""Doyen, Ern and Piperno's semi-explicit modified mass method (SIAM J. Sci. Comput. 33,
2011).

Central differences on a lumped (diagonal) mass whose contact dofs carry no inertia: the
contact nodes' lumped mass is moved to their neighbours off the contact zone, the total
mass kept (`contact_bench.api.fem.LUMPED_MASSLESS`; on a body `fem_nd.lumped_massless`).
The dofs with mass advance explicitly, one division by their mass each, no mass solve; the
massless ones are then solved at t_{n+1} from their own rows,
K_mm U_m = F_m - K_mh U_h + C^T lambda, with the contact exact: on the bar
u_0 = max(0, (F_0 - K_01 u_1) / K_00), on a body a small complementarity problem on the
Delassus matrix C K_mm^-1 C^T (computed once). The step limit is lumped central
differences' on the interior mass (about h / c on a uniform bar), computed from the
mesh's own eigenvalues (`contact_bench.kernels.semi_explicit`). Measurements:
docs/schemes.md.
"""

from __future__ import annotations

from contact_bench.api.fem import LUMPED_MASSLESS
from contact_bench.api.plugin import CallStepper, Contact, Energy, Family, Scheme, Stepper, Traits
from contact_bench.api.problem import BarScale, banded
from contact_bench.kernels.common import massless_drift_bound
from contact_bench.kernels.semi_explicit import bar_limit, body_limit, prepare_body, run_bar


class SemiExplicit(Scheme):
    name = "semi_explicit"
    summary = ("lumped mass with massless contact dofs, central differences, the massless "
               "dofs solved with exact contact (Doyen-Ern-Piperno)")

    def mass_kind(self) -> str:
        return LUMPED_MASSLESS

    def traits(self, problem=None) -> Traits:
        return Traits(implicit=False, massless_contact_node=True, contact=Contact.EXACT,
                      energy=Energy.CONSERVED, order=2, family=Family.MODIFIED_MASS)

    def stability_limit(self, problem) -> float | None:
        semi = banded(problem)
        if isinstance(semi, BarScale):  # a bar known by h and c alone: the uniform bar's
            return problem.hmin / problem.c_max  # lumped central differences, h / c
        return bar_limit(semi) if semi is not None else body_limit(problem)

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        semi = banded(problem)
        return None if semi is None else massless_drift_bound(semi, dt,
                                                              self.stability_limit(problem))

    def adds_time_load(self) -> bool:
        return True  # the body's kernel adds problem.load at each step's end

    def follows_curved_obstacle(self) -> bool:
        return True  # its sparse stepper re-linearises the gaps every step

    def prepare(self, problem, dt: float) -> Stepper:
        semi = banded(problem)
        if semi is not None:
            return CallStepper(lambda n, s: run_bar(semi, dt, n, s))
        return prepare_body(problem, dt)
