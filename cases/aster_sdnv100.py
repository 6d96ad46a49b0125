"""code_aster's SDNV100 (validation manual V5.03.100, "Impact of a beam on a rigid
wall"): a steel bar 20 cm long, 2 cm square, E = 2e11 Pa, nu = 0.3, rho = 8000 kg/m^3,
hits a rigid wall after a 2 mm gap at 100 m/s (frictionless; published: a quarter of the
bar in HEXA8, lateral faces free).

The published reference (read, sec. 2.1) is the 1D wave solution with the P-wave speed
c_p = sqrt(E (1 - nu) / (rho (1 + nu) (1 - 2 nu))) = 5801 m/s: impact at U0 / V0 = 2e-5 s,
a shock of 2 L / c_p = 6.895e-5 s; derived from it, the force rho c_p V0 S = 1.856e6 N
and the rebound at 100 m/s. This scene is that model (E_1D = rho c_p^2), exact by
characteristics; `embedded_bar[of=aster_sdnv100,dim=3,sides=sliding,nu=0.3]` is the 3D
hexahedral bar for which it is exact. `wave=bar` is the slender bar's c_0 = sqrt(E /
rho) = 5000 m/s: the published bar has free lateral faces and moves at c_0, its contact
15 % longer than published (benchmarks/lateral_effects.py; docs/production-cases.md).
Tolerances: none found in the text read; ours, 1 % (`PUBLISHED`); err_published_<q>.
"""

from __future__ import annotations

import math

from contact_bench.api.params import Param
from contact_bench.exact.published import Published
from contact_bench.exact.uniform_impact import PublishedImpactBar

E_STEEL, NU, RHO = 2e11, 0.3, 8000.0  # Pa, -, kg/m^3
LENGTH, SIDE = 0.20, 0.02  # m
GAP, SPEED = 2e-3, 100.0  # m, m/s
P_MODULUS = E_STEEL * (1 - NU) / ((1 + NU) * (1 - 2 * NU))
C_P = math.sqrt(P_MODULUS / RHO)

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


class AsterSdnv100(PublishedImpactBar):
    name = "aster_sdnv100"
    summary = "code_aster SDNV100: steel bar 20 cm, 2 cm square, hits a wall at 100 m/s"
    params = {"wave": Param("p", "1D model: p (the published c_p, sliding sides) or bar "
                            "(c_0 = sqrt(E / rho), a slender bar with free sides)",
                            choices=("p", "bar"))}
    L, rho, gap, speed = LENGTH, RHO, GAP, SPEED
    T, nx, dt = 1.2e-4, 200, 1e-7
    # not in the study's stability sweep: its T is a few transits, shorter than the
    # sweep's largest CFL steps (steel_bar is the stiff scene there)
    stiff = False
    quantities = frozenset(f"published_{q}" for q in PUBLISHED)
    published = PUBLISHED
    #: the section's area: a bar's stress times it is the contact force
    area = SIDE**2

    @property
    def E(self) -> float:  # type: ignore[override]
        """The 1D modulus: the P-wave modulus (wave = p) or Young's (wave = bar)."""
        return P_MODULUS if self.wave == "p" else E_STEEL
