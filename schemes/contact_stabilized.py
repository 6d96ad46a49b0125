"""The contact-stabilized Newmark method (Deuflhard, Krause, Ertel 2008): Kane's step
(`schemes/kane.py`) after a predictor that projects U^n + h V^n onto the admissible set
in the mass norm (h = dt, S = M + h^2/4 K):

    U~      = argmin { |U - U^n - h V^n|_M : gap0 + C U >= 0 }
    U^{n+1} = argmin { 1/2 U.S.U - U.(M U~ - h^2/4 K U^n + h^2/2 F) : gap0 + C U >= 0 }
    V^{n+1} = B + 2 / h (U^{n+1} - U~)

B = (U~ - U^n) / h with `velocity=klapproth` (Klapproth, Schiela, Deuflhard's improved
variant, the default: the step is Kane's from a velocity of no larger M-norm, so the
energy never grows), B = V^n with `velocity=dke` (the 2008 paper; Utopia's
ContactStabilizedNewmark): no sign for its energy balance, declared "may grow" (no
growth measured). Both problems are LCPs on the Delassus matrices C M^-1 C^T and C S^-1
C^T (`contact_bench.kernels.kane`). Readings (docs/schemes.md): no acceleration term in
the predictor, as in the paper and Utopia; the reported contact force is the one the
velocity update feels over the step. Order 2 away from contact; class: exact. Friction
(Krause-Walloth): the projection stays normal, step 2 takes Coulomb's law on V^{n+1}
through the shared solver, bounded by mu times the whole normal impulse V^{n+1} feels
(Klapproth's: the predictor's too; `contact_bench.kernels.kane.kane_friction_step`).
"""

from __future__ import annotations

from contact_bench.api.params import Param
from contact_bench.api.plugin import Contact, Energy, Family, Scheme, Stepper, Traits
from contact_bench.api.problem import as_problem, banded
from contact_bench.kernels.kane import prepare_kane, prepare_kane_banded


class ContactStabilized(Scheme):
    name = "contact_stabilized"
    summary = ("contact-stabilized Newmark: Kane's step after an M-projected predictor "
               "(Deuflhard, Krause, Ertel 2008)")
    params = {
        "velocity": Param("klapproth", "velocity update: dke (V^n + 2/h (U - U~)) or "
                          "klapproth ((U~ - U^n)/h + 2/h (U - U~))",
                          choices=("klapproth", "dke")),
        "mass": Param("consistent", "mass matrix (contact_bench.api.fem; mass on every dof)",
                      choices=("consistent", "lumped")),
    }

    def mass_kind(self) -> str:
        return self.mass

    def traits(self, problem=None) -> Traits:
        energy = Energy.DISSIPATED if self.velocity == "klapproth" else Energy.MAY_GROW
        return Traits(implicit=True, massless_contact_node=False, contact=Contact.EXACT,
                      energy=energy, order=2, family=Family.EXACT, friction=True)

    def stability_limit(self, problem) -> float | None:
        return None  # the trapezoidal rule: unconditionally stable

    def follows_curved_obstacle(self) -> bool:
        return True  # its sparse stepper re-linearises the gaps every step

    def adds_time_load(self) -> bool:
        # the body's trapezoidal step adds the mean of its values at t_n and t_{n+1}
        return True

    def prepare(self, problem, dt: float) -> Stepper:
        predictor = "projected_klapproth" if self.velocity == "klapproth" else "projected"
        semi = banded(problem)  # the bar: its tridiagonal kernel; a body: the sparse one
        if semi is not None:
            return prepare_kane_banded(semi, dt, predictor)
        return prepare_kane(as_problem(problem, self.mass), dt, predictor)
