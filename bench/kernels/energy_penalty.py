"""The energy-conserving penalty step (Armero and Petocz 1998) on the general problem.

The implicit midpoint rule in first-order form, the penalty springs entering through the
discrete gradient of their energy Phi(g) = kappa/2 min(0, g)^2 (one spring per contact
dof, g_i = gap0_i + U[dof_i]):

    M (V_{n+1} - V_n) / dt = F - K (U_n + U_{n+1}) / 2 + C^T f,   (F at t_{n+1/2})
    (U_{n+1} - U_n) / dt = (V_n + V_{n+1}) / 2,
    f_i = -(Phi_i(g_{n+1,i}) - Phi_i(g_{n,i})) / (g_{n+1,i} - g_{n,i})   (>= 0),

the quotient read as Phi_i' where the two gaps are equal. Dotting the first line with
U_{n+1} - U_n gives E_{n+1} = E_n exactly for E = 1/2 V.M.V + 1/2 U.K.U - F.U +
sum_i Phi_i(g_i): the scheme conserves that energy up to the round-off of the solves.

Eliminating V_{n+1}: S U_{n+1} = M (U_n + dt V_n) + dt^2/2 F - dt^2/4 K U_n + dt^2/2
C^T f with S = M + dt^2/4 K (factored once, `Factor`). With the contact-free solution
X_f, the gaps solve the n_c x n_c system

    R(g) = g - g_f - dt^2/2 W f(g) = 0,   W = C S^-1 C^T (computed once, no n x n_c
    matrix kept: the correction S^-1 C^T f is a second solve),

f_i depending on g_i alone. Each -f_i is the secant slope of the convex Phi_i between
g_{n,i} and g_i, so it is nondecreasing and C^1 in g_i (piecewise: kappa/2 (g + g_n)
when both gaps are negative, kappa/2 g^2 / (g - g_n) or -kappa/2 g_n^2 / (g - g_n)
across the obstacle, 0 when both are positive): the Jacobian I + dt^2/2 W D (D >= 0
diagonal) is invertible and Newton, with a backtracking line search on |R|, is run to
round-off (`discrete_gradient_solve`). Without penetration at either end of the step f
is 0 and the step is the trapezoidal Newmark step.

The recorded energy is E above (the springs' at t_{n+1}); the stress is the force the
step applies, -sum_i f_i / (the zone's measure) (the discrete gradient acts over the
whole step, so its integral over the steps is the momentum balance's impulse; the
springs' force at t_{n+1}, kappa_i min(0, g_i), is not the one the velocity update
feels), and each contact dof's force (chatter, contact times, peak, impulse) is the
step's f_i.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit

from contact_bench.api.sparse import SparseProblem
from contact_bench.core.loop import BLOWN, OK, drive
from contact_bench.core.refcount import counted, uncounted_inline
from contact_bench.kernels.contact import ContactOps, contact_ops, gaps, push
from contact_bench.kernels.csr import CSR, csr_arrays, matvec
from contact_bench.kernels.linalg import LU, lu
from contact_bench.kernels.recording import csr_energy
from contact_bench.kernels.sparse import Factor
from contact_bench.kernels.stepper import LoopStepper
from contact_bench.kernels.time_load import LoadOps, NoLoad, force_at, load_ops, load_scratch

#: Newton iterations of `discrete_gradient_solve` before it gives up
NEWTON_MAX = 100


@njit(cache=True)
def secant_force(g, gn, k):  # pragma: no cover - compiled
    """(phi, dphi/dg): phi = (Phi(g) - Phi(gn)) / (g - gn), Phi = k/2 min(0, .)^2 (the
    discrete gradient, <= 0), and its derivative in g (>= 0)."""
    if g >= 0.0 and gn >= 0.0:
        return 0.0, 0.0
    if g <= 0.0 and gn <= 0.0:
        return 0.5 * k * (g + gn), 0.5 * k
    d = g - gn
    if gn > 0.0:  # g < 0 < gn
        return 0.5 * k * g * g / d, 0.5 * k * g * (g - 2.0 * gn) / (d * d)
    return -0.5 * k * gn * gn / d, 0.5 * k * gn * gn / (d * d)  # gn < 0 <= g


@njit(cache=True)
def _residual(g, gf, gn, k, W, a, out):  # pragma: no cover - compiled
    """r = g - gf + a W phi(g) (phi <= 0 the discrete gradient, a = dt^2/2) with out =
    (phi, dphi, r) written; returns max |r|."""
    phi, dphi, r = out
    nc = g.size
    for i in range(nc):
        phi[i], dphi[i] = secant_force(g[i], gn[i], k[i])
    worst = 0.0
    for i in range(nc):
        s = g[i] - gf[i]
        for j in range(nc):
            s += a * W[i, j] * phi[j]
        r[i] = s
        worst = max(worst, abs(s))
    return worst


@counted
def discrete_gradient_solve(gf, gn, k, W, a, g, phi):  # pragma: no cover - compiled
    """The gaps g at t_{n+1} solving g = gf - a W phi(g) (module docstring) by Newton
    with backtracking on max |R|, from g = gf; phi is left at phi(g). Runs until the
    step or the residual reaches round-off. Returns the iterations (-1: not converged)."""
    nc = g.size
    dphi = np.empty(nc)
    r = np.empty(nc)
    gt = np.empty(nc)
    rt = np.empty(nc)
    scale = 0.0
    for i in range(nc):
        g[i] = gf[i]
        scale = max(scale, abs(gf[i]), abs(gn[i]))
    tol = 4e-16 * max(scale, 1e-300)
    res = _residual(g, gf, gn, k, W, a, (phi, dphi, r))
    J = np.empty((nc, nc))
    for it in range(NEWTON_MAX):
        if res <= tol:
            return it
        for i in range(nc):
            for j in range(nc):
                J[i, j] = a * W[i, j] * dphi[j] + (1.0 if i == j else 0.0)
        if nc == 1:  # the bar: a division (a LAPACK call costs more than the step)
            delta = -r / J[0, 0]
        else:
            delta = np.linalg.solve(J, -r)
        step = 0.0
        for i in range(nc):
            step = max(step, abs(delta[i]))
        t = 1.0
        while True:  # backtrack until max |R| decreases (Newton's direction descends)
            for i in range(nc):
                gt[i] = g[i] + t * delta[i]
            rest = _residual(gt, gf, gn, k, W, a, (phi, dphi, rt))
            if rest < res or t < 1e-6:
                break
            t *= 0.5
        if not rest < res:  # no progress: round-off reached
            _residual(g, gf, gn, k, W, a, (phi, dphi, r))
            return it if step <= 1e3 * tol else -1
        g[:] = gt
        r[:] = rt
        res = rest
        if t * step <= tol:
            return it + 1
    return -1


class PenaltyMidpointOps(NamedTuple):
    """The energy-conserving penalty step's operators: M, K, F, S's factor, the contact
    dofs, gaps and springs kappa, W = C S^-1 C^T, dt, the energy's offset."""

    M: CSR
    K: CSR
    F: np.ndarray
    fac: LU
    ct: ContactOps  # the gaps and W = G S^-1 G^T (Z not kept: the correction is a solve)
    weights: np.ndarray
    kappa: np.ndarray
    dt: float
    offset: float
    load: LoadOps | NoLoad  # the time load (`contact_bench.kernels.time_load`)


