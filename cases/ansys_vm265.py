"""Ansys Mechanical APDL verification case VM265, "Elastic Rod Impacting a Rigid Wall"
(reference: Carpenter, Taylor and Katona 1991), in its units (inch, lbf, second).

Published (read, VM265 page): rod L = 10 in, A = 1 in^2, E = 3.0e7 psi, nu = 0.3, density
printed "0.73 lbf sec2/in4", gap 0.01 in, v0 = 202.2 in/s (printed "in/sec2"); 20
elements, HHT without damping, dt = 0.2226e-5 s; first target: impact at 0.00005 s.
Density: 0.73 cannot be meant; steel is 7.3e-4 lbf s^2/in^4, with which the published dt
is 0.9 h / c (c = 202,721 in/s); with 0.73 the contact would last 3.1e-3 s. `RHO` is
7.3e-4. Reference (derived, 1D as the rod of Carpenter et al.): impact at g / v0 =
4.946e-5 s (the printed 0.00005 is rounded, 1.1 % high), contact 2 L / c = 9.866e-5 s,
release 1.481e-4 s, force rho c v0 A = 29,922 lbf, rebound +202.2 in/s; the page's
other targets could not be read and are derived, marked so. `wave=shell`: the published
model's constrained plane-stress shell has modulus E / (1 - nu^2), 4.8 % faster waves
(derived, not checked against Ansys). Details: docs/production-cases.md.
"""

from __future__ import annotations

import math

from contact_bench.api.params import Param
from contact_bench.exact.published import Published
from contact_bench.exact.uniform_impact import PublishedImpactBar

E_ROD, NU = 3.0e7, 0.3  # psi
RHO = 7.3e-4  # lbf s^2 / in^4 (the page prints 0.73: module docstring)
LENGTH, AREA = 10.0, 1.0  # in, in^2
GAP, SPEED = 0.01, 202.2  # in, in/s
C0 = math.sqrt(E_ROD / RHO)

#: the published reference (module docstring), with its source and tolerance
PUBLISHED = {
    "impact_time": Published(0.00005, 0.1, "read: VM265 target at impact, printed "
                             "0.00005 s (one digit: tolerance half a unit of it)"),
    "release_time": Published(GAP / SPEED + 2 * LENGTH / C0, 1e-2,
                              "derived: g / v0 + 2 L / c (target not readable)"),
    "contact_duration": Published(2 * LENGTH / C0, 1e-2, "derived: 2 L / c"),
    "contact_force": Published(RHO * C0 * SPEED * AREA, 1e-2, "derived: rho c v0 A, the (constant) "
                               "force over the contact"),
    "rebound_velocity": Published(SPEED, 1e-2, "derived: elastic rod leaves at v0"),
}


class AnsysVm265(PublishedImpactBar):
    name = "ansys_vm265"
    summary = "Ansys VM265: elastic rod (10 in, steel, inch-lbf-s) hits a rigid wall"
    params = {"wave": Param("bar", "1D model: bar (E, Carpenter's rod) or shell "
                            "(E / (1 - nu^2), the constrained plane-stress shell)",
                            choices=("bar", "shell"))}
    L, rho, gap, speed = LENGTH, RHO, GAP, SPEED
    T, nx, dt = 2.0e-4, 20, 0.2226e-5
    # not in the study's stability sweep: its T is a few transits, shorter than the
    # sweep's largest CFL steps (steel_bar is the stiff scene there)
    stiff = False
    quantities = frozenset(f"published_{q}" for q in PUBLISHED)
    published = PUBLISHED
    area = AREA

    @property
    def E(self) -> float:  # type: ignore[override]
        return E_ROD if self.wave == "bar" else E_ROD / (1 - NU**2)
