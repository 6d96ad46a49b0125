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
from numba import njit, uint64

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
from contact_bench.core.sampling import blown_up, energy_rows, is_sample, record_sample, row_sums
from contact_bench.core.spike import (
    SPIKE_CUTOFF,
    L,
    record_lane_sample,
    spike_factor,
    spike_solve,
    stencil_solve,
)
from contact_bench.core.tridiag import factor_pt, pt_solve, tri_matvec
from contact_bench.kernels.common import (
    MassiveContactNodeScheme,
    allocate,
    initial_acceleration,
    trajectory,
)
from contact_bench.kernels.lumped import tf_lumped_kernel
from contact_bench.kernels.newmark import kernel_form, newmark_limit
from contact_bench.kernels.sparse import central_sparse
from contact_bench.kernels.sparse_explicit import stable_dt, taylor_flanagan_sparse

#: below this many unknowns (or `contact_bench.kernels.newmark.SPIKE_MIN_DOF_STEPS`
#: dof-steps) a consistent mass steps with the natural-order `taylor_flanagan_kernel`,
#: faster there than the SPIKE form and its set-up: the crossover measured on the
#: project's machine (docs/performance-small-grids.md)
SERIAL_BELOW = 160

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

    def prepare(self, problem, dt: float) -> Stepper:
        # a body: with the lumped mass each contact dof is stopped on its own
        # (`contact_bench.kernels.sparse.central_sparse`); with the consistent one the
        # penetrating dofs are stopped together through the Delassus matrix C M^-1 C^T
        # (`contact_bench.kernels.sparse_explicit.taylor_flanagan_sparse`)
        semi = banded(problem)
        if semi is None:
            if self.mass == "lumped":
                return CallStepper(lambda n, s: central_sparse(problem, dt, n, s))
            return CallStepper(lambda n, s: taylor_flanagan_sparse(problem, dt, n, s))
        self.check_massive(semi)

        def run(nsteps: int, stride: int) -> Trajectory:
            # a lumped M always takes its fused kernel; a banded one the serial
            # natural-order kernel on small problems (`SERIAL_BELOW`), the SPIKE kernel
            # on large ones
            fast = (not np.any(semi.M.off)
                    or kernel_form(semi.nfree, nsteps, serial_below=SERIAL_BELOW) == "spike")
            return run_taylor_flanagan(semi, dt, nsteps, stride, fast)

        return CallStepper(run)


