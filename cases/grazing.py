"""Grazing: the end reaches the obstacle with zero velocity and leaves at once.

L = 1, rho = E = 1 (c = 1), g = 0, both ends free, T = 4.
u0 = A (1 + cos(pi x)), v0 = 0 with A = 0.1: the first free-free mode on top of a rigid
shift, u = A (1 + cos(pi x) cos(pi t)). The end u(0, t) = A (1 + cos(pi t)) comes down
to the obstacle at t = 1 (and t = 3) with zero velocity and zero contact force: the
contact periods are single instants (intervals of zero length, checked with the exact
solver in tests/test_scenes.py), and the free motion is the exact solution.

Stresses: contact detection at a touch (a scheme whose discrete end dips below 0 by
dispersion activates a spurious contact, a scheme that smooths the constraint may lift
the end early); everything else is smooth. Reference: that free motion in closed form
(`GrazingExact`), checked against the characteristics solution of the same data, which
finds the touch as a one-node contact run (tests/test_scenes.py). It provides u, u_t
and the energy, but no contact stress: the exact stress is identically 0, so the
relative stress error of the harness (divided by its norm) would be 0/0. The numerical
contact stress is in the trajectory and the figures.
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.plugin import BarCase
from contact_bench.exact.grazing import GrazingExact

AMPLITUDE = 0.1


class Grazing(BarCase):
    name = "grazing"
    summary = "first free-free mode whose end touches the obstacle with zero velocity"
    L, rho, E, g = 1.0, 1.0, 1.0, 0.0
    far_end, u_L = "free", 0.0
    T, nx, dt = 4.0, 80, 0.005
    reference = "exact"
    provides = frozenset({"u", "v", "energy"})

    def u0(self, x: np.ndarray) -> np.ndarray:
        return AMPLITUDE * (1.0 + np.cos(np.pi * np.asarray(x, float) / self.L))

    def exact(self, T: float) -> GrazingExact:
        return GrazingExact(self.L, float(np.sqrt(self.E / self.rho)), AMPLITUDE)

    @property
    def exact_energy(self) -> float:
        # 1/2 int E u0'^2 = 1/2 E (A pi / L)^2 L / 2
        return 0.25 * self.E * (AMPLITUDE * np.pi) ** 2 / self.L
