"""code_aster's SDNV100 (validation manual V5.03.100, "Impact of a beam on a rigid
wall"): a steel bar of square section hits a rigid wall at 100 m/s.

Published data (read: the V5.03.100 text, problem and reference-solution sections):
length L = 20 cm, square section of side a = 2 cm (S = a^2), E = 2e11 Pa, nu = 0.3, rho =
8000 kg/m^3, every node initially at U0 = 2 mm from the wall with speed -100 m/s (the
wall normal z), frictionless; code_aster meshes a quarter of the bar (symmetry planes x = 0
and y = 0, the outer lateral faces free) with HEXA8 (modelling F: 21 HEXA8, 88 nodes) and
a penalised contact (E_N = 1e14 Pa). Its reference solution (Gibert 1988) is the 1D wave
solution with the P-wave speed c_p = sqrt(E (1 - nu) / (rho (1 + nu) (1 - 2 nu))) =
5801 m/s: impact at tau0 = U0 / V0 = 2e-5 s, a shock of duration 2 L / c_p = 6.895e-5 s
("any shock duration"), and (derived from the same 1D solution) the contact force
rho c_p V0 S = 1.856e6 N on the whole section, the bar leaving at +100 m/s.

This scene is that reference model: the 1D bar with E_1D = rho c_p^2 (the P-wave
modulus), exact by characteristics. `embedded_bar[of=aster_sdnv100,dim=3,sides=sliding,
nu=0.3]` is the 3D hexahedral bar whose lateral faces slide: its Young modulus is then
exactly the published 2e11 and the 1D solution is exact for it too.

Where the published reference is approximate: the published bar's lateral faces are
free, and then c_p is the speed of the wave front only; a slender bar's long waves run
at c_0 = sqrt(E / rho) = 5000 m/s (Pochhammer-Chree), 16 % slower, so 2 L / c_0 = 8.0e-5 s
and rho c_0 V0 S = 1.6e6 N. `wave=bar` is that 1D model. How far the 3D bar with free
faces is from each: benchmarks/lateral_effects.py (results/references/lateral_effects.md).

Published tolerances: none found in the text read; the comparison (`PUBLISHED`) uses 1 %
on every value (ours: a run locates a switch within dt / 2, 0.25 % of tau0 at the
default dt = 1e-7 s and nx = 200, c_p dt / h = 0.58). Error columns err_published_<q>
(`quantity_errors`).
"""

from __future__ import annotations

import math

import numpy as np

from contact_bench.api.params import Param
from contact_bench.api.plugin import BarCase
from contact_bench.exact.characteristics import CharacteristicsSolution, coarse_solution
from contact_bench.exact.published import Published, bar_observables, published_errors

E_STEEL, NU, RHO = 2e11, 0.3, 8000.0  # Pa, -, kg/m^3
LENGTH, SIDE = 0.20, 0.02  # m
GAP, SPEED = 2e-3, 100.0  # m, m/s
P_MODULUS = E_STEEL * (1 - NU) / ((1 + NU) * (1 - 2 * NU))
C_P = math.sqrt(P_MODULUS / RHO)
EXACT_CELLS = 1  # cells per length L of the reference's grid: exact for these data

#: the published reference (module docstring), with its source
PUBLISHED = {
    "impact_time": Published(GAP / SPEED, 1e-2, "read: tau0 = U0 / V0 (V5.03.100 sec. 2.1)"),
    "contact_duration": Published(2 * LENGTH / C_P, 1e-2,
                                  "read: tau - tau0 = 2 L / c_p (V5.03.100 sec. 2.1)"),
    "release_time": Published(GAP / SPEED + 2 * LENGTH / C_P, 1e-2,
                              "derived: tau0 + 2 L / c_p"),
    "contact_force": Published(RHO * C_P * SPEED * SIDE**2, 1e-2,
                               "derived: rho c_p V0 S, the 1D reference's "
                               "(constant) force over the contact"),
    "rebound_velocity": Published(SPEED, 1e-2, "derived: elastic 1D bar leaves at V0"),
}


class AsterSdnv100(BarCase):
    name = "aster_sdnv100"
    summary = "code_aster SDNV100: steel bar 20 cm, 2 cm square, hits a wall at 100 m/s"
    params = {"wave": Param("p", "1D model: p (the published c_p, sliding sides) or bar "
                            "(c_0 = sqrt(E / rho), a slender bar with free sides)",
                            choices=("p", "bar"))}
    L, rho, g = LENGTH, RHO, 0.0
    far_end, u_L = "free", 0.0
    T, nx, dt = 1.2e-4, 200, 1e-7
    reference = "exact"
    stiff = True
    provides = frozenset({"u", "v", "stress", "energy"})
    quantities = frozenset(f"published_{q}" for q in PUBLISHED)
    published = PUBLISHED
    #: the section's area: a bar's stress times it is the contact force
    area = SIDE**2

    @property
    def E(self) -> float:  # type: ignore[override]
        """The 1D modulus: the P-wave modulus (wave = p) or Young's (wave = bar)."""
        return P_MODULUS if self.wave == "p" else E_STEEL

    def u0(self, x: np.ndarray) -> np.ndarray:
        return np.full_like(np.asarray(x, float), GAP)

    def v0(self, x: np.ndarray) -> np.ndarray:
        return np.full_like(np.asarray(x, float), -SPEED)

    def exact(self, T: float) -> CharacteristicsSolution:
        return coarse_solution(EXACT_CELLS, L=self.L, E=self.E, rho=self.rho,
                               far_end=self.far_end, u0=GAP, v0=-SPEED, T=T)

    @property
    def exact_energy(self) -> float:
        return 0.5 * self.rho * self.L * SPEED**2

    def quantity_errors(self, problem, traj, row) -> dict[str, float]:
        """err_published_<q>: the run against the published values (`PUBLISHED`)."""
        mine = bar_observables(problem, traj, float(row["dt"]), self.area)
        return published_errors(self.published, mine)
