"""Nitsche contact (Chouly, Hild, Renard 2015) for the P1 bar, Newmark in time.

Weak form, with sigma(u) = E u_x(0) = E (u1 - u0) / h (P1, first element), gam =
gamma0 E / h and the Nitsche stress S(u) = min(0, gam u0 + sigma(u)) (S = sigma(u)
exactly when the Signorini conditions hold):

    M U'' + K U - (theta/gam) sigma(U) sigma(.) + (1/gam) S(U) (gam e0 + theta sigma(.)) = F

(the boundary term sigma(u) v(0) of the wave equation, written as
(1/gam) S (gam v0 + theta sigma(v)) - (theta/gam) sigma(u) sigma(v)). theta = 1 is
symmetric: a gradient system whose energy E_1 = kinetic + strain
- (1/2gam) sigma^2 + (1/2gam) S^2 is conserved by the semi-discrete problem. In general
E_theta = kinetic + strain + (theta/2gam)(S^2 - sigma^2) (CHR's energy; GetFEM's demo
samples the same) obeys dE_theta/dt = (theta - 1) S u0', so for theta != 1 it may
grow. The sampled energy is E_theta, the sampled stress S.

Coercivity: with theta = 1 the first element's stiffness becomes (1 - 1/gamma0) E/h,
so gamma0 > 1 is required (exactly, for P1 in 1D); gamma0 > 1 also makes the contact
node's row monotone for every theta. gamma0 is therefore restricted to (1, inf).

Massless contact node: row 0 gives u0 = u1 when inactive and, when active,
(gamma0 - theta) u0 / h = 0, i.e. u0 = 0: exact contact, u0 = max(0, u1), and
E_theta reduces to the plain energy, as in the redistributed scheme, whatever theta
and gamma0 > 1. (Only the very first step differs when node 0 starts out of
equilibrium, as on clamped_bar: it sees the Nitsche-modified first element.)

GetFEM's demo (interface/tests/python/demo_dynamic_contact_1D.py, version = 3) gives
NaN for theta = 1 with the redistributed or singular mass. That is the
implementation, not the scheme. In its implicit branch (beta > 0) it forms the
acceleration as MA1 = Fc1 - K U1 with Fc1 = (K_N U1 - B) / (beta dt^2), where K_N
already contains the Nitsche term K_N1 = -(theta/gam) sigma sigma: MA1 misses
-K_N1 U1. With a massive contact node this is only an inconsistency (for theta != 0);
with a massless one, row 0 of MA1 should vanish but equals (K_N1 U1)[0], which
accumulates in MV[0] and enters the next right-hand side B[0] amplified by
1 / (beta dt^2) until it overflows. Evidence: `replicate_getfem_demo` below is a
line-by-line numpy transcription of that branch (the same matrices, Dirichlet rows,
M2, tests and updates; scipy.sparse, NX = 20, dt = 0.002, T = 12, gamma0 = 5,
beta = 1/4). Run ``python -m contact_bench.schemes.nitsche``; it prints (nonfinite: first time E is
not finite; that time depends on round-off, since the growth is exponential):

    mass=standard       theta=+1: demo: nonfinite=None  E(T)=0.1268   fixed: E(T)=0.1237
    mass=redistributed  theta=-1: demo: nonfinite=None  E(T)=0.1186   fixed: E(T)=0.1187
    mass=redistributed  theta=+0: demo: nonfinite=None  E(T)=0.1187   fixed: E(T)=0.1187
    mass=redistributed  theta=+1: demo: nonfinite=1.308 E(T)=nan      fixed: E(T)=0.1187
    mass=singular       theta=+1: demo: nonfinite=1.306 E(T)=nan      fixed: E(T)=0.1187

"fixed" adds the missing term (MA1 -= K_N1 U1), nothing else: every run is finite,
and with a massless node every theta gives the same energy, as shown above. This
module's own implicit scheme (`nitsche[theta=1,mass=getfem]`) runs the same scene
with a finite, bounded energy (tests/test_scheme_properties.py).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from contact_bench.api.fem import MASS_KINDS, MASSLESS_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import Scheme, Semidiscrete, Traits, Trajectory
from contact_bench.kernels.boundary import element_limit, energy_budget, run_boundary
from contact_bench.kernels.common import massless_drift_bound
from contact_bench.kernels.newmark import BETA, GAMMA
from contact_bench.kernels.sparse import ContactLaw, newmark_sparse


class Nitsche(Scheme):
    name = "nitsche"
    summary = "Nitsche contact (Chouly-Hild-Renard 2015), theta in {-1, 0, 1}; Newmark"
    params = {
        "theta": Param(1, "Nitsche variant: 1 symmetric, 0 incomplete, -1 skew",
                       choices=(-1, 0, 1)),
        "gamma0": Param(5.0, "Nitsche parameter: gam = gamma0 E / h", low=1.0, low_open=True,
                        high=1e8),
        "mass": Param("consistent", "mass matrix (contact_bench.api.fem)", choices=MASS_KINDS),
        "beta": BETA,
        "gamma": GAMMA,
    }

    def mass_kind(self) -> str:
        return self.mass

    def traits(self) -> Traits:
        massless = self.mass in MASSLESS_KINDS
        if massless:  # identical to the redistributed scheme (module docstring)
            energy = "dissipated" if self.gamma > 0.5 else "conserved"
            contact = "exact"
        else:
            energy = "dissipated" if self.gamma > 0.5 and self.theta == 1 else "may grow"
            contact = "Nitsche O(h / gamma0)"
        return Traits(implicit=self.beta > 0, massless_contact_node=massless, contact=contact,
                      energy=energy, order=2 if self.gamma == 0.5 else 1)

    def _blocks(self) -> tuple[np.ndarray, np.ndarray]:
        """First element's stiffness changes (units E/h): inactive, active."""
        g0, th = self.gamma0, float(self.theta)
        inactive = -(th / g0) * np.array([[1.0, -1.0], [-1.0, 1.0]])
        active = inactive + np.outer([g0 - th, th], [g0 - 1.0, 1.0]) / g0
        return inactive, active

    def stability_limit(self, h: float, c: float) -> float | None:
        limits = [element_limit(self.beta, self.gamma, h, c, self.mass, x) for x in self._blocks()]
        return None if limits[0] is None else float(min(limits))

    def penetration_bound(self, semi: Semidiscrete, dt: float) -> float:
        """|u0| <= (|S| + |sigma|) / gam with (1/2gam) S^2 <= W' and the first element's
        (1 - theta+/gamma0) h sigma^2 / 2E <= W', W' = 2|E(0)| + g m h (energy at most
        twice the initial one, penetration below one element). Exact (0) when massless."""
        if self.mass in MASSLESS_KINDS:
            return 0.0
        h = float(semi.h[0])
        E = semi.E_contact
        gam = self.gamma0 * E / h
        W, gm = energy_budget(semi)
        W += gm * h
        soft = 1.0 - max(self.theta, 0) / self.gamma0
        return float((math.sqrt(2.0 * gam * W) + math.sqrt(2.0 * E * W / (h * soft))) / gam)

    def energy_drift_bound(self, semi: Semidiscrete, dt: float) -> float | None:
        return massless_drift_bound(semi, dt) if self.mass in MASSLESS_KINDS else None

    def integrate(self, semi: Semidiscrete, dt: float, nsteps: int, stride: int) -> Trajectory:
        h = float(semi.h[0])
        E = semi.E_contact
        gam = self.gamma0 * E / h
        th = float(self.theta)
        inactive, _ = self._blocks()
        p = (gam - E / h, E / h)
        q = (gam - th * E / h, th * E / h)
        return run_boundary(semi, dt, nsteps, stride, self.beta, self.gamma,
                            inactive * (E / h), 1.0 / gam, p, q, th, 1.0)

    # the general sparse problem (implicit), with the problem's normal stress B at the
    # contact dofs and nodal quadrature on the zone (weights w_i) for the contact term:
    # P = gam C + B, Q = gam C + theta B; K' = K - (theta / gam) B^T M_f B with the
    # zone's consistent mass M_f (coercive for gamma0 > 1, as in 1D); gam = gamma0 E / h at
    # the zone (`contact_bench.kernels.sparse.ContactLaw`)
    forms = frozenset({"banded1d", "sparse"})

    def cannot_run(self, case) -> str | None:
        if case.form == "sparse" and self.beta == 0.0:
            return "the explicit (beta = 0) step has no sparse path yet"
        return None

    def integrate_sparse(self, problem, dt: float, nsteps: int, stride: int) -> Trajectory:
        B = problem.normal_stress
        if B is None or not (problem.E_contact > 0 and problem.h_contact > 0):
            raise ValueError("nitsche needs the problem's normal_stress, E_contact, h_contact")
        gam = self.gamma0 * problem.E_contact / problem.h_contact
        th = float(self.theta)
        c = problem.contact
        n = problem.nfree
        C = sp.csr_matrix((np.ones(c.size), (np.arange(c.size), c.dofs)), shape=(c.size, n))
        B = sp.csr_matrix(B)
        w = np.asarray(c.weights, float)
        Mf = sp.diags(w) if c.face_mass is None else sp.csr_matrix(c.face_mass)
        law = ContactLaw(P=sp.csr_matrix(gam * C + B), Q=sp.csr_matrix(gam * C + th * B),
                         y0=gam * np.asarray(c.gap0, float), c=w / gam, ew=th, sc=w,
                         K_extra=sp.csr_matrix(-(th / gam) * (B.T @ Mf @ B)), fscale=gam)
        return newmark_sparse(problem, dt, nsteps, stride, self.beta, self.gamma, law=law)


