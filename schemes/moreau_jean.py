"""Moreau-Jean: velocity-level Newton impact law with the theta-method (as in Siconos).

The time-stepping scheme of Moreau and Jean (Jean 1999; Acary, Brogliato 2008, ch. 10;
Siconos' `MoreauJeanOSI`) for M u'' + K u = F + p e0:

    M (V^{n+1} - V^n) = dt (F - K (theta U^{n+1} + (1 - theta) U^n)) + P^{n+1} e0,
    U^{n+1} = U^n + dt (theta V^{n+1} + (1 - theta) V^n),

one solve per step with M + theta^2 dt^2 K, factored once. Contact is detected on the
predicted gap u0^n + dt/2 v0^n <= 0; the impulse P >= 0 then satisfies the Newton law
0 <= v0^{n+1} + e v0^n _|_ P. The reported contact stress is -P / dt.

The constraint holds on velocities only, so the end may penetrate by O(dt v_impact).
Friction (a body's `ContactSet.friction`): the Coulomb cone on velocities, as Siconos'
MoreauJeanOSI with its NSGS: the impulses (P_n, P_t) of the points in the index set
solve Newton's law on v_n and Coulomb's on v_t^{n+1} (`contact_bench.kernels.contact.
coulomb`); mu = 0 is the frictionless step itself. A massless contact node is refused:
it has no momentum for an impact law to act on (`redistributed` is the sound treatment).
Declared bounds and their measurements: docs/schemes.md.
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.fem import MASS_ALIASES, MASS_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import (
    CallStepper,
    Contact,
    Energy,
    Stepper,
    Traits,
    Trajectory,
)
from contact_bench.api.problem import banded
from contact_bench.core.tridiag import Implicit, factor_pt, pt_solve
from contact_bench.kernels.common import (
    MassiveContactNodeScheme,
    allocate,
    bar_ops,
    run_spec,
    trajectory,
    velocity_scale,
)
from contact_bench.kernels.moreau_jean import moreau_jean_kernel
from contact_bench.kernels.sparse_impact import prepare_moreau_jean

MASSLESS_REASON = ("moreau_jean needs a contact node with mass: a velocity impact law "
                   "does not determine a massless node (use redistributed)")


class MoreauJean(MassiveContactNodeScheme):
    name = "moreau_jean"
    massless_reason = MASSLESS_REASON
    summary = "Moreau-Jean theta-method, Newton impact law on velocities (Siconos)"
    params = {
        "e": Param(0.0, "Newton restitution coefficient", low=0.0, high=1.0,
                   sweep=(0.0, 0.5, 1.0)),
        "theta": Param(0.5, "theta of the theta-method", low=0.5, high=1.0),
        "mass": Param("consistent", "mass matrix (massless contact node kinds are refused)",
                      choices=MASS_KINDS, aliases=MASS_ALIASES),
    }

    def traits(self, problem=None) -> Traits:
        conserved = self.e == 1 and self.theta == 0.5
        return Traits(implicit=True, massless_contact_node=False,
                      contact=Contact.VELOCITY_LEVEL,
                      energy=Energy.CONSERVED if conserved else Energy.DISSIPATED,
                      order=2 if self.theta == 0.5 else 1, friction=True)

    def penetration_bound(self, problem, dt: float) -> float:
        return 4.0 * dt * velocity_scale(banded(problem))

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        return 1e-8 if self.e == 1 and self.theta == 0.5 else None

    def follows_curved_obstacle(self) -> bool:
        return True  # its sparse stepper re-linearises the gaps every step

    def adds_time_load(self) -> bool:
        return True  # the body's theta-method adds it at its theta point t_n + theta dt

    def prepare(self, problem, dt: float) -> Stepper:
        # a body: the same step, Newton's law on the contact dofs whose predicted gap is
        # <= 0 (the LCP on the Delassus matrix of M + theta^2 dt^2 K); the sampled stress
        # is the impulse over dt (`contact_bench.kernels.sparse_impact.moreau_jean_sparse`)
        semi = banded(problem)
        if semi is not None:
            return CallStepper(lambda n, s: self.run_bar(semi, dt, n, s))
        return prepare_moreau_jean(problem, dt, self.e, self.theta)

    def run_bar(self, semi, dt: float, nsteps: int, stride: int) -> Trajectory:
        """The bar's step on the tridiagonal bands (`moreau_jean_kernel`)."""
        self.check_massive(semi)
        M, K = semi.M, semi.K
        t2 = (self.theta * dt) ** 2
        Sd, Se = factor_pt(M.diag + t2 * K.diag, M.off + t2 * K.off)
        w = np.zeros(semi.nfree)
        w[0] = 1.0
        pt_solve(Sd, Se, w)
        U, V = semi.U0.copy(), semi.V0.copy()
        out = allocate(semi, nsteps, stride)
        k, done, min_u0, blow = moreau_jean_kernel(
            bar_ops(semi), Implicit(Sd, Se, w), U, V, float(self.theta), float(self.e),
            run_spec(semi, dt, nsteps, stride), out)
        return trajectory(out, k, done, min_u0, blow, dt)

