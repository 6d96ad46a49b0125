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
grid. `series_u` is the paper's series (5.5) with its typo fixed (sqrt(2 u0 g), not
sqrt(2 u0 / g), in h1), a cross-check valid for these parameters only. Measurements:
docs/scenes.md.
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.plugin import Case
from contact_bench.exact.characteristics import CharacteristicsSolution, coarse_solution

EXACT_CELLS = 1  # cells per length L of the reference's grid: exact for these data
COARSE_PERIODS = 2.0  # ... up to T = this many periods 16 L / c (default grid beyond)
SERIES_MODES = 4000
SERIES_TRUNCATION = 1.2e-4  # bound on |u_series - u| with SERIES_MODES modes


class DroppedBar(Case):
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


def series_u(x: np.ndarray, t: np.ndarray, modes: int = SERIES_MODES) -> np.ndarray:
    """The corrected eq. (5.5) for L=10, E=900, g=10, u0=5 (rho = 1), vectorised."""
    L, E, g, u0 = DroppedBar.L, DroppedBar.E, DroppedBar.g, DroppedBar.height
    x, t = np.broadcast_arrays(np.asarray(x, float), np.asarray(t, float))
    x, t = x.ravel(), t.ravel()
    sE = np.sqrt(E)
    tL, t1, vf = L / sE, np.sqrt(2 * u0 / g), np.sqrt(2 * u0 * g)
    n = np.arange(1, modes + 1)
    nu, lam = (n - 0.5) * np.pi / L, n * np.pi / L

    def h1(xx, tt):
        s = np.zeros_like(xx)
        for a in range(0, xx.size, 2000):
            b = slice(a, a + 2000)
            s[b] = ((np.cos(sE * np.outer(tt[b], nu)) - 1) * np.sin(np.outer(xx[b], nu))
                    ) @ (2 * g / (E * L * nu**3))
        return -vf * np.minimum(xx / sE, tL - np.abs(tt - tL)) + s

    def h2(xx, tt):
        s = np.zeros_like(xx)
        for a in range(0, xx.size, 2000):
            b = slice(a, a + 2000)
            s[b] = (np.cos(sE * np.outer(tt[b], lam)) * np.cos(np.outer(xx[b], lam))
                    ) @ (4 * g / (E * lam**2))
        return u0 - 0.5 * g * (tt - t1) ** 2 - 2 * g * L**2 / (3 * E) + s

    out = np.empty_like(x)
    period = 16 * tL
    k = np.floor((t - 3 * tL) / period)
    k = np.maximum(k, 0)
    ta = 3 * tL + k * period  # t_{4k+1}
    tb, tc, td = ta + 2 * tL, ta + 8 * tL, ta + 10 * tL
    free0 = t <= t1
    out[free0] = u0 - 0.5 * g * t[free0] ** 2
    m1 = ~free0 & (t > ta) & (t <= tb)
    out[m1] = h1(x[m1], t[m1] - ta[m1])
    m2 = ~free0 & (t > tb) & (t <= tc)
    out[m2] = h2(x[m2], t[m2] - tb[m2])
    m3 = ~free0 & (t > tc) & (t <= td)
    out[m3] = h1(x[m3], td[m3] - t[m3])
    m4 = ~free0 & (t > td)
    out[m4] = u0 - 0.5 * g * (t[m4] - td[m4] - t1) ** 2
    return out
