"""Penalized contact: the obstacle pushes back with kappa min(0, u(0)), kappa = gamma_p E / h.

h is the first element's length and E the Young modulus there. The contact is violated
by O(1/kappa) (the end penetrates about |sigma| / kappa), and the spring's energy
kappa/2 min(0, u0)^2 is part of the sampled energy.

Time integration: Newmark(beta, gamma), in the shared boundary-contact kernel
(`contact_bench.kernels.boundary`). Implicit (beta > 0): each step is piecewise linear
in u0 and solved exactly. Explicit (beta = 0): central differences; the spring stiffens
the first element, and the stability limit uses that element's eigenvalue with the
spring (`element_limit`). With a massless contact node the node and its spring are
static (a softer first element): energy as `redistributed`. The penetration bound
follows from the energy (at most twice its initial value, which the property test
checks): kappa/2 d^2 <= W + g m d. Friction (implicit; 2D and 3D, the circular cone): a
tangential spring kappa on the slip with Coulomb's return map
(`newmark_penalty_friction_step`). Details: docs/schemes.md.
"""

from __future__ import annotations

import math

import numpy as np

from contact_bench.api.fem import MASS_ALIASES, MASS_KINDS, MASSLESS_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import CallStepper, Contact, Energy, Scheme, Stepper, Traits
from contact_bench.api.problem import banded
from contact_bench.kernels.boundary import bar_law, element_limit, energy_budget, run_boundary_law
from contact_bench.kernels.common import massless_drift_bound
from contact_bench.kernels.newmark import BETA, GAMMA
from contact_bench.kernels.sparse import ContactLaw, prepare_newmark
from contact_bench.kernels.sparse_explicit import penalty_law, prepare_explicit_law, stable_dt


class Penalty(Scheme):
    name = "penalty"
    summary = "penalty force kappa min(0, u0), kappa = gamma_p E / h; Newmark (beta 0: explicit)"
    params = {
        "gamma_p": Param(1.0, "penalty parameter: kappa = gamma_p E / h", low=0.0, low_open=True,
                         high=1e8, sweep=(1.0, 1e2, 1e4, 1e6, 1e8)),
        "mass": Param("consistent", "mass matrix (contact_bench.api.fem)", choices=MASS_KINDS,
                      aliases=MASS_ALIASES),
        "beta": BETA,
        "gamma": GAMMA,
    }

    def mass_kind(self) -> str:
        return self.mass

    def traits(self, problem=None) -> Traits:
        massless = self.mass in MASSLESS_KINDS
        return Traits(implicit=self.beta > 0, massless_contact_node=massless,
                      contact=Contact.PENALTY,
                      energy=(Energy.DISSIPATED if self.gamma > 0.5 else Energy.CONSERVED)
                      if massless else Energy.MAY_GROW,
                      order=2 if self.gamma == 0.5 else 1, friction=self.beta > 0)

    def kappa(self, problem) -> float:
        """The bar's spring, gamma_p E / h at the contact node."""
        semi = banded(problem)
        return self.gamma_p * semi.E_contact / float(semi.h[0])

    def spring_stiffnesses(self, problem) -> np.ndarray:
        """A body's springs: kappa w_i on each contact point (w_i its share of the zone's
        area), kappa = gamma_p E / h at the zone."""
        if not (problem.E_contact > 0 and problem.h_contact > 0):
            raise ValueError("penalty needs the problem's E_contact and h_contact")
        return self.gamma_p * problem.E_contact / problem.h_contact * problem.contact.weights

    def contact_law(self, problem) -> ContactLaw:
        """The springs as a piecewise-linear `ContactLaw` (force kappa_i max(0, -g_i))."""
        semi = banded(problem)
        if semi is not None:
            kappa = self.kappa(semi)
            return bar_law(semi.nfree, np.zeros((2, 2)), kappa, (1.0, 0.0), (1.0, 0.0), 1.0,
                           kappa)
        return penalty_law(problem, self.spring_stiffnesses(problem))

    def stability_limit(self, problem) -> float | None:
        if banded(problem) is not None:
            extra = np.array([[self.gamma_p, 0.0], [0.0, 0.0]])
            return element_limit(self.beta, self.gamma, problem.hmin, problem.c_max,
                                 self.mass, extra)
        # a body: the springs' eigenvalues on this mesh (the 1D element formula does not
        # bound those of 2D/3D elements): `contact_bench.kernels.sparse_explicit.stable_dt`
        try:
            law = self.contact_law(problem)
        except ValueError:  # no springs to size: prepare says what is missing
            return None
        return stable_dt(problem, self.beta, self.gamma, law)

    def penetration_bound(self, problem, dt: float) -> float:
        semi = banded(problem)
        kappa = self.kappa(semi)
        W, gm = energy_budget(semi)
        return float((gm + math.sqrt(gm * gm + 2.0 * kappa * W)) / kappa)

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        semi = banded(problem)
        return (massless_drift_bound(semi, dt)
                if self.mass in MASSLESS_KINDS and semi is not None else None)

    def adds_time_load(self) -> bool:
        return True  # implicit: Newmark's at t_{n+1}; explicit: A_{n+1} at U_{n+1}, t_{n+1}

    def follows_curved_obstacle(self) -> bool:
        return self.beta > 0.0  # the sparse Newmark stepper, not the explicit one

    def prepare(self, problem, dt: float) -> Stepper:
        # the bar: the first element's boundary kernel; a body: implicit, the springs'
        # piecewise-linear step solved exactly (`contact_bench.kernels.sparse`);
        # explicit, the springs at U_{n+1}, massless dofs quasi-static
        # (`contact_bench.kernels.sparse_explicit`)
        law = self.contact_law(problem)
        semi = banded(problem)
        if semi is not None:
            return CallStepper(lambda n, s: run_boundary_law(semi, dt, n, s, self.beta,
                                                             self.gamma, law))
        if self.beta == 0.0:
            return prepare_explicit_law(problem, dt, self.gamma, law)
        return prepare_newmark(problem, dt, self.beta, self.gamma, law=law)
