"""The paper's Lipschitz ODE (P_U^mod) by Stormer-Verlet with a fixed step.

With a massless contact node the semi-discrete problem is an ODE in the other nodes
(Dabaghi, Petrov, Pousin, Renard 2014, section 4):

    M_bar U_bar'' + K_bar U_bar = F_bar - C u0(U_bar),  u0 = max(0, (F0 - K01 u1) / K00),

with a Lipschitz right-hand side, so any ODE integrator applies. Here velocity Verlet:
V += dt/2 A(U); U += dt V; V += dt/2 A(U), one solve with M_bar per step (factored once;
`verlet_spike_kernel` on the SPIKE factors of `contact_bench.core.spike`, checked against
the natural-order `verlet_kernel`). The contact node is not a state: u0 = u0(u1) at
every step, v0 its exact derivative. Algebraically the same update as
`redistributed[beta=0]`, written from the ODE. Declared bounds and their measurements:
docs/schemes.md. On the general sparse problem: the massless contact dofs solved from
their rows with exact contact, their velocity the exact derivative
(`contact_bench.kernels.sparse_family.verlet_sparse`).
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.fem import MASS_ALIASES, REDISTRIBUTED_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import (
    CallStepper,
    Contact,
    Energy,
    Scheme,
    Semidiscrete,
    Stepper,
    Traits,
    Trajectory,
)
from contact_bench.api.problem import banded
from contact_bench.core.spike import spike_factor
from contact_bench.core.tridiag import BarState, factor_pt
from contact_bench.kernels.common import allocate, bar_ops, run_spec, trajectory
from contact_bench.kernels.massless_ode import verlet_kernel, verlet_spike_kernel
from contact_bench.kernels.newmark import EXPLICIT_SERIAL_BELOW as SERIAL_BELOW
from contact_bench.kernels.newmark import LaneStiffness, kernel_form, newmark_limit
from contact_bench.kernels.sparse_family import massless_ode_omega, prepare_verlet


class OdeVerlet(Scheme):
    name = "ode_verlet"
    summary = "the paper's Lipschitz ODE (P_U^mod) by Stormer-Verlet, fixed step"
    params = {
        "variant": Param("first_element_massless", "where the first element's mass goes",
                         choices=REDISTRIBUTED_KINDS, aliases=MASS_ALIASES),
    }

    def mass_kind(self) -> str:
        return self.variant

    def traits(self, problem=None) -> Traits:
        return Traits(implicit=False, massless_contact_node=True, contact=Contact.EXACT,
                      energy=Energy.CONSERVED, order=2)

    def stability_limit(self, problem) -> float | None:
        if banded(problem) is None:
            # the 1D formula at the problem's hmin is too large in 2D and 3D: the ODE's
            # own largest frequency (docs/sparse.md)
            return 2.0 / massless_ode_omega(problem)
        return newmark_limit(0.0, 0.5, problem.hmin, problem.c_max, lumped=False,
                             first_element_massless=self.variant == "first_element_massless")

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        return 2.0 * (problem.c_max * dt / problem.hmin) ** 2

    def follows_curved_obstacle(self) -> bool:
        return True  # its sparse stepper re-linearises the gaps every step

    def adds_time_load(self) -> bool:
        # Verlet's acceleration and massless rows at U_{n+1} add it at t_{n+1}
        return True

    def prepare(self, problem, dt: float) -> Stepper:
        # a body: velocity Verlet on the dofs with mass, the massless ones solved from
        # their rows (`contact_bench.kernels.sparse_family.verlet_sparse`)
        semi = banded(problem)
        if semi is None:
            return prepare_verlet(problem, dt)

        def run(nsteps: int, stride: int) -> Trajectory:
            fast = kernel_form(semi.nfree, nsteps, serial_below=SERIAL_BELOW) == "spike"
            return run_ode_verlet(semi, dt, nsteps, stride, fast)

        return CallStepper(run)


def run_ode_verlet(semi: Semidiscrete, dt: float, nsteps: int, stride: int,
                   fast: bool = True) -> Trajectory:
    """Velocity Verlet on (P_U^mod): `verlet_spike_kernel` on the SPIKE factors of M_bar
    (node 0 decoupled), or with `fast` False the natural-order `verlet_kernel` (its
    reference in tests/test_spike_ports.py)."""
    M, K = semi.M, semi.K
    n = semi.nfree
    if n < 2:
        raise ValueError("ode_verlet needs at least one node besides the contact node")
    U, V = semi.U0.copy(), semi.V0.copy()
    out = allocate(semi, nsteps, stride)
    bar, run = bar_ops(semi), run_spec(semi, dt, nsteps, stride)
    if fast:
        d, e = M.diag.copy(), M.off.copy()
        d[0], e[0] = 1.0, 0.0  # node 0 decoupled: M_bar on nodes 1.. plus an identity row
        sp = spike_factor(d, e)
        lanes = LaneStiffness(sp.to_lanes(K.diag), sp.lower_to_lanes(K.off),
                              sp.to_lanes(semi.F), sp.factors())
        state = BarState(sp.to_lanes(U), sp.to_lanes(V), sp.zeros())
        k, done, min_u0, blow = verlet_spike_kernel(
            bar, lanes, state, sp.zeros(), np.zeros(2 * sp.lanes + 1), run, out)
    else:
        Sd, Se = factor_pt(M.diag[1:], M.off[1:])
        k, done, min_u0, blow = verlet_kernel(bar, Sd, Se, U, V, run, out)
    return trajectory(out, k, done, min_u0, blow, dt)
