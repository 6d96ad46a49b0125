"""Armero and Petocz (1998): an energy-conserving penalty scheme.

The implicit midpoint rule (trapezoidal in displacement and velocity) with the penalty
springs of `penalty` (kappa = gamma_p E / h at the contact zone, kappa w_i on a body's
contact point i) entering through the discrete gradient of their energy
Phi(g) = kappa/2 min(0, g)^2: the force over a step is -(Phi(g_{n+1}) - Phi(g_n)) /
(g_{n+1} - g_n), not the spring at t_{n+1} nor at the midpoint. Then the discrete energy
1/2 V.M.V + 1/2 U.K.U - F.U + sum Phi(g) is conserved exactly (round-off); the contact
is violated by O(1/kappa), as `penalty`.

Reading of the paper: Armero and Petocz write the penalty's discrete gradient for a
general gap function; with the suite's gaps linear in U (g = gap0 + U at each contact
dof) the secant quotient above is that gradient, per contact dof. The nonlinear step (the
n_c gaps at t_{n+1}) is solved by Newton to round-off (`contact_bench.kernels.
energy_penalty`), the bar's one contact dof and a body's many alike, on the problem's
sparse matrices (the bar's tridiagonal ones too). Details: docs/schemes.md.
"""

from __future__ import annotations

import math

import numpy as np

from contact_bench.api.params import Param
from contact_bench.api.plugin import (
    Contact,
    Energy,
    Family,
    Scheme,
    Stepper,
    Traits,
    on_curved_obstacle,
)
from contact_bench.api.problem import banded
from contact_bench.kernels.boundary import energy_budget
from contact_bench.kernels.energy_penalty import prepare_midpoint_penalty

#: the energy drift claimed: round-off of the solves, summed over the steps
DRIFT_BOUND = 1e-9


class ArmeroPetocz(Scheme):
    name = "armero_petocz"
    summary = ("penalty through the discrete gradient of its energy, midpoint rule: "
               "energy conserved (Armero-Petocz 1998)")
    params = {
        "gamma_p": Param(1.0, "penalty parameter: kappa = gamma_p E / h", low=0.0, low_open=True,
                         high=1e8, sweep=(1.0, 1e2, 1e4, 1e6, 1e8)),
        "mass": Param("consistent", "mass matrix (contact_bench.api.fem)",
                      choices=("consistent", "lumped")),
    }

    def mass_kind(self) -> str:
        return self.mass

    def traits(self, problem=None) -> Traits:
        return Traits(implicit=True, massless_contact_node=False, contact=Contact.PENALTY,
                      energy=Energy.MAY_GROW if on_curved_obstacle(problem)
                      else Energy.CONSERVED, order=2, family=Family.PENALTY)

    def spring_stiffnesses(self, problem) -> np.ndarray:
        """kappa w_i on each contact point (w_i its share of the zone's measure; the bar:
        one point of weight 1), kappa = gamma_p E / h at the zone."""
        if not (problem.E_contact > 0 and problem.h_contact > 0):
            raise ValueError("armero_petocz needs the problem's E_contact and h_contact")
        return (self.gamma_p * problem.E_contact / problem.h_contact
                * np.asarray(problem.contact.weights, float))

    def penetration_bound(self, problem, dt: float) -> float:
        # the springs' energy kappa/2 d^2 is at most the conserved energy plus the weight's
        # work g m d (`energy_budget`: twice |E(0)|, a margin over round-off)
        semi = banded(problem)
        kappa = self.gamma_p * semi.E_contact / float(semi.h[0])
        W, gm = energy_budget(semi)
        return float((gm + math.sqrt(gm * gm + 2.0 * kappa * W)) / kappa)

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        return DRIFT_BOUND

    def follows_curved_obstacle(self) -> bool:
        return True  # its sparse stepper re-linearises the gaps every step

    def adds_time_load(self) -> bool:
        return True  # the body's midpoint step adds it at t_{n+1/2}

    def prepare(self, problem, dt: float) -> Stepper:
        # one path for the bar and the bodies: the sparse midpoint kernel with the
        # discrete-gradient springs (`contact_bench.kernels.energy_penalty`)
        return prepare_midpoint_penalty(problem, dt, self.spring_stiffnesses(problem))
