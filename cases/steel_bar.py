"""The Siconos ImpactingBar setup in SI units: a steel bar dropped flat on a rigid wall.

E = 210e9 Pa, rho = 7800 kg/m^3, L = 1 m, both ends free, no gravity; initial gap
5e-5 m, uniform velocity v0 = -0.1 m/s. Wave speed c = sqrt(E / rho) = 5188.7 m/s,
transit time L / c = 1.93e-4 s. The bar hits at t1 = 5e-4 s, stays in contact for
exactly 2 L / c = 3.85e-4 s with stress -rho c v0 = -4.05e6 Pa, and leaves at
+0.1 m/s. Energy 1/2 rho L v0^2 = 39 J.

Stresses: a stiff scene in physical units (K ~ 1e13 N/m per element against M ~ 1e2 kg:
what a scheme's tolerances, penalty parameters or blow-up checks assume about scales
shows here). Time scale 1e-4 s: T = 1.2e-3 s (flight, contact, 1.7 transits of flight
after take-off), nx = 100, dt = 1e-6 s (c dt / h = 0.52; explicit schemes get 0.9 x
their stability limit). Reference: the characteristics solution (exact: piecewise
linear); its contact interval has length 2 L / c to round-off (tests/test_scenes.py).
Its grid has one cell per length L (`contact_bench.exact.uniform_impact`): constant data,
so any grid is exact (the impact instant is inserted), and it agrees with the default grid
to round-off (tests/test_characteristics_runs.py). Provides u, u_t, the contact stress and
the energy.
"""

from __future__ import annotations

from contact_bench.exact.uniform_impact import UniformImpactBar

GAP = 5e-5  # m
SPEED = 0.1  # m/s, towards the obstacle


class SteelBar(UniformImpactBar):
    name = "steel_bar"
    summary = "Siconos ImpactingBar: steel, SI units, gap 5e-5 m, v0 = -0.1 m/s (stiff)"
    L, rho, E, gap, speed = 1.0, 7800.0, 210e9, GAP, SPEED
    T, nx, dt = 1.2e-3, 100, 1e-6
    stiff = True
