"""The clamped bar over 1000 periods: does the energy drift accumulate?

The scene of `clamped_bar` (L = 1, rho = E = 1, u0 = 1/2 - x/2, v0 = 0, clamped at
x = 1, period 3, energy 1/8) run to T = 3000: 1000 periods, 1000 impacts and 1000
take-offs. Reference: the same closed form (`contact_bench.exact.clamped.ClampedBarExact`,
exact for all t: it only uses t mod 3 and floor(t / 3)); the characteristics solver
agrees with it at late times (tests/test_scenes.py).

Stresses: accumulation of the energy error of a contact treatment (a drift per impact
that is invisible on 4 periods), phase error of the discrete wave over many periods.
Defaults: nx = 80, dt = 0.005 (600000 steps) and a sampling stride of 50 (12 samples
per period), so the kept samples stay small; --stride overrides it.

Every scheme can run it. One whose energy grows at impacts (traits().energy ==
'may grow', e.g. the standard Newmark scheme) shows up as an 'unstable' row with the
time of its blow-up, which is the long-time answer for it (docs/scenes.md).
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.plugin import BarCase
from contact_bench.exact.clamped import ClampedBarExact


class LongTime(BarCase):
    name = "long_time"
    summary = "clamped_bar over 1000 periods (T = 3000): accumulated energy drift"
    L, rho, E, g = 1.0, 1.0, 1.0, 0.0
    far_end, u_L = "clamped", 0.0
    T, nx, dt = 3000.0, 80, 0.005
    reference = "exact"
    provides = frozenset({"u", "v", "stress", "energy"})
    stride = 50
    in_default_run = False

    def u0(self, x):
        return 0.5 - 0.5 * np.asarray(x, float)

    def exact(self, T: float) -> ClampedBarExact:
        return ClampedBarExact()

    @property
    def exact_energy(self) -> float:
        return 0.125