class PenaltyMidpointState(NamedTuple):
    """(U, V), the springs' forces, the gaps (free, at t_n, at t_{n+1}), the discrete
    gradient phi, the load, scratch."""

    U: np.ndarray
    V: np.ndarray
    force: np.ndarray
    mu: np.ndarray
    gf: np.ndarray
    gn: np.ndarray
    g: np.ndarray
    phi: np.ndarray
    rhs: np.ndarray
    X: np.ndarray
    w: np.ndarray
    work: np.ndarray
    mv: np.ndarray
    ku: np.ndarray
    Fn: np.ndarray
    vals: np.ndarray


@uncounted_inline
def penalty_midpoint_step(o, s, step):  # pragma: no cover - compiled
    """Advance (U, V) in place (module docstring); a step whose Newton iteration does not
    converge stops the run as blown up. F is the load at the midpoint t_{n+1/2}. Compiled
    without reference counting (`contact_bench.core.refcount`)."""
    U, V, X, rhs, mv, ku = s.U, s.V, s.X, s.rhs, s.mv, s.ku
    gf, gn, lam, mu, dt = s.gf, s.gn, s.force, s.mu, o.dt
    n = U.size
    nc = gf.size
    a = 0.5 * dt * dt
    q = 0.25 * dt * dt
    for i in range(n):
        mv[i] = U[i] + dt * V[i]
    F = force_at(o.load, o.F, (step - 0.5) * dt, s.vals, s.Fn)
    matvec(o.M, mv, rhs)
    matvec(o.K, U, ku)
    for i in range(n):
        rhs[i] += a * F[i] - q * ku[i]
    lu(o.fac, rhs, X, s.work)
    pen = gaps(o.ct, U, gn)
    pen = gaps(o.ct, X, gf) or pen
    if pen:
        if discrete_gradient_solve(gf, gn, o.kappa, o.ct.W, a, s.g, s.phi) < 0:
            return BLOWN  # no converged step
        for j in range(nc):
            mu[j] = -a * s.phi[j]
            lam[j] = -s.phi[j]
        push(o.ct, o.fac, mu, X, (rhs, s.w, s.work))
    else:
        lam[:] = 0.0
    for i in range(n):
        V[i] = 2.0 * (X[i] - U[i]) / dt - V[i]
        U[i] = X[i]
    return OK


