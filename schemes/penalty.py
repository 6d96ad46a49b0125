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
checks): kappa/2 d^2 <= W + g m d. Details: docs/schemes.md.
"""

from __future__ import annotations

import math

import numpy as np

from contact_bench.api.fem import MASS_ALIASES, MASS_KINDS, MASSLESS_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import Contact, Energy, Scheme, Semidiscrete, Traits, Trajectory
from contact_bench.kernels.boundary import element_limit, energy_budget, run_boundary
from contact_bench.kernels.common import massless_drift_bound
from contact_bench.kernels.newmark import BETA, GAMMA
from contact_bench.kernels.sparse import newmark_sparse
from contact_bench.kernels.sparse_explicit import explicit_law_sparse, penalty_law, stable_dt


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

    def traits(self) -> Traits:
        massless = self.mass in MASSLESS_KINDS
        return Traits(implicit=self.beta > 0, massless_contact_node=massless,
                      contact=Contact.PENALTY,
                      energy=(Energy.DISSIPATED if self.gamma > 0.5 else Energy.CONSERVED)
                      if massless else Energy.MAY_GROW,
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

    # the general sparse problem: a spring kappa w_i on each contact dof (w_i its share
    # of the zone's area), kappa = gamma_p E / h at the zone. Implicit: the springs'
    # piecewise-linear step solved exactly (`contact_bench.kernels.sparse.penalty_solve`);
    # explicit: the springs at U_{n+1}, massless dofs quasi-static
    # (`contact_bench.kernels.sparse_explicit`)
    forms = frozenset({"banded1d", "sparse"})

    def _sparse_kappa(self, problem) -> np.ndarray:
        if not (problem.E_contact > 0 and problem.h_contact > 0):
            raise ValueError("penalty needs the problem's E_contact and h_contact")
        return self.gamma_p * problem.E_contact / problem.h_contact * problem.contact.weights

    def sparse_stability_limit(self, problem) -> float | None:
        # the springs' eigenvalues on this mesh (the 1D element formula does not bound
        # those of 2D/3D elements): `contact_bench.kernels.sparse_explicit.stable_dt`
        try:
            law = penalty_law(problem, self._sparse_kappa(problem))
        except ValueError:  # no springs to size: integrate_sparse says what is missing
            return None
        return stable_dt(problem, self.beta, self.gamma, law)

    def integrate_sparse(self, problem, dt: float, nsteps: int, stride: int) -> Trajectory:
        kappa = self._sparse_kappa(problem)
        if self.beta == 0.0:
            return explicit_law_sparse(problem, dt, nsteps, stride, self.gamma,
                                       penalty_law(problem, kappa))
        return newmark_sparse(problem, dt, nsteps, stride, self.beta, self.gamma, kappa)
