"""Paoli-Schatzman: a two-step scheme with the constraint on (U^{n+1} + e U^{n-1}) / (1 + e).

The central difference in its two-step form, with a stiffness weight beta (0: explicit,
1/4: implicit, as in Doyen, Ern, Piperno 2011; Paoli, Schatzman 2002):

    M (U^{n+1} - 2 U^n + U^{n-1}) / dt^2 + K (beta U^{n+1} + (1 - 2 beta) U^n + beta U^{n-1})
        = F + r^n e0,      0 <= u0^{n+1} + e u0^{n-1}  _|_  r^n >= 0.

e is Newton's restitution coefficient of the contact node (0 inelastic, 1 elastic). One
step is one solve with S = M + beta dt^2 K (a diagonal one for the default lumped mass
and beta = 0: a fused stencil pass, `contact_bench.kernels.lumped.ps_lumped_kernel`)
plus a scalar complementarity. The sample at t_n is (U^n, (U^{n+1} - U^{n-1}) / 2 dt)
with stress -r^n, so the kernel runs one step past the last sample. For beta > 0 that
centred velocity is not the trapezoidal rule's, so the sampled energy is not the scheme's
invariant between impacts (GetFEM's demo samples the one that is: docs/getfem-comparison.md).

A massless contact node is refused: there the two-step scheme is singular (beta = 0) or
has an undamped mode that e = 1 pumps (beta > 0). Declared bounds, their measurements
and why GetFEM's demo gives NaN: docs/schemes.md and docs/comparisons.md.
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.fem import MASS_ALIASES, MASS_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import (
    CallStepper,
    Contact,
    Energy,
    Semidiscrete,
    Stepper,
    Traits,
    Trajectory,
)
from contact_bench.api.problem import banded
from contact_bench.core.errors import BenchError
from contact_bench.core.tridiag import Implicit, factor_pt, pt_solve
from contact_bench.kernels.common import (
    MassiveContactNodeScheme,
    allocate,
    bar_ops,
    initial_acceleration,
    run_spec,
    trajectory,
    velocity_scale,
)
from contact_bench.kernels.lumped import ps_lumped_kernel
from contact_bench.kernels.newmark import newmark_limit
from contact_bench.kernels.paoli_schatzman import ps_kernel
from contact_bench.kernels.sparse_explicit import stable_dt
from contact_bench.kernels.sparse_impact import prepare_paoli_schatzman

MASSLESS_REASON = (
    "restitution (Paoli-Schatzman) needs a contact node with mass: with M00 = 0 the "
    "two-step scheme is singular for beta = 0 and its (-1)^n mode at node 0 blows up "
    "for e = 1, beta = 1/4 (docs/comparisons.md); use redistributed or ode_verlet")


class Restitution(MassiveContactNodeScheme):
    name = "restitution"
    massless_reason = MASSLESS_REASON
    summary = "Paoli-Schatzman two-step scheme, constraint on (U^{n+1} + e U^{n-1})/(1+e)"
    params = {
        "e": Param(0.0, "restitution coefficient (0 inelastic, 1 elastic)", low=0.0, high=1.0,
                   sweep=(0.0, 0.5, 1.0)),
        "mass": Param("lumped", "mass matrix (massless contact node kinds are refused)",
                      choices=MASS_KINDS, aliases=MASS_ALIASES),
        "beta": Param(0.0, "stiffness weight (0: explicit central difference, 1/4: implicit)",
                      low=0.0, high=0.5),
    }

    def traits(self, problem=None) -> Traits:
        return Traits(implicit=self.beta > 0, massless_contact_node=False,
                      contact=Contact.EXACT if self.e == 0 else Contact.RESTITUTION,
                      energy=Energy.DISSIPATED if self.e == 0 else Energy.MAY_GROW, order=2)

    def stability_limit(self, problem) -> float | None:
        if banded(problem) is None:
            # the two-step scheme is Newmark(beta, 1/2) between impacts (the projection
            # adds no stiffness): 1 / (sqrt(1/4 - beta) omega_max), omega_max the mesh's
            # own largest frequency (the 1D formula does not bound 2D/3D elements'); none
            # for beta >= 1/4, as in 1D
            return stable_dt(problem, self.beta, 0.5)
        return newmark_limit(self.beta, 0.5, problem.hmin, problem.c_max,
                             lumped=self.mass == "lumped")

    def penetration_bound(self, problem, dt: float) -> float:
        return 4.0 * self.e * dt * velocity_scale(banded(problem))

    def follows_curved_obstacle(self) -> bool:
        return True  # its sparse stepper re-linearises the gaps every step

    def adds_time_load(self) -> bool:
        return True  # the two-step scheme adds it at the centre level t_n

    def prepare(self, problem, dt: float) -> Stepper:
        # a body: the same two-step scheme, the impact law on every contact dof (a per-dof
        # projection with a lumped mass and beta = 0, else the LCP on the Delassus matrix
        # of S = M + beta dt^2 K: `contact_bench.kernels.sparse_impact`)
        semi = banded(problem)
        if semi is not None:
            self.check_massive(semi)
            return CallStepper(lambda n, s: run_paoli_schatzman(semi, dt, n, s, self.e,
                                                                self.beta))
        return prepare_paoli_schatzman(problem, dt, self.e, self.beta)


def run_paoli_schatzman(semi: Semidiscrete, dt: float, nsteps: int, stride: int,
                        e: float, beta: float, fast: bool = True) -> Trajectory:
    """The scheme on any mass (no massless guard: used to show what a massless node does).

    A diagonal S (lumped mass, beta = 0) takes the fused kernel of `contact_bench.kernels.lumped`
    unless `fast` is False (then the generic `ps_kernel`, its reference in the tests).
    """
    M, K = semi.M, semi.K
    bdt2 = beta * dt * dt
    try:
        Sd, Se = factor_pt(M.diag + bdt2 * K.diag, M.off + bdt2 * K.off)
    except BenchError:
        raise BenchError("restitution: M + beta dt^2 K is singular (massless contact node "
                         "with beta = 0): the two-step scheme has no equation for u0") from None
    w = np.zeros(semi.nfree)
    w[0] = 1.0
    pt_solve(Sd, Se, w)
    U = semi.U0.copy()
    A0 = initial_acceleration(semi)
    Um = U - dt * semi.V0 + 0.5 * dt * dt * A0
    out = allocate(semi, nsteps, stride)
    bar, run = bar_ops(semi), run_spec(semi, dt, nsteps, stride)
    if fast and beta == 0.0 and not np.any(M.off):
        # S = M diagonal: one fused stencil pass per step, no solve (contact_bench.kernels.lumped)
        k, done, min_u0, blow = ps_lumped_kernel(
            bar, float(w[0]), Um, U, semi.V0.copy(), float(e), run, out)
    else:
        k, done, min_u0, blow = ps_kernel(
            bar, Implicit(Sd, Se, w), Um, U, semi.V0.copy(), (float(beta), float(e)), run, out)
    return trajectory(out, k, done, min_u0, blow, dt)
