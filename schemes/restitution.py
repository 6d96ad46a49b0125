"""Paoli-Schatzman: a two-step scheme with the constraint on (U^{n+1} + e U^{n-1}) / (1 + e).

The scheme (Paoli, Schatzman, SIAM J. Numer. Anal. 40, 2002; for a bar: Paoli,
Schatzman, CMAME 196, 2007; in the comparison of Doyen, Ern, Piperno, SIAM J. Sci.
Comput. 33, 2011) is the central difference in its two-step form, with a stiffness
weight beta (beta = 0: explicit central difference; beta = 1/4: the implicit
two-step form of Crank-Nicolson used by Doyen-Ern-Piperno):

    M (U^{n+1} - 2 U^n + U^{n-1}) / dt^2 + K (beta U^{n+1} + (1 - 2 beta) U^n + beta U^{n-1})
        = F + r^n e0,
    0 <= u0^{n+1} + e u0^{n-1}  _|_  r^n >= 0.

e is Newton's restitution coefficient of the contact node: e = 0 a fully inelastic
impact (u0^{n+1} >= 0 exactly), e = 1 an elastic one. With S = M + beta dt^2 K the
contact force only adds dt^2 r S^{-1} e0, so one step is one solve with S (a diagonal
one for the lumped mass and beta = 0: fully explicit, one fused stencil pass per step in
`contact_bench.kernels.lumped.ps_lumped_kernel`) plus a scalar complementarity.
The literature uses a lumped mass (finite differences): `mass=lumped` is the default;
`consistent` is allowed (then each step solves with M).

Sampling: the state sampled at t_n is (U^n, (U^{n+1} - U^{n-1}) / (2 dt)) and the stress
-r^n (r^n is the force of the step from n to n+1), so the kernel runs one step past
the last sample. The start uses U^{-1} = U^0 - dt V^0 + dt^2/2 A^0. For beta > 0 that
centred velocity is not the trapezoidal rule's, so the sampled energy is not the
scheme's invariant between impacts; GetFEM's demo samples the one that is, and takes
U^1 from a Newmark step (docs/getfem-comparison.md).

Declared: implicit iff beta > 0; stability limit of the central difference (h/c
lumped, h/(c sqrt 3) consistent) scaled like Newmark(beta, 1/2), none for
beta >= 1/4; contact exact for e = 0, and for e > 0 a penetration up to e u0^{n-1},
i.e. O(e dt v_impact): declared bound 4 e dt v with v = `velocity_scale` (max|v0| +
c max|u0'| + sqrt(2 g H)); measured up to 3 e dt v (clamped_bar and dropped_bar, nx =
20 ... 100). Energy: e = 0 only dissipates ("dissipated": never above E(0) beyond
round-off, measured on both scenes; the loss is O(h), 2.5 % at nx = 40); any e > 0
"may grow": e = 0.5 gains 0.5 % on clamped_bar at nx = 160, e = 1 gains up to 10 %
(and 180 % with the consistent mass, beta = 1/4 on dropped_bar at nx = 100).

A massless contact node (mass = seed, getfem, conservative, singular) is refused,
with the reason, because the two-step scheme is not defined or not stable there:
- beta = 0: M00 = 0 and S00 = 0: row 0 reads K0.U^n = F0 + r^n and contains no
  u0^{n+1}; the step has no solution when K0.U^n < F0 and no unique one otherwise.
- beta > 0: the step exists (S is positive definite), but the massless node obeys
  beta u0^{n+1} + (1 - 2 beta) u0^n + beta u0^{n-1} = g^n when free (a double root at
  -1 for beta = 1/4: an undamped, linearly growing (-1)^n mode) and u0^{n+1} = -e u0^{n-1}
  in contact (for e = 1 an undamped period-4 mode). Switching between the two laws
  pumps the mode: with e = 1 it grows exponentially.
- and a massless node has no momentum, so a restitution law for it says nothing: the
  sound treatment of a massless node is its static elimination, which is the
  `redistributed` scheme (or `ode_verlet`), where e plays no role.

GetFEM's NaN. GetFEM's dynamic 1D contact demo (interface/tests/python/
demo_dynamic_contact_1D.py, version = 1, e_PS = 1, mass_matrix_type = 1, beta = 1/4)
gives NaN. Answer: it is the scheme, not (only) that implementation. The demo's
implicit branch also lets the "momentum" MV[0] of the massless node accumulate the
Paoli-Schatzman impulse (a bug: it should stay 0), but the scheme written above,
implemented without that bug (`run_paoli_schatzman`, which skips the guard), blows up
on the same data too, while lumped and consistent masses run fine:

    python -c "from contact_bench.api.fem import mesh_nodes; from contact_bench.api.problem import
    discretise
    from contact_bench.cases.clamped_bar import ClampedBar; from contact_bench.schemes.restitution
    import run_paoli_schatzman
    for m in ('lumped', 'consistent', 'getfem', 'seed'):
        for e in (0.0, 1.0):
            s = discretise(ClampedBar(), mesh_nodes(1.0, 20), m)
            tr = run_paoli_schatzman(s, 0.002, 6000, 100, e, 0.25)
            print(m, e, 'blow-up at t =', tr.blowup_time, 'E_end = %.4g' % tr.energy[-1])"

    lumped 0.0 blow-up at t = None E_end = 0.1165
    lumped 1.0 blow-up at t = None E_end = 0.1249
    consistent 0.0 blow-up at t = None E_end = 0.1173
    consistent 1.0 blow-up at t = None E_end = 0.1267
    getfem 0.0 blow-up at t = None E_end = 0.2186
    getfem 1.0 blow-up at t = 0.6 E_end = 4042
    seed 0.0 blow-up at t = None E_end = 0.8145
    seed 1.0 blow-up at t = 0.4 E_end = 1.856e+16

(clamped_bar, nx = 20, dt = 0.002 and T = 12 as in the demo; exact energy 0.125;
tests/test_schemes_extra.py checks the getfem/lumped contrast). The blow-up comes
before the physical impact at t = 1: the initial disequilibrium of the massless node
excites its (-1)^n mode, which dips below the obstacle, and e = 1 then pumps it. It is
not only a start-up effect: started from the relaxed node (u0 = u1), getfem, e = 1
still blows up at t = 2.2 (beta = 1/4); beta = 0.3 (no double root) blows up at t = 2.4
from the interpolated start. With e = 0 the massless runs do not blow up but their
energy is wrong by a factor 2 to 7 (0.22, 0.81 against 0.125).
A numpy transliteration of the demo's implicit branch (not kept in the repository)
reaches inf at t = 9.9 (redistributed) and 9.1 (singular mass) for e = 1, and runs for
the standard mass. GetFEM's explicit branch (beta = 0) does not run Paoli-Schatzman at all for a
redistributed mass: it sets u0^{n+1} = max(-e u0^{n-1}, -K01 u1^{n+1}) / K00, which
divides the restitution term by K00 (dimensionally inconsistent); it does not blow up.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from contact_bench.api.fem import MASS_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import Semidiscrete, Traits, Trajectory
from contact_bench.core.errors import BenchError
from contact_bench.core.sampling import blown_up, energy_of, is_sample, record_sample
from contact_bench.core.tridiag import factor_pt, pt_solve, tri_matvec
from contact_bench.kernels.common import (
    MassiveContactNodeScheme,
    allocate,
    initial_acceleration,
    trajectory,
    velocity_scale,
)
from contact_bench.kernels.lumped import ps_lumped_kernel
from contact_bench.kernels.newmark import newmark_limit

MASSLESS_REASON = (
    "restitution (Paoli-Schatzman) needs a contact node with mass: with M00 = 0 the "
    "two-step scheme is singular for beta = 0 and its (-1)^n mode at node 0 blows up "
    "for e = 1, beta = 1/4 (see the module docstring); use redistributed or ode_verlet")


@njit(cache=True)
def ps_kernel(Md, Me, Kd, Ke, F, Sd, Se, w, Um, U, V0, dt, beta, e, nsteps, stride,
              offset, t_out, U_out, V_out, cu_out, s_out, E_out):
    """Two-step Paoli-Schatzman from (U^{-1}, U^0); one extra step gives the last velocity."""
    n = U.size
    rhs = np.empty(n)
    tmp = np.empty(n)
    Up = np.empty(n)
    dt2 = dt * dt
    min_u0 = U[0]
    E0 = energy_of(Md, Me, Kd, Ke, F, U, V0, offset)
    t_out[0] = 0.0
    U_out[0, :] = U
    V_out[0, :] = V0
    cu_out[0] = U[0]
    E_out[0] = E0
    k = 1
    for step in range(1, nsteps + 2):
        # S U^{n+1} = M (2 U^n - U^{n-1}) - dt^2 K ((1 - 2 beta) U^n + beta U^{n-1}) + dt^2 F
        for i in range(n):
            tmp[i] = 2.0 * U[i] - Um[i]
        tri_matvec(Md, Me, tmp, rhs)
        for i in range(n):
            tmp[i] = (1.0 - 2.0 * beta) * U[i] + beta * Um[i]
        tri_matvec(Kd, Ke, tmp, Up)
        for i in range(n):
            rhs[i] += dt2 * (F[i] - Up[i])
        pt_solve(Sd, Se, rhs)
        r = 0.0
        gap = rhs[0] + e * Um[0]
        if gap < 0.0:
            r = -gap / (dt2 * w[0])
            for i in range(n):
                rhs[i] += dt2 * r * w[i]
            rhs[0] = -e * Um[0]
        # level n = step - 1 is complete: sample (U^n, (U^{n+1} - U^{n-1}) / 2 dt, -r^n)
        lvl = step - 1
        if lvl == 0:
            s_out[0] = -r
        elif is_sample(lvl, nsteps, stride):
            for i in range(n):
                tmp[i] = (rhs[i] - Um[i]) / (2.0 * dt)
            energy = energy_of(Md, Me, Kd, Ke, F, U, tmp, offset)
            record_sample(k, lvl * dt, U, tmp, -r, energy,
                          t_out, U_out, V_out, cu_out, s_out, E_out)
            k += 1
            if blown_up(energy, E0):
                return k, lvl, min_u0, lvl
        if step == nsteps + 1:
            break
        for i in range(n):
            Um[i] = U[i]
            U[i] = rhs[i]
        if U[0] < min_u0:
            min_u0 = U[0]
    return k, nsteps, min_u0, -1


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
    bufs = (out["t"], out["U"], out["V"], out["cu"], out["s"], out["E"])
    if fast and beta == 0.0 and not np.any(M.off):
        # S = M diagonal: one fused stencil pass per step, no solve (contact_bench.kernels.lumped)
        k, done, min_u0, blow = ps_lumped_kernel(
            M.diag, M.off, K.diag, K.off, semi.F, float(w[0]), Um, U, semi.V0.copy(),
            float(dt), float(e), int(nsteps), int(stride), semi.energy_offset, *bufs)
    else:
        k, done, min_u0, blow = ps_kernel(
            M.diag, M.off, K.diag, K.off, semi.F, Sd, Se, w, Um, U, semi.V0.copy(), float(dt),
            float(beta), float(e), int(nsteps), int(stride), semi.energy_offset, *bufs)
    return trajectory(out, k, done, min_u0, blow, dt)


class Restitution(MassiveContactNodeScheme):
    name = "restitution"
    massless_reason = MASSLESS_REASON
    summary = "Paoli-Schatzman two-step scheme, constraint on (U^{n+1} + e U^{n-1})/(1+e)"
    params = {
        "e": Param(0.0, "restitution coefficient (0 inelastic, 1 elastic)", low=0.0, high=1.0),
        "mass": Param("lumped", "mass matrix (massless contact node kinds are refused)",
                      choices=MASS_KINDS),
        "beta": Param(0.0, "stiffness weight (0: explicit central difference, 1/4: implicit)",
                      low=0.0, high=0.5),
    }

    def traits(self) -> Traits:
        return Traits(implicit=self.beta > 0, massless_contact_node=False,
                      contact="exact" if self.e == 0 else "restitution O(e dt v)",
                      energy="dissipated" if self.e == 0 else "may grow", order=2)

    def stability_limit(self, h: float, c: float) -> float | None:
        return newmark_limit(self.beta, 0.5, h, c, lumped=self.mass == "lumped")

    def penetration_bound(self, semi: Semidiscrete, dt: float) -> float:
        return 4.0 * self.e * dt * velocity_scale(semi)

    def integrate(self, semi: Semidiscrete, dt: float, nsteps: int, stride: int) -> Trajectory:
        self.check_massive(semi)
        return run_paoli_schatzman(semi, dt, nsteps, stride, self.e, self.beta)
