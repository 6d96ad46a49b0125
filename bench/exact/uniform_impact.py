"""A free bar flying onto the wall at a uniform speed, and its exact solution: the scene
kind of `fast_impact`, `steel_bar`, `aster_sdnv100` and `ansys_vm265`.

The bar (0, L), both ends free, no gravity, starts at the gap `gap` from the obstacle
with the velocity -`speed` everywhere. It hits at gap / speed, stays in contact for
exactly 2 L / c with the stress -rho c speed, and leaves at +speed; its energy is
1/2 rho L speed^2. The reference is the characteristics solution on one cell per
length L (`EXACT_CELLS`): the data are constant, so any grid is exact (the impact
instant is inserted in it).

`PublishedImpactBar` adds a production code's published values (`published`, a
`contact_bench.exact.published.Published` per observable) and the section's `area`,
and reads a run's errors against them (err_published_<q>).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from contact_bench.api.plugin import BarCase
from contact_bench.exact.characteristics import CharacteristicsSolution, coarse_solution
from contact_bench.exact.published import Published, bar_observables, published_errors

EXACT_CELLS = 1  # cells per length L of the reference's grid: exact for these data


class UniformImpactBar(BarCase):
    """A free bar at gap `gap` moving at -`speed` (module docstring). Subclasses set
    `gap` and `speed` (numbers, or properties of their params) and the bar's data."""

    gap: float = 0.0
    speed: float = 0.0
    far_end, u_L, g = "free", 0.0, 0.0
    reference = "exact"
    provides = frozenset({"u", "v", "stress", "energy"})

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


class PublishedImpactBar(UniformImpactBar):
    """A production code's verification case of that kind: its published values and the
    section's area (a bar's stress times it is the contact force)."""

    published: ClassVar[dict[str, Published]] = {}
    area: float = 1.0

    def quantity_errors(self, problem: Any, traj: Any, row: dict) -> dict[str, float]:
        """err_published_<q>: the run against the published values (`published`)."""
        mine = bar_observables(problem, traj, float(row["dt"]), self.area)
        return published_errors(self.published, mine)