@njit(cache=True)
def taylor_flanagan_kernel(Md, Me, Kd, Ke, F, Sd, Se, w, U, V, A, dt, nsteps, stride, offset,
                           t_out, U_out, V_out, cu_out, s_out, E_out):
    """Advance (U, V, A) in place; returns (samples, steps, min u0, blow-up step)."""
    n = U.size
    KU = np.empty(n)
    min_u0 = U[0]
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    E0 = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
    t_out[0] = 0.0
    U_out[0, :] = U
    V_out[0, :] = V
    cu_out[0] = U[0]
    s_out[0] = 0.0
    E_out[0] = E0
    k = 1
    for step in range(1, nsteps + 1):
        for i in range(n):
            U[i] += dt * V[i] + 0.5 * dt * dt * A[i]
            V[i] += 0.5 * dt * A[i]
        lam = 0.0
        if U[0] < 0.0:
            lam = -V[0] / (dt * w[0])
            if lam < 0.0:
                lam = 0.0
            for i in range(n):
                U[i] += dt * dt * lam * w[i]
                V[i] += dt * lam * w[i]
        tri_matvec(Kd, Ke, U, KU)
        for i in range(n):
            A[i] = F[i] - KU[i]
        pt_solve(Sd, Se, A)
        for i in range(n):
            V[i] += 0.5 * dt * A[i]
        if U[0] < min_u0:
            min_u0 = U[0]
        if is_sample(step, nsteps, stride):
            energy = energy_rows(rM, Me, rK, Ke, F, U, V, offset)
            record_sample(k, step * dt, U, V, -lam, energy,
                          t_out, U_out, V_out, cu_out, s_out, E_out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1


@njit(cache=True, fastmath={"contract"})
def tf_spike_kernel(Md, Me, Kd, Ke, F, Kdl, Klo, Fl, fac, wpos, wval, w0, U, V, A, z, coef,
                    dt, nsteps, stride, offset, t_out, U_out, V_out, cu_out, s_out, E_out):
    """`taylor_flanagan_kernel` in the lane-interleaved layout of `contact_bench.core.spike` (U, V,
    A, z interleaved; fac = `Spike.factors()` of M). Same update, samples, stress, min
    u0 and blow-up step.

    w = M^-1 e0 enters as its entries above `SPIKE_CUTOFF` x w0 (positions wpos, values
    wval: w decays by 2 - sqrt 3 per node, a few dozen entries). Between samples the
    closing half kick of a step and the next step's drift and half kick are one pass
    (the same operations, in the same order, as the reference kernel's loops).
    """
    m, nodes = fac[9], fac[10]
    N = L * m
    h = 0.5 * dt
    h2 = 0.5 * dt * dt
    dt2 = dt * dt
    min_u0 = U[0]
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    E0 = record_lane_sample(0, 0.0, nodes, U, V, 0.0, rM, Me, rK, Ke, F, offset,
                            t_out, U_out, V_out, cu_out, s_out, E_out)
    k = 1
    drifted = False  # U, V already hold this step's drift and half kick
    for step in range(1, nsteps + 1):
        if not drifted:
            for p in range(N):
                pu = uint64(p)
                U[pu] = U[pu] + (dt * V[pu] + h2 * A[pu])
                V[pu] = V[pu] + h * A[pu]
        lam = 0.0
        if U[0] < 0.0:
            lam = -V[0] / (dt * w0)
            if lam < 0.0:
                lam = 0.0
            cu = dt2 * lam
            cv = dt * lam
            for q in range(wpos.size):
                p = wpos[q]
                U[p] += cu * wval[q]
                V[p] += cv * wval[q]
        # A^{n+1} = M^-1 (F - K U^{n+1})
        stencil_solve(Kdl, Klo, U, Fl, -1.0, fac, z, coef)
        A, z = z, A  # the old A is the next solve's scratch
        u0 = U[0]
        if u0 < min_u0:
            min_u0 = u0
        sample = step % stride == 0 or step == nsteps
        if sample:
            for p in range(N):
                pu = uint64(p)
                V[pu] = V[pu] + h * A[pu]
        else:  # closing half kick, next drift and half kick
            for p in range(N):
                pu = uint64(p)
                a = A[pu]
                v = V[pu] + h * a
                U[pu] = U[pu] + (dt * v + h2 * a)
                V[pu] = v + h * a
        drifted = not sample
        if sample:
            energy = record_lane_sample(k, step * dt, nodes, U, V, -lam, rM, Me, rK, Ke, F,
                                        offset, t_out, U_out, V_out, cu_out, s_out, E_out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
    return k, nsteps, min_u0, -1


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
    bufs = (out["t"], out["U"], out["V"], out["cu"], out["s"], out["E"])
    if fast and np.any(M.off):
        sp = spike_factor(M.diag, M.off)
        fac = sp.factors()
        lo, invd, sa, sb, Hrow, Hpos, Hval, ja, jb, m, nodes = fac
        w = sp.zeros()  # w = M^-1 e0, interleaved; node 0 is at position 0
        w[0] = 1.0
        spike_solve(lo, invd, sa, sb, Hrow, Hpos, Hval, m, ja, jb, w, np.zeros(2 * sp.lanes + 1))
        wpos = np.flatnonzero(np.abs(w) > SPIKE_CUTOFF * abs(w[0]))
        k, done, min_u0, blow = tf_spike_kernel(
            M.diag, M.off, K.diag, K.off, semi.F, sp.to_lanes(K.diag), sp.lower_to_lanes(K.off),
            sp.to_lanes(semi.F), fac, wpos, w[wpos], float(w[0]), sp.to_lanes(U),
            sp.to_lanes(V), sp.to_lanes(A), sp.zeros(), np.zeros(2 * sp.lanes + 1), float(dt),
            int(nsteps), int(stride), semi.energy_offset, *bufs)
        return trajectory(out, k, done, min_u0, blow, dt)
    Sd, Se = factor_pt(M.diag, M.off)
    w = np.zeros(semi.nfree)
    w[0] = 1.0
    pt_solve(Sd, Se, w)
    if fast:
        k, done, min_u0, blow = tf_lumped_kernel(
            M.diag, M.off, K.diag, K.off, semi.F, float(w[0]), U, V, A, float(dt),
            int(nsteps), int(stride), semi.energy_offset, *bufs)
    else:
        k, done, min_u0, blow = taylor_flanagan_kernel(
            M.diag, M.off, K.diag, K.off, semi.F, Sd, Se, w, U, V, A, float(dt), int(nsteps),
            int(stride), semi.energy_offset, *bufs)
    return trajectory(out, k, done, min_u0, blow, dt)
