"""Kane, Repetto, Ortiz, Marsden (1999): the trapezoidal rule (Newmark beta = 1/4,
gamma = 1/2) for the internal and external forces, the contact force fully implicit at
t_{n+1}. With h = dt and a_el = M^-1 (F - K U) the elastic acceleration:

    U^{n+1} = U^n + h V^n + h^2/4 (a_el^n + a_el^{n+1}) + h^2/2 M^-1 C^T lambda^{n+1}
    V^{n+1} = 2 (U^{n+1} - U^n) / h - V^n,  0 <= lambda^{n+1} _|_ gap0 + C U^{n+1} >= 0

The contact force acts over its own step only: it never enters the next predictor (in
`standard` it does, through the acceleration). One solve with S = M + h^2/4 K and exact
contact on the Delassus matrix per step, lambda = 2 mu / h^2 (`contact_bench.kernels.
kane`: the bar's tridiagonal kernel, a body's sparse one).

Energy: the contact force adds -lambda^{n+1}.(gap0 + C U^n) <= 0 per step to the
trapezoidal rule's balance: it never gains energy. Order 2 away from impacts. Reading:
Kane et al. move the contact force's weight to t_{n+1} for any Newmark (beta, gamma);
the comparisons (Deuflhard-Krause-Ertel 2008, Doyen-Ern-Piperno 2011, who class it with
exact enforcement) use beta = 1/4, gamma = 1/2, implemented here (docs/schemes.md).
"""

from __future__ import annotations

from contact_bench.api.params import Param
from contact_bench.api.plugin import Contact, Energy, Family, Scheme, Stepper, Traits
from contact_bench.api.problem import as_problem, banded
from contact_bench.kernels.kane import prepare_kane, prepare_kane_banded


class Kane(Scheme):
    name = "kane"
    summary = "trapezoidal rule, contact force fully implicit at t_{n+1} (Kane et al. 1999)"
    params = {
        "mass": Param("consistent", "mass matrix (contact_bench.api.fem; mass on every dof)",
                      choices=("consistent", "lumped")),
    }

    def mass_kind(self) -> str:
        return self.mass

    def traits(self, problem=None) -> Traits:
        return Traits(implicit=True, massless_contact_node=False, contact=Contact.EXACT,
                      energy=Energy.DISSIPATED, order=2, family=Family.EXACT)

    def stability_limit(self, problem) -> float | None:
        return None  # the trapezoidal rule: unconditionally stable

    def follows_curved_obstacle(self) -> bool:
        return True  # its sparse stepper re-linearises the gaps every step

    def adds_time_load(self) -> bool:
        # the body's trapezoidal step adds the mean of its values at t_n and t_{n+1}
        return True

    def prepare(self, problem, dt: float) -> Stepper:
        semi = banded(problem)  # the bar: its tridiagonal kernel; a body: the sparse one
        if semi is not None:
            return prepare_kane_banded(semi, dt, "none")
        return prepare_kane(as_problem(problem, self.mass), dt, "none")
