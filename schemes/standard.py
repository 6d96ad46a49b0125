"""The standard scheme: consistent mass, Newmark, contact enforced exactly at t_{n+1}.

The starting point of Dabaghi, Petrov, Pousin, Renard (2014, section 5): with a massive
contact node the impact is an instantaneous inelastic shock of that node, so the energy
jumps at impacts (it grows, their Fig. 5.3 left) and the contact stress oscillates
(Fig. 5.1-5.2 left). No convergence order is claimed with a massive contact node
(measurements: docs/schemes.md).

`mass` picks the mass matrix (`contact_bench.api.fem`). With a massless contact node
(first_element_massless, getfem, mass_conserving, singular) this is the `redistributed`
scheme, with its energy behaviour and drift bound.
"""

from __future__ import annotations

from contact_bench.api.fem import MASS_ALIASES, MASS_KINDS, MASSLESS_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import CallStepper, Contact, Energy, Scheme, Stepper, Traits
from contact_bench.api.problem import banded
from contact_bench.kernels.common import massless_drift_bound
from contact_bench.kernels.newmark import GAMMA, newmark_limit, run_newmark
from contact_bench.kernels.sparse import prepare_newmark


class Standard(Scheme):
    name = "standard"
    summary = "consistent mass, Newmark, exact contact (Lagrange multiplier at t_{n+1})"
    params = {
        "beta": Param(0.25, "Newmark beta (> 0: implicit)", low=0.0, high=0.5, low_open=True),
        "gamma": GAMMA,
        "mass": Param("consistent", "mass matrix (contact_bench.api.fem)", choices=MASS_KINDS,
                      aliases=MASS_ALIASES),
    }

    def mass_kind(self) -> str:
        return self.mass

    def traits(self, problem=None) -> Traits:
        massless = self.mass in MASSLESS_KINDS
        energy = ((Energy.DISSIPATED if self.gamma > 0.5 else Energy.CONSERVED) if massless
                  else Energy.MAY_GROW)
        order = (2 if self.gamma == 0.5 else 1) if massless else None  # see the docstring
        return Traits(implicit=True, massless_contact_node=massless, contact=Contact.EXACT,
                      energy=energy, order=order, friction=True)

    def stability_limit(self, problem) -> float | None:
        return newmark_limit(self.beta, self.gamma, problem.hmin, problem.c_max,
                             lumped=self.mass == "lumped")

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        if self.mass not in MASSLESS_KINDS or banded(problem) is None:
            return None
        return massless_drift_bound(banded(problem), dt, self.stability_limit(problem))

    def newmark_parameters(self) -> tuple[float, float] | None:
        return self.beta, self.gamma

    def cannot_run(self, case) -> str | None:
        if case.form == "sparse" and self.beta == 0.0:
            return "the explicit (beta = 0) step has no sparse path yet"
        return None

    def adds_time_load(self) -> bool:
        return True  # the sparse Newmark stepper adds it

    def follows_curved_obstacle(self) -> bool:
        return True  # its sparse stepper re-linearises the gaps every step

    def prepare(self, problem, dt: float) -> Stepper:
        # the bar: the banded Newmark kernel; a body: the same step, exact contact on
        # every contact dof through the Delassus matrix (`contact_bench.kernels.sparse`)
        semi = banded(problem)
        if semi is not None:
            return CallStepper(lambda n, s: run_newmark(semi, dt, n, s, self.beta, self.gamma))
        return prepare_newmark(problem, dt, self.beta, self.gamma)