@njit(cache=True)
def penalty_midpoint_sample(o, s):  # pragma: no cover - compiled
    """The energy with the springs' at t_{n+1}, the stress of the step's force and V."""
    e = csr_energy(o.M, o.K, o.F, s.U, s.V, o.offset, s.w)
    gaps(o.ct, s.U, s.gn)
    st = 0.0
    for j in range(o.kappa.size):
        y = min(0.0, s.gn[j])
        e += 0.5 * o.kappa[j] * y * y
        st -= s.force[j]
    return e, st / o.weights.sum(), s.V


@njit(cache=True)
def penalty_midpoint_loop(ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """The one loop (`contact_bench.core.loop.drive`) with `penalty_midpoint_step`."""
    return drive(penalty_midpoint_step, penalty_midpoint_sample, ops, st, rec, nsteps, stride)


class MidpointPenaltyStepper(LoopStepper):
    """`prepare_midpoint_penalty` prepared: S = M + dt^2/4 K factored, W = C S^-1 C^T
    (n_c solves, only its n_c x n_c values kept), sample 0's energy and stress."""

    adds_time_load = True
    any_gap_operator = True
    follows_curved = True
    loop = staticmethod(penalty_midpoint_loop)

    def __init__(self, p: SparseProblem, dt: float, kappa: np.ndarray) -> None:
        super().__init__(p, dt)
        dt = self.dt
        n = p.nfree
        kappa = np.asarray(kappa, float)
        if kappa.shape != (p.contact.size,) or not np.all(kappa > 0.0):
            raise ValueError("the midpoint penalty needs one positive stiffness per contact dof")
        S = sp.csr_matrix(p.M + 0.25 * dt * dt * p.K)
        fac = Factor.of(S)
        gap0 = np.asarray(p.contact.gap0, float)
        G = sp.csr_matrix(p.contact.gap_operator(n))
        ct = contact_ops(fac, G, gap0, keep=False, obstacle=p.contact.obstacle)
        weights = np.asarray(p.contact.weights, float)
        U, V = p.U0.astype(float).copy(), p.V0.astype(float).copy()
        y = np.minimum(0.0, p.gaps(U))
        self.sample0 = {"energy": float(p.energy(U, V) + 0.5 * np.sum(kappa * y * y)),
                        "stress": float(np.sum(kappa * y) / np.sum(weights))}
        self.force0 = float(np.sum(kappa * np.maximum(0.0, -p.gaps(U))))
        self.gamma = 1.0  # the step's force acts over the whole step
        self.ops = PenaltyMidpointOps(csr_arrays(p.M), csr_arrays(p.K), np.asarray(p.F, float),
                                      fac.arrays, ct, weights, kappa, dt,
                                      float(p.energy_offset), load_ops(p))
        self.initial = (U, V)
        self.springs = kappa

    def new_state(self) -> PenaltyMidpointState:
        n, nc = self.problem.nfree, self.ops.kappa.size
        U, V = (a.copy() for a in self.initial)
        vals, Fn = load_scratch(self.ops.load, n)
        return PenaltyMidpointState(U, V, np.zeros(nc), np.empty(nc), np.empty(nc),
                                    np.empty(nc), np.empty(nc), np.zeros(nc), np.empty(n),
                                    np.empty(n), np.empty(n), np.empty(n), np.empty(n),
                                    np.empty(n), Fn, vals)

    def law_energy(self, U: np.ndarray) -> float:
        """The springs' energy sum_i kappa_i/2 min(0, g_i)^2 in state U."""
        y = np.minimum(0.0, self.problem.gaps(np.asarray(U)))
        return float(0.5 * np.sum(self.springs * y * y))


def prepare_midpoint_penalty(p: SparseProblem, dt: float, kappa: np.ndarray
                             ) -> MidpointPenaltyStepper:
    """The energy-conserving midpoint step with penalty springs `kappa` (one per contact
    dof) through the discrete gradient of their energy (module docstring)."""
    return MidpointPenaltyStepper(p, dt, kappa)
