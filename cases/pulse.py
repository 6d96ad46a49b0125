"""A smooth compactly supported pulse running into the obstacle, several impacts.

L = 1, rho = E = 1 (c = 1), g = 0, clamped at x = 1 (u = 0), T = 8.
u0 = gap (1 - x) + f(x), v0 = f'(x): a wave f(x + t) travelling towards the obstacle on
the uniform strain gap (1 - x), gap = 0.1, with f = -A b((x - x0) / w), the C-infinity
bump b(y) = exp(1 - 1 / (1 - y^2)) on |y| < 1, A = 0.2, x0 = 1/2, w = 0.2. The pulse
pulls the end down by A > gap, so it hits the obstacle, comes back from the clamped end
with the opposite sign, returns and hits again: contact periods [0.340, 0.505],
[2.505, 2.689], [4.689, 6], [6.363, 6.505] in [0, 8].

Stresses the smooth regime (away from impacts the errors are those of a smooth wave,
so a loss of order comes from the contact only), dispersion over several reflections
and repeated impacts. Reference: d'Alembert's formula (`contact_bench.exact.dalembert`)
on the closed forms of the data below (`_u0`, `_V`); how it is checked:
docs/scenes.md. Provides u, u_t, the contact stress and the conserved energy.
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.plugin import BarCase
from contact_bench.exact.dalembert import DalembertSolution

GAP, AMPLITUDE, CENTER, WIDTH = 0.1, 0.2, 0.5, 0.2


class Pulse(BarCase):
    name = "pulse"
    summary = "smooth compact pulse hitting the obstacle again and again (4 impacts)"
    L, rho, E, g = 1.0, 1.0, 1.0, 0.0
    far_end, u_L = "clamped", 0.0
    T, nx, dt = 8.0, 80, 0.005
    reference = "exact"
    provides = frozenset({"u", "v", "stress", "energy"})

    def u0(self, x: np.ndarray) -> np.ndarray:
        return _u0(x)[0]

    def v0(self, x: np.ndarray) -> np.ndarray:
        return _V(x)[1]

    def exact(self, T: float) -> DalembertSolution:
        return DalembertSolution(L=self.L, E=self.E, rho=self.rho, far_end=self.far_end,
                                 u_L=self.u_L, u0=_u0, V=_V, T=T)

    @property
    def exact_energy(self) -> float:
        return float(self.exact(1e-3).energy(0.0))


def _bump(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """b(y) and b'(y) of the C-infinity bump exp(1 - 1/(1 - y^2)) on (-1, 1)."""
    y = np.asarray(y, float)
    inside = np.abs(y) < 1.0
    s = np.where(inside, 1.0 - y * y, 1.0)
    b = np.where(inside, np.exp(1.0 - 1.0 / s), 0.0)
    return b, np.where(inside, b * (-2.0 * y / s**2), 0.0)


def _u0(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """u0 and u0' in closed form (for the d'Alembert reference)."""
    x = np.asarray(x, float)
    b, db = _bump((x - CENTER) / WIDTH)
    return GAP * (1.0 - x) - AMPLITUDE * b, -GAP - AMPLITUDE / WIDTH * db


def _V(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """V = int_0^x v0 = -A (b((x - x0) / w) - b(-x0 / w)) and v0, in closed form."""
    b, db = _bump((np.asarray(x, float) - CENTER) / WIDTH)
    b0 = float(_bump(np.asarray(-CENTER / WIDTH))[0])
    return -AMPLITUDE * (b - b0), -AMPLITUDE / WIDTH * db
