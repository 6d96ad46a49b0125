"""Laursen and Love (2002): exact contact at t_{n+1}, then an energy-restoring velocity
update on the contact dofs.

The implicit midpoint rule, M (V1 - V0) / dt + K (U0 + U1) / 2 = F + C^T lambda, with
exact Signorini at t_{n+1} (g_{n+1} >= 0, lambda >= 0, lambda . g_{n+1} = 0). The step
changes the energy by lambda . (g_{n+1} - g_n) = -lambda . g_n: it loses
D = lambda . g_n >= 0 in a step where a dof arrives from an open gap (nothing while it
stays in contact). The velocity update V1 += s M^-1 C^T lambda, s >= 0 the root of
1/2 s^2 lambda.C M^-1 C^T.lambda + s lambda.(C V1) = D, gives it back: the energy
balance holds to round-off and the contact stays exact (U1 is not changed).

Reading chosen (the update's direction is not fixed by the energy balance alone): an
impulse along the step's own contact force lambda, weighted by M^-1, so that only the
dofs that pushed are kicked and the kick is outward. GetFEM's minimal variant
(tests/dynamic_friction.cc, scheme 7) reflects the mean normal velocity of the active
dofs instead (v_N^{n+1} = -v_N^n, the contact on the midpoint displacement), which does
not restore the energy exactly in general. Exact contact at a time level: Doyen, Ern,
Piperno's exact class. Kernel: `contact_bench.kernels.energy_conserving`.
Measurements: docs/schemes.md.
"""

from __future__ import annotations

from contact_bench.api.plugin import (
    Contact,
    Energy,
    Family,
    Scheme,
    Stepper,
    Traits,
    on_curved_obstacle,
)
from contact_bench.kernels.energy_conserving import (
    SIGNORINI_VELOCITY_UPDATE,
    prepare_midpoint_contact,
)

#: the drift the restored balance keeps (relative, over a run): round-off of the sums
ROUNDOFF_DRIFT = 1e-9


class LaursenLove(Scheme):
    name = "laursen_love"
    summary = ("midpoint rule, exact contact at t_{n+1}, velocity update restoring the "
               "energy")
    params = {}

    def traits(self, problem=None) -> Traits:
        return Traits(implicit=True, massless_contact_node=False, contact=Contact.EXACT,
                      energy=Energy.MAY_GROW if on_curved_obstacle(problem)
                      else Energy.CONSERVED, order=2, family=Family.EXACT)

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        return ROUNDOFF_DRIFT

    def follows_curved_obstacle(self) -> bool:
        return True  # its sparse stepper re-linearises the gaps every step

    def adds_time_load(self) -> bool:
        return True  # the body's midpoint step adds it at t_{n+1/2}

    def prepare(self, problem, dt: float) -> Stepper:
        # the bar (its CSR matrices) and a body: one compiled midpoint step
        return prepare_midpoint_contact(problem, dt, SIGNORINI_VELOCITY_UPDATE)
