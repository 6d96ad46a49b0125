"""A free bar thrown at the obstacle with uniform velocity: Mach number v/c as parameter.

L = 1, rho = E = 1 (c = 1), g = 0, both ends free. u0 = gap = 0.01 L, v0 = -mach c
(uniform), mach in [1e-3, 0.5] (default 0.01). The bar flies for t1 = gap / (mach c),
stays in contact for exactly 2 L / c while a compression wave (stress -rho c v =
-E mach) runs up and back, then leaves with velocity +mach c, stress free.
T = t1 + 3 L / c (the scene ends one transit after the take-off).

Stresses the ratio of two time scales, the flight (gap / v) and the wave transit
(L / c): at mach = 1e-3 the impact comes after 10 transits of slow flight, at mach = 0.5
after 0.02 (4 steps at the default dt), with a strain of 0.5, far outside small strain
on purpose. Reference: the characteristics solution, exact (piecewise linear; the
impact instant is inserted in its grid), on one cell per length L (`EXACT_CELLS`): the
data are constant, so any grid is exact. Provides u, u_t, the contact stress and the
energy 1/2 rho L v^2. More: docs/scenes.md.
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.params import Param
from contact_bench.api.plugin import BarCase
from contact_bench.exact.characteristics import CharacteristicsSolution, coarse_solution

GAP_FRACTION = 0.01  # initial gap / L
EXACT_CELLS = 1  # cells per length L of the reference's grid: exact for these data


class FastImpact(BarCase):
    name = "fast_impact"
    summary = "free bar at uniform speed towards the obstacle, Mach v/c from 1e-3 to 0.5"
    params = {"mach": Param(0.01, "impact speed / wave speed c", low=1e-3, high=0.5)}
    L, rho, E, g = 1.0, 1.0, 1.0, 0.0
    far_end, u_L = "free", 0.0
    nx, dt = 80, 0.005
    reference = "exact"
    provides = frozenset({"u", "v", "stress", "energy"})
    mach: float

    @property
    def speed(self) -> float:
        return self.mach * self.wave_speed

    @property
    def gap(self) -> float:
        return GAP_FRACTION * self.L

    @property
    def impact_time(self) -> float:
        return self.gap / self.speed

    @property
    def T(self) -> float:  # type: ignore[override]
        return self.impact_time + 3.0 * self.L / self.wave_speed

    def u0(self, x: np.ndarray) -> np.ndarray:
        return np.full_like(np.asarray(x, float), self.gap)

    def v0(self, x: np.ndarray) -> np.ndarray:
        return np.full_like(np.asarray(x, float), -self.speed)

    def exact(self, T: float) -> CharacteristicsSolution:
        return coarse_solution(EXACT_CELLS, L=self.L, E=self.E, rho=self.rho,
                               far_end=self.far_end, u0=self.gap, v0=-self.speed, T=T)

    @property
    def exact_energy(self) -> float:
        return 0.5 * self.rho * self.L * self.speed**2
