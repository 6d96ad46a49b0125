"""Laursen and Chawla (1997): the midpoint rule with a discrete persistency condition.

The implicit midpoint rule, M (V1 - V0) / dt + K (U0 + U1) / 2 = F + C^T lambda, with
the obstacle's force at the midpoint; on the contact dofs closed at t_n (gap <= 0)
the discrete persistency condition Dg >= 0, lambda >= 0, lambda . Dg = 0 on the gap
increment Dg = g_{n+1} - g_n, the other dofs free. The step's energy change is
lambda . Dg = 0: the discrete energy 1/2 V.M.V + 1/2 U.K.U - F.U is conserved to
round-off. The price: a dof that reaches the obstacle inside a step penetrates by its
travel in that step (at most dt |v|) and is held there while it pushes.

Reading chosen (the paper states the persistency condition, not when a dof enters the
active set): a dof is active when it is closed at the start of the step (its gap
g_n <= 0); activating it on a predicted g_{n+1} < 0 instead would stop it where it
is, with no self-consistent active set in the step of an impact. The condition is
an LCP on the gap increments (a condition on the mean normal velocity of the step):
Doyen, Ern, Piperno's velocity class. Kernel: `contact_bench.kernels.energy_conserving`,
on the bar's CSR matrices and on a body's alike. Measurements: docs/schemes.md.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

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
from contact_bench.api.recorder import discrete_energy
from contact_bench.kernels.energy_conserving import PERSISTENCY, prepare_midpoint_contact

#: the drift a conserving step keeps (relative, over a run): round-off of the sums
ROUNDOFF_DRIFT = 1e-9


class LaursenChawla(Scheme):
    name = "laursen_chawla"
    summary = ("midpoint rule, persistency lambda (g_{n+1} - g_n) = 0 on closed dofs: "
               "energy conserved, small penetration")
    params = {}

    def traits(self, problem=None) -> Traits:
        return Traits(implicit=True, massless_contact_node=False,
                      contact=Contact.VELOCITY_LEVEL, order=2,
                      energy=Energy.MAY_GROW if on_curved_obstacle(problem)
                      else Energy.CONSERVED,
                      family=Family.VELOCITY)

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        return ROUNDOFF_DRIFT

    def penetration_bound(self, problem, dt: float) -> float:
        """On the bar: a dof penetrates only in the step it arrives, by dt times its mean
        velocity there, |v_0| <= sqrt(2 Ekin (M^-1)_00); with the energy conserved Ekin is
        at most E(0) - min_U (1/2 U.K.U - F.U + offset) (K positive definite: the far end
        clamped). No bound (inf) for a free bar, whose weight does unbounded work, nor for
        a body."""
        semi = banded(problem)
        if semi is None or semi.u_fixed is None:
            return math.inf
        K, M = sp.csc_matrix(semi.K.to_sparse()), sp.csc_matrix(semi.M.to_sparse())
        F = np.asarray(semi.F, float)
        e0 = discrete_energy(semi, semi.U0, semi.V0)
        ekin = max(e0 + 0.5 * F @ spsolve(K, F) - semi.energy_offset, 0.0)
        e = np.zeros(semi.nfree)
        e[0] = 1.0
        return float(dt * math.sqrt(2.0 * ekin * spsolve(M, e)[0]))

    def follows_curved_obstacle(self) -> bool:
        return True  # its sparse stepper re-linearises the gaps every step

    def adds_time_load(self) -> bool:
        return True  # the body's midpoint step adds it at t_{n+1/2}

    def prepare(self, problem, dt: float) -> Stepper:
        # the bar (its CSR matrices) and a body: one compiled midpoint step
        return prepare_midpoint_contact(problem, dt, PERSISTENCY)
