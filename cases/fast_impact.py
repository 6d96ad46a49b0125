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
impact instant is inserted in its grid), on one cell per length L
(`contact_bench.exact.uniform_impact`): the data are constant, so any grid is exact.
Provides u, u_t, the contact stress and the energy 1/2 rho L v^2. More: docs/scenes.md.
"""

from __future__ import annotations

from contact_bench.api.params import Param
from contact_bench.exact.uniform_impact import UniformImpactBar

GAP_FRACTION = 0.01  # initial gap / L


class FastImpact(UniformImpactBar):
    name = "fast_impact"
    summary = "free bar at uniform speed towards the obstacle, Mach v/c from 1e-3 to 0.5"
    params = {"mach": Param(0.01, "impact speed / wave speed c", low=1e-3, high=0.5)}
    L, rho, E = 1.0, 1.0, 1.0
    nx, dt = 80, 0.005
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
