"""The bar dropped under gravity (Dabaghi, Petrov, Pousin, Renard 2014, section 5.2).

L = 10, E = 900, rho = 1, g = 10, u0 = 5, v0 = 0, both ends free, T = 6.5; c = 30,
transit time L/c = 1/3. The bar falls for 1 s, hits at speed 10, stays in contact for
2L/c while a wave runs up and back, flies, and so on (period 16 L/c). Contact
intervals [1, 5/3], [11/3, 13/3], [19/3, 7]; stress on the first contact from -300 to
-500; energy (with gravity) rho g L u0 = 500. Stresses gravity, free ends and a nearly
grazing second impact (speed 10/3).

Reference: the characteristics solution (`contact_bench.exact.characteristics`), exact
to round-off. Up to `COARSE_PERIODS` periods it uses one cell per length L
(`EXACT_CELLS`): the data are constant and every impact and take-off falls on a
multiple of L/c, so that grid is exact and much faster; longer runs use the default
grid. The paper's series (5.5), with its typo fixed, is a cross-check of it
(`contact_bench.exact.dropped_series`). Measurements: docs/scenes.md.
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.plugin import BarCase
from contact_bench.exact.characteristics import CharacteristicsSolution, coarse_solution

EXACT_CELLS = 1  # cells per length L of the reference's grid: exact for these data
COARSE_PERIODS = 2.0  # ... up to T = this many periods 16 L / c (default grid beyond)


class DroppedBar(BarCase):
    name = "dropped_bar"
    summary = "free bar dropped under gravity on the obstacle (the paper's sec. 5.2)"
    L, rho, E, g = 10.0, 1.0, 900.0, 10.0
    far_end, u_L = "free", 0.0
    T, nx, dt = 6.5, 100, 2e-3
    reference = "exact"
    in_default_run = True
    provides = frozenset({"u", "v", "stress", "energy"})
    height = 5.0

    def u0(self, x):
        return np.full_like(np.asarray(x, float), self.height)

    def exact(self, T: float) -> CharacteristicsSolution:
        """The characteristics solution, on EXACT_CELLS cells per length up to
        COARSE_PERIODS periods (module docstring: exact to round-off for these data,
        events on multiples of L/c), on the default grid beyond."""
        kw = {"L": self.L, "E": self.E, "rho": self.rho, "g": self.g, "far_end": "free",
              "u0": self.u0, "v0": self.v0, "T": T}
        if T <= COARSE_PERIODS * 16.0 * self.L / self.wave_speed:
            return coarse_solution(EXACT_CELLS, **kw)
        return CharacteristicsSolution(**kw)

    @property
    def exact_energy(self) -> float:
        return self.rho * self.g * self.L * self.height