# ---------------------------------------------------------------- GetFEM's demo, replicated


def _outer_at_contact(a: np.ndarray, b: np.ndarray, n: int) -> sp.csc_matrix:
    """a b^T as a sparse matrix, for vectors supported on nodes 0 and 1."""
    rows, cols = np.meshgrid([0, 1], [0, 1], indexing="ij")
    return sp.csc_matrix((np.outer(a[:2], b[:2]).ravel(), (rows.ravel(), cols.ravel())),
                         shape=(n, n))


def replicate_getfem_demo(theta: float, mass: int, fixed: bool, NX: int = 20, T: float = 12.0,
                          dt: float = 0.002, gamma0: float = 5.0,
                          beta: float = 0.25, gamma: float = 0.5) -> np.ndarray:
    """GetFEM demo_dynamic_contact_1D.py, version 3, implicit branch, line by line.

    mass: 0 standard, 1 redistributed (M11 += M00 + M01), 2 singular (M11 = 7h/12), as
    the demo's mass_matrix_type, in scipy.sparse (no dense n x n). fixed=True adds the
    missing -K_N1 U1 to MA1. Returns the demo's sampled energy at every step.
    """
    h, n = 1.0 / NX, NX + 1
    g = gamma0 / h
    x = np.linspace(0.0, 1.0, n)
    ends = np.r_[0.5, np.ones(n - 2), 0.5]
    M = sp.diags([np.full(n - 1, h / 6), 2 * h / 3 * ends, np.full(n - 1, h / 6)],
                 [-1, 0, 1], format="lil")
    K = sp.diags([np.full(n - 1, -1 / h), 2 / h * ends, np.full(n - 1, -1 / h)],
                 [-1, 0, 1], format="lil")
    K[n - 1, n - 2] = M[n - 1, n - 2] = 0.0  # the demo's Dirichlet rows
    M[n - 1, n - 1] = K[n - 1, n - 1] = 1.0
    if mass == 1:
        M[1, 1] += M[0, 0] + M[1, 0]
        M[0, 0] = M[0, 1] = M[1, 0] = 0.0
    elif mass == 2:
        M[1, 1] = 7 * h / 12
        M[0, 0] = M[0, 1] = M[1, 0] = 0.0
    M2 = M.copy()
    if mass:
        M2[0, 0] = 1.0
    M, K, M2 = M.tocsc(), K.tocsc(), M2.tocsc()
    sx = np.zeros(n)  # Grad of the basis functions at x = 0
    sx[:2] = -1 / h, 1 / h
    e0 = np.zeros(n)
    e0[0] = 1.0
    KN1 = -(theta / g) * _outer_at_contact(sx, sx, n)
    KN2 = (1 / g) * _outer_at_contact(g * e0 + theta * sx, g * e0 + sx, n)
    KN = (M + dt * dt * beta * (K + KN1)).tocsc()
    KNC = (KN + dt * dt * beta * KN2).tocsc()
    U0 = 0.5 - 0.5 * x
    V0 = np.zeros(n)
    MV0 = M @ V0
    MA0 = -K @ U0
    if mass:
        MA0[0] = 0.0
    s0 = ux = 0.0
    NT = int(round(T / dt)) + 1
    energy = np.zeros(NT)
    with np.errstate(all="ignore"):
        for nit in range(NT):
            if nit > 0:
                B = M @ U0 + dt * MV0 + (dt * dt * (1 - 2 * beta) / 2) * MA0
                U1 = spsolve(KN, B)
                ux = sx @ U1
                if g * U1[0] + ux < 0:
                    U1 = spsolve(KNC, B)
                    ux = sx @ U1
                Fc1 = (KN @ U1 - B) / (beta * dt * dt)
                s1 = min(0.0, g * U1[0] + ux)
                MA1 = Fc1 - K @ U1
                if fixed:
                    MA1 -= KN1 @ U1
                MV1 = MV0 + dt * ((1 - gamma) * MA0 + gamma * MA1)
                V1 = spsolve(M2, MV1)
                V1[n - 1] = 0.0
                if mass:
                    V1[0] = (U1[0] - U0[0]) / dt
                MA0 = MA1
                U0, V0, MV0, s0 = U1, V1, MV1, s1
            energy[nit] = (0.5 * (V0 @ M @ V0 + U0 @ K @ U0)
                           + 0.5 * theta * (h / gamma0) * (s0 * s0 - ux * ux))
    return energy


def _main() -> None:
    names = {0: "standard", 1: "redistributed", 2: "singular"}
    runs = [(0, 1), (1, -1), (1, 0), (1, 1), (2, 1)]
    for mass, theta in runs:
        line = f"mass={names[mass]:14s} theta={theta:+d}: "
        for fixed in (False, True):
            E = replicate_getfem_demo(float(theta), mass, fixed)
            bad = np.flatnonzero(~np.isfinite(E))
            first = f"{bad[0] * 0.002:.4g}" if bad.size else "None"
            line += (f"fixed: E(T)={E[-1]:.4g}" if fixed else
                     f"demo: nonfinite={first:5s} E(T)={E[-1]:<9.4g}")
        print(line)


if __name__ == "__main__":
    _main()
