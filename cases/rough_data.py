"""Rough data: a step in the initial velocity and a kink in the initial displacement.

L = 1, rho = E = 1 (c = 1), g = 0, clamped at x = 1 (u = 0), T = 6.
u0 is piecewise linear with a kink at x = 0.3 (u0 in H1, not H2):
(0, 0.1) - (0.3, 0.35) - (1, 0); v0 jumps at x = 1/2 from -1/2 to +1/4 (v0 in L2 only).
This is the regularity that the convergence theorem of Dabaghi, Petrov, Pousin, Renard
(2014) assumes, and no more: the solution carries a velocity jump and a strain jump
along characteristics for all times. Contact periods in [0, 6]: [0.5, 1.7], [3.5, 4],
[4.4, 4.5]. Stresses convergence at minimal regularity (fronts smeared by the mesh,
order below 1) and repeated impacts of a discontinuous wave.

Reference: the characteristics solution (`contact_bench.exact.characteristics`) with
the data as tuples, so the kink and the jump lie on its grid and it is exact to
round-off, on one cell per length L (`EXACT_CELLS`). It provides u, u_t, the contact
stress (in L2(0, T) by hidden regularity; piecewise constant here) and the energy.
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.plugin import BarCase
from contact_bench.exact.characteristics import CharacteristicsSolution, coarse_solution

U0_DATA = (np.array([0.0, 0.3, 1.0]), np.array([0.1, 0.35, 0.0]))
V0_DATA = (np.array([0.0, 0.5, 0.5, 1.0]), np.array([-0.5, -0.5, 0.25, 0.25]))
EXACT_CELLS = 1  # cells per length L of the reference's grid: exact for tuple data


class RoughData(BarCase):
    name = "rough_data"
    summary = "step in v0 (only L2) and kinked u0 (H1): the paper's minimal regularity"
    L, rho, E, g = 1.0, 1.0, 1.0, 0.0
    far_end, u_L = "clamped", 0.0
    T, nx, dt = 6.0, 80, 0.005
    reference = "exact"
    provides = frozenset({"u", "v", "stress", "energy"})

    def u0(self, x: np.ndarray) -> np.ndarray:
        return np.interp(np.asarray(x, float), *U0_DATA)

    def v0(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, float)
        return np.where(x < 0.5, V0_DATA[1][0], V0_DATA[1][-1])

    def exact(self, T: float) -> CharacteristicsSolution:
        return coarse_solution(EXACT_CELLS, L=self.L, E=self.E, rho=self.rho,
                               far_end=self.far_end, u_L=self.u_L, u0=U0_DATA, v0=V0_DATA,
                               T=T)

    @property
    def exact_energy(self) -> float:
        # 1/2 int v0^2 + 1/2 int u0'^2 (E = rho = 1)
        kin = 0.5 * (0.5 * 0.5**2 + 0.5 * 0.25**2)
        slopes = np.diff(U0_DATA[1]) / np.diff(U0_DATA[0])
        return float(kin + 0.5 * np.sum(slopes**2 * np.diff(U0_DATA[0])))
