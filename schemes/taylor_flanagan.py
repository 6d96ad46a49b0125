"""Taylor-Flanagan / Carpenter: explicit central difference, a contact force that stops the node.

The explicit contact treatment of PRONTO-type codes (Taylor, Flanagan 1989; Carpenter,
Taylor, Katona 1991), as in GetFEM's dynamic 1D contact demo (version = 4):

    U1 = U + dt V + dt^2/2 A,   V_half = V + dt/2 A;
    if U1[0] < 0: lam = max(0, -V_half[0] / (dt w0)), w = M^{-1} e0,
        U1 += dt^2 lam w, V_half += dt lam w   (the contact node's velocity becomes 0);
    A1 = M^{-1} (F - K U1),   V1 = V_half + dt/2 A1.

The reported stress is -lam; the node is stopped where it was, so it never penetrates.
Energy "may grow": stopping the node removes kinetic energy, but the position
correction dt^2 lam w moves the bar against the load, so a contact held under gravity
gains energy at every step (docs/schemes.md).
Lumped mass: one fused pass per step (`contact_bench.kernels.lumped.tf_lumped_kernel`);
consistent (default): one solve with M per step on SPIKE factors (`tf_spike_kernel`);
`taylor_flanagan_kernel` is the natural-order reference of both. A massless contact
node is refused: it has no velocity to stop (`redistributed[beta=0]` is its static
elimination). Declared bounds and their measurements: docs/schemes.md.
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
from contact_bench.core.spike import (
    SPIKE_CUTOFF,
    spike_factor,
    spike_solve,
)
from contact_bench.core.tridiag import BarState, Implicit, factor_pt, pt_solve
from contact_bench.kernels.common import (
    MassiveContactNodeScheme,
    allocate,
    bar_ops,
    initial_acceleration,
    run_spec,
    trajectory,
)
from contact_bench.kernels.lumped import tf_lumped_kernel
from contact_bench.kernels.newmark import EXPLICIT_SERIAL_BELOW as SERIAL_BELOW
from contact_bench.kernels.newmark import LaneStiffness, kernel_form, newmark_limit
from contact_bench.kernels.sparse import prepare_central
from contact_bench.kernels.sparse_explicit import prepare_taylor_flanagan, stable_dt
from contact_bench.kernels.taylor_flanagan import (
    SparseResponse,
    taylor_flanagan_kernel,
    tf_spike_kernel,
)

MASSLESS_REASON = ("taylor_flanagan needs a contact node with mass (there is no velocity to "
                   "stop); with a massless node it is redistributed[beta=0]")


class TaylorFlanagan(MassiveContactNodeScheme):
    name = "taylor_flanagan"
    massless_reason = MASSLESS_REASON
    summary = "explicit central difference; contact force that stops the contact node"
    params = {
        "mass": Param("consistent", "mass matrix (massless contact node kinds are refused)",
                      choices=MASS_KINDS, aliases=MASS_ALIASES),
    }

    def traits(self, problem=None) -> Traits:
        return Traits(implicit=False, massless_contact_node=False,
                      contact=Contact.EXACT, energy=Energy.MAY_GROW, order=2)

    def stability_limit(self, problem) -> float | None:
        if banded(problem) is None:
            # the mesh's largest eigenvalue (the 1D formula does not bound 2D/3D elements')
            return stable_dt(problem, 0.0, 0.5)
        return newmark_limit(0.0, 0.5, problem.hmin, problem.c_max,
                             lumped=self.mass == "lumped")

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        # no claim: the position correction dt^2 lam w works against the load, so a
        # contact held under gravity gains energy at every step (module docstring)
        return None

    def adds_time_load(self) -> bool:
        return True  # the central difference's acceleration at U_n adds it at t_n

    def prepare(self, problem, dt: float) -> Stepper:
        # a body: with the lumped mass each contact dof is stopped on its own
        # (`contact_bench.kernels.sparse.central_sparse`); with the consistent one the
        # penetrating dofs are stopped together through the Delassus matrix C M^-1 C^T
        # (`contact_bench.kernels.sparse_explicit.taylor_flanagan_sparse`)
        semi = banded(problem)
        if semi is None:
            if self.mass == "lumped":
                return prepare_central(problem, dt)
            return prepare_taylor_flanagan(problem, dt)
        self.check_massive(semi)

        def run(nsteps: int, stride: int) -> Trajectory:
            # a lumped M always takes its fused kernel; a banded one the serial
            # natural-order kernel on small problems (`SERIAL_BELOW`), the SPIKE kernel
            # on large ones
            fast = (not np.any(semi.M.off)
                    or kernel_form(semi.nfree, nsteps, serial_below=SERIAL_BELOW) == "spike")
            return run_taylor_flanagan(semi, dt, nsteps, stride, fast)

        return CallStepper(run)


def run_taylor_flanagan(semi: Semidiscrete, dt: float, nsteps: int, stride: int,
                        fast: bool = True) -> Trajectory:
    """The scheme on a massive contact node.

    With `fast` (the default) a diagonal M (lumped) takes the fused kernel of
    `contact_bench.kernels.lumped`, any other M `tf_spike_kernel` on the SPIKE factors of M; with
    `fast` False the natural-order `taylor_flanagan_kernel`, their reference in the tests.
    """
    M, K = semi.M, semi.K
    U, V = semi.U0.copy(), semi.V0.copy()
    A = initial_acceleration(semi)
    out = allocate(semi, nsteps, stride)
    bar, run = bar_ops(semi), run_spec(semi, dt, nsteps, stride)
    if fast and np.any(M.off):
        sp = spike_factor(M.diag, M.off)
        fac = sp.factors()
        w = sp.zeros()  # w = M^-1 e0, interleaved; node 0 is at position 0
        w[0] = 1.0
        spike_solve(fac, w, np.zeros(2 * sp.lanes + 1))
        wpos = np.flatnonzero(np.abs(w) > SPIKE_CUTOFF * abs(w[0]))
        lanes = LaneStiffness(sp.to_lanes(K.diag), sp.lower_to_lanes(K.off),
                              sp.to_lanes(semi.F), fac)
        state = BarState(sp.to_lanes(U), sp.to_lanes(V), sp.to_lanes(A))
        k, done, min_u0, blow = tf_spike_kernel(
            bar, lanes, SparseResponse(wpos, w[wpos], float(w[0])), state, sp.zeros(),
            np.zeros(2 * sp.lanes + 1), run, out)
        return trajectory(out, k, done, min_u0, blow, dt)
    Sd, Se = factor_pt(M.diag, M.off)
    w = np.zeros(semi.nfree)
    w[0] = 1.0
    pt_solve(Sd, Se, w)
    if fast:
        k, done, min_u0, blow = tf_lumped_kernel(bar, float(w[0]), BarState(U, V, A), run, out)
    else:
        k, done, min_u0, blow = taylor_flanagan_kernel(
            bar, Implicit(Sd, Se, w), BarState(U, V, A), run, out)
    return trajectory(out, k, done, min_u0, blow, dt)
