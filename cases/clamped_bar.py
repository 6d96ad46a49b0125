"""The clamped bar (Chouly, Hild, Renard 2015; GetFEM's dynamic 1D contact test).

L = 1, rho = E = 1, g = 0, u0 = 1/2 - x/2, v0 = 0, clamped at x = 1 (u = 0). The
bar, compressed against nothing, is released: the end at x = 0 moves down, hits the
obstacle at t = 1, stays in contact until t = 2 with stress -1/2 and flies off; the
motion is periodic with period 3 and the energy is 1/8.

Reference: the closed form `contact_bench.exact.clamped.ClampedBarExact`; as reference
quantities, the first contact's duration 1 and the peak contact force 1/2.
Stresses this scene: a kinked, piecewise-linear solution with repeated impacts.
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.plugin import Case
from contact_bench.exact.clamped import ClampedBarExact


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

    quantities = frozenset({"contact_duration", "peak_force"})

    def quantity_errors(self, problem, traj, row) -> dict[str, float]:
        """Relative errors of the first contact's duration (its run of samples with a
        contact force, plus one sample spacing) and of the peak contact force."""
        force = -np.asarray(traj.stress)
        out = {"err_peak_force": abs(float(np.max(force, initial=0.0)) / 0.5 - 1.0)}
        on = np.flatnonzero(force > 0.0)
        if on.size and traj.t.size > 1:
            a = on[0]
            off = np.flatnonzero(force[a:] <= 0.0)
            if off.size:  # the first contact ended within the run
                b = a + off[0] - 1
                duration = traj.t[b] - traj.t[a] + (traj.t[1] - traj.t[0])
                out["err_contact_duration"] = abs(float(duration) - 1.0)
        return out

    def exact(self, T: float) -> ClampedBarExact:
        return ClampedBarExact()

    @property
    def exact_energy(self) -> float:
        return 0.125
