"""Penalized contact: the obstacle pushes back with kappa min(0, u(0)), kappa = gamma_p E / h.

h is the first element's length and E the Young modulus there. The contact is
violated by O(1/kappa): the end penetrates about |sigma| / kappa (0.5 / kappa on
clamped_bar, up to 500 / kappa on dropped_bar). The spring's energy
kappa/2 min(0, u0)^2 is part of the sampled energy.

Time integration: Newmark(beta, gamma). Implicit (beta > 0): each step is piecewise
linear in u0 and solved exactly with the precomputed w = S^-1 e0 (see
`contact_bench.kernels.boundary`). Explicit (beta = 0): central differences with any mass the
kernel can invert once (consistent, lumped; a massless contact node is solved from
its own row). With beta = 1/4, gamma = 1/2 the energy is conserved between contact
switches; at a switch the step is not energy-exact, so no conservation is claimed
for a massive contact node ("may grow"). With a massless node the node and its
spring are static (a softer first element): energy as `redistributed`, the first
step releasing the first element's strain and the drift bound
`contact_bench.schemes.redistributed.massless_drift_bound` (checked by the property test).

Stability (explicit): the spring stiffens the first element; the limit uses the
first element's local eigenvalue with the spring (`contact_bench.kernels.boundary.element_limit`),
e.g. lumped mass: dt <= 2 / omega, omega^2 = (c/h)^2 2 (2 + a + sqrt(a^2 + 4)) / 2,
a = gamma_p.

Penetration bound: from the energy, kappa/2 d^2 <= W + g m d with W = 2 |E(0)|
(the discrete energy is assumed to stay below twice its initial value, which the
property test checks) and g m the bar's weight: d <= (g m + sqrt((g m)^2 + 2 kappa W)) / kappa.
"""

from __future__ import annotations

import math

import numpy as np

from contact_bench.api.fem import MASS_KINDS, MASSLESS_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import Scheme, Semidiscrete, Traits, Trajectory
from contact_bench.kernels.boundary import element_limit, energy_budget, run_boundary
from contact_bench.kernels.common import massless_drift_bound
from contact_bench.kernels.newmark import BETA, GAMMA
from contact_bench.kernels.sparse import newmark_sparse


class Penalty(Scheme):
    name = "penalty"
    summary = "penalty force kappa min(0, u0), kappa = gamma_p E / h; Newmark (beta 0: explicit)"
    params = {
        "gamma_p": Param(1.0, "penalty parameter: kappa = gamma_p E / h", low=0.0, low_open=True,
                         high=1e8),
        "mass": Param("consistent", "mass matrix (contact_bench.api.fem)", choices=MASS_KINDS),
        "beta": BETA,
        "gamma": GAMMA,
    }

    def mass_kind(self) -> str:
        return self.mass

    def traits(self) -> Traits:
        massless = self.mass in MASSLESS_KINDS
        return Traits(implicit=self.beta > 0, massless_contact_node=massless,
                      contact="penalty O(1/kappa)",
                      energy=("dissipated" if self.gamma > 0.5 else "conserved") if massless
                      else "may grow",
                      order=2 if self.gamma == 0.5 else 1)

    def stability_limit(self, h: float, c: float) -> float | None:
        extra = np.array([[self.gamma_p, 0.0], [0.0, 0.0]])
        return element_limit(self.beta, self.gamma, h, c, self.mass, extra)

    def kappa(self, semi: Semidiscrete) -> float:
        return self.gamma_p * semi.E_contact / float(semi.h[0])

    def penetration_bound(self, semi: Semidiscrete, dt: float) -> float:
        kappa = self.kappa(semi)
        W, gm = energy_budget(semi)
        return float((gm + math.sqrt(gm * gm + 2.0 * kappa * W)) / kappa)

    def energy_drift_bound(self, semi: Semidiscrete, dt: float) -> float | None:
        return massless_drift_bound(semi, dt) if self.mass in MASSLESS_KINDS else None

    def integrate(self, semi: Semidiscrete, dt: float, nsteps: int, stride: int) -> Trajectory:
        kappa = self.kappa(semi)
        return run_boundary(semi, dt, nsteps, stride, self.beta, self.gamma,
                            np.zeros((2, 2)), kappa, (1.0, 0.0), (1.0, 0.0), 1.0, kappa)

    # the general sparse problem (implicit): a spring kappa w_i on each contact dof
    # (w_i its share of the zone's area), kappa = gamma_p E / h at the zone; the springs'
    # piecewise-linear step solved exactly (`contact_bench.kernels.sparse.penalty_solve`)
    forms = frozenset({"banded1d", "sparse"})

    def cannot_run(self, case) -> str | None:
        if case.form == "sparse" and self.beta == 0.0:
            return "the explicit (beta = 0) step has no sparse path yet"
        return None

    def integrate_sparse(self, problem, dt: float, nsteps: int, stride: int) -> Trajectory:
        if not (problem.E_contact > 0 and problem.h_contact > 0):
            raise ValueError("penalty needs the problem's E_contact and h_contact")
        kappa = self.gamma_p * problem.E_contact / problem.h_contact * problem.contact.weights
        return newmark_sparse(problem, dt, nsteps, stride, self.beta, self.gamma, kappa)
