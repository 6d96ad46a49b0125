"""The clamped bar (Chouly, Hild, Renard 2015; GetFEM's dynamic 1D contact test).

L = 1, rho = E = 1, g = 0, u0 = 1/2 - x/2, v0 = 0, clamped at x = 1 (u = 0). The
bar, compressed against nothing, is released: the end at x = 0 moves down, hits the
obstacle at t = 1, stays in contact until t = 2 with stress -1/2 and flies off; the
motion is periodic with period 3 and the energy is 1/8.

Reference: the closed form `contact_bench.exact.clamped.ClampedBarExact`; from its contact
stress the harness reads the first contact [1, 2] and its peak force 1/2 (the err_contact_*
and err_peak_force columns, `contact_bench.harness.quantities`).
Stresses this scene: a kinked, piecewise-linear solution with repeated impacts.
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.plugin import BarCase
from contact_bench.exact.clamped import ClampedBarExact


class ClampedBar(BarCase):
    name = "clamped_bar"
    summary = "clamped bar released from compression, period 3, energy 1/8 (closed form)"
    L, rho, E, g = 1.0, 1.0, 1.0, 0.0
    far_end, u_L = "clamped", 0.0
    T, nx, dt = 12.0, 80, 0.005
    reference = "exact"
    in_default_run = True
    provides = frozenset({"u", "v", "stress", "energy"})

    def u0(self, x):
        return 0.5 - 0.5 * np.asarray(x, float)

    def exact(self, T: float) -> ClampedBarExact:
        return ClampedBarExact()

    @property
    def exact_energy(self) -> float:
        return 0.125
