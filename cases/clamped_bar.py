"""The clamped bar (Chouly, Hild, Renard 2015; GetFEM's dynamic 1D contact test).

L = 1, rho = E = 1, g = 0, u0 = 1/2 - x/2, v0 = 0, clamped at x = 1 (u = 0). The
bar, compressed against nothing, is released: the end at x = 0 moves down, hits the
obstacle at t = 1, stays in contact until t = 2 with stress -1/2 and flies off; the
motion is periodic with period 3 and the energy is 1/8.

Closed form (derived by marching the characteristics by hand): u = P(x+t) + Q(x-t),
  P(y) = P0(y mod 3) - floor(y/3)/4,  P0(y) = (1-y)/4 on [0,2), (y-3)/4 on [2,3);
  Q(s) = Q0(r mod 3) + floor(r/3)/4 with r = 1 - s,
  Q0(r) = r/4 on [0,1), (2-r)/4 on [1,2), (r-2)/4 on [2,3).
Stresses this scene: a kinked, piecewise-linear solution with repeated impacts.
"""

from __future__ import annotations

import numpy as np

from bench.plugin import Case


def _P(y):
    r = np.mod(y, 3.0)
    return np.where(r < 2.0, (1.0 - r) / 4.0, (r - 3.0) / 4.0) - np.floor(y / 3.0) / 4.0


def _dP(y):
    return np.where(np.mod(y, 3.0) < 2.0, -0.25, 0.25)


def _Q(s):
    r = 1.0 - s
    m = np.mod(r, 3.0)
    base = np.where(m < 1.0, m / 4.0, np.where(m < 2.0, (2.0 - m) / 4.0, (m - 2.0) / 4.0))
    return base + np.floor(r / 3.0) / 4.0


def _dQ(s):
    m = np.mod(1.0 - s, 3.0)  # dQ/ds = -dQ0/dr
    return np.where(m < 1.0, -0.25, np.where(m < 2.0, 0.25, -0.25))


class ClampedBarExact:
    """The closed form above (rho = E = c = 1)."""

    energy = 0.125

    def u(self, x, t):
        x, t = np.broadcast_arrays(np.asarray(x, float), np.asarray(t, float))
        return _P(x + t) + _Q(x - t)

    def ut(self, x, t):
        x, t = np.broadcast_arrays(np.asarray(x, float), np.asarray(t, float))
        return _dP(x + t) - _dQ(x - t)

    def ux(self, x, t):
        x, t = np.broadcast_arrays(np.asarray(x, float), np.asarray(t, float))
        return _dP(x + t) + _dQ(x - t)

    def stress(self, t):
        t = np.asarray(t, float)
        return np.where((np.mod(t, 3.0) > 1.0) & (np.mod(t, 3.0) < 2.0), -0.5, 0.0)


class ClampedBar(Case):
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
