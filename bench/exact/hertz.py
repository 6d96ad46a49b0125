"""Hertz's quasi-static impact of an elastic sphere on a rigid plane (Johnson 1985, sec. 11).

The contact force of an approach d is F = k d^(3/2), k = (4/3) E* sqrt(R), E* = E / (1 -
nu^2) (the plane rigid). With the sphere's mass m = rho (4/3) pi R^3 hitting at speed v,
energy gives the largest approach d_max = (15 m v^2 / (16 E* sqrt(R)))^(2/5), the peak
force F_max = k d_max^(3/2), and the contact lasts T_c = (4/5) B(2/5, 1/2) d_max / v
(about 2.9432 d_max / v; B is Euler's beta function: twice the time of the quarter
oscillation of m d'' = -k d^(3/2)). It is the limit v / c -> 0 of the elastodynamic
impact: a finite-element run approaches it as v and h shrink, it does not equal it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scipy.special import beta as _beta

#: T_c v / d_max = (4/5) B(2/5, 1/2)
CONTACT_TIME_FACTOR = 0.8 * float(_beta(0.4, 0.5))


@dataclass(frozen=True)
class HertzImpact:
    """Hertz's reference quantities of a sphere (radius R, Young's modulus E, Poisson's
    ratio nu, density rho) hitting a rigid plane at speed v."""

    R: float
    E: float
    nu: float
    rho: float
    v: float

    def __post_init__(self) -> None:
        for name in ("R", "E", "rho", "v"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} = {value!r}: must be positive and finite")
        if not -1.0 < self.nu < 0.5:
            raise ValueError(f"nu = {self.nu!r} outside (-1, 1/2)")

    @property
    def mass(self) -> float:
        return self.rho * 4.0 / 3.0 * math.pi * self.R**3

    @property
    def E_star(self) -> float:
        """The contact modulus E / (1 - nu^2) against a rigid plane."""
        return self.E / (1.0 - self.nu**2)

    @property
    def k(self) -> float:
        """F = k d^(3/2)."""
        return 4.0 / 3.0 * self.E_star * math.sqrt(self.R)

    @property
    def d_max(self) -> float:
        """The largest approach."""
        return (15.0 * self.mass * self.v**2 / (16.0 * self.E_star * math.sqrt(self.R))) ** 0.4

    @property
    def peak_force(self) -> float:
        return self.k * self.d_max**1.5

    @property
    def contact_time(self) -> float:
        return CONTACT_TIME_FACTOR * self.d_max / self.v


__all__ = ["CONTACT_TIME_FACTOR", "HertzImpact"]
