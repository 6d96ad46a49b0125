"""The standard scheme: consistent mass, Newmark, contact enforced exactly at t_{n+1}.

This is the reference point of the seed paper (section 5): with a massive contact
node the impact is treated as an instantaneous inelastic shock of that node, so the
energy jumps at impacts (it grows, Fig. 5.3 left) and the contact stress oscillates
(Fig. 5.1-5.2 left).
"""

from __future__ import annotations

from bench.params import Param
from bench.plugin import Scheme, Semidiscrete, Trajectory, Traits
from schemes._newmark import GAMMA, newmark_limit, run_newmark


class Standard(Scheme):
    name = "standard"
    summary = "consistent mass, Newmark, exact contact (Lagrange multiplier at t_{n+1})"
    params = {
        "beta": Param(0.25, "Newmark beta (> 0: implicit)", low=0.0, high=0.5, low_open=True),
        "gamma": GAMMA,
    }

    def traits(self) -> Traits:
        return Traits(implicit=True, massless_contact_node=False, contact="exact",
                      energy="may grow", order=2 if self.gamma == 0.5 else 1)

    def stability_limit(self, h: float, c: float) -> float | None:
        return newmark_limit(self.beta, self.gamma, h, c, lumped=False)

    def integrate(self, semi: Semidiscrete, dt: float, nsteps: int, stride: int) -> Trajectory:
        return run_newmark(semi, dt, nsteps, stride, self.beta, self.gamma)
