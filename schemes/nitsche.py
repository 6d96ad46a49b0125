"""Nitsche contact (Chouly, Hild, Renard 2015) for the P1 bar, Newmark in time.

With sigma(u) = E (u1 - u0) / h on the first element, gam = gamma0 E / h and the Nitsche
stress S(u) = min(0, gam u0 + sigma(u)), the semi-discrete problem is

    M U'' + K U - (theta/gam) sigma(U) sigma(.) + (1/gam) S(U) (gam e0 + theta sigma(.)) = F.

theta = 1 is symmetric (a gradient system whose energy is conserved), 0 incomplete,
-1 skew. gamma0 > 1 keeps the first element coercive for theta = 1, so gamma0 is in
(1, inf). The sampled energy is CHR's E_theta, the sampled stress S. The step is the
shared boundary-contact kernel (`contact_bench.kernels.boundary`): piecewise linear in
u0, solved exactly. With a massless contact node, row 0 gives u0 = max(0, u1): exact
contact, the energy of `redistributed`, whatever theta.

Friction (a body, implicit; Chouly-Hild-Renard's Coulomb term): the traction along the
tangents is tau = proj onto the disc of radius mu p (an interval in 2D, a disc of two
tangents in 3D) of sigma_t(U) - gam (u_t^{n+1} - u_t^n), p the normal pressure, theta and
gam the normal term's (`contact_law`). Readings, energy identities, GetFEM's NaN with a
redistributed mass: docs/schemes.md and docs/comparisons.md.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from contact_bench.api.fem import MASS_ALIASES, MASS_KINDS, MASSLESS_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import CallStepper, Contact, Energy, Scheme, Stepper, Traits
from contact_bench.api.problem import banded
from contact_bench.kernels.boundary import bar_law, element_limit, energy_budget, run_boundary_law
from contact_bench.kernels.common import massless_drift_bound
from contact_bench.kernels.newmark import BETA, GAMMA
from contact_bench.kernels.sparse import ContactLaw, prepare_newmark
from contact_bench.kernels.sparse_explicit import prepare_explicit_law, stable_dt


class Nitsche(Scheme):
    name = "nitsche"
    summary = "Nitsche contact (Chouly-Hild-Renard 2015), theta in {-1, 0, 1}; Newmark"
    params = {
        "theta": Param(1, "Nitsche variant: 1 symmetric, 0 incomplete, -1 skew",
                       choices=(-1, 0, 1)),
        "gamma0": Param(5.0, "Nitsche parameter: gam = gamma0 E / h", low=1.0, low_open=True,
                        high=1e8, sweep=(1.0, 1e2, 1e4, 1e6, 1e8)),
        "mass": Param("consistent", "mass matrix (contact_bench.api.fem)", choices=MASS_KINDS,
                      aliases=MASS_ALIASES),
        "beta": BETA,
        "gamma": GAMMA,
    }

    def mass_kind(self) -> str:
        return self.mass

    def traits(self, problem=None) -> Traits:
        # with a massless contact node the bar's row 0 gives u0 = max(0, u1): exact
        # contact, redistributed's energy (module docstring); massless contact dofs of a
        # body, coupled through the zone's normal stress, do not reduce to that dof by
        # dof: Nitsche's own contact and energy (docs/sparse.md)
        massless = self.mass in MASSLESS_KINDS
        if massless and problem is not None and banded(problem) is not None:
            energy = Energy.DISSIPATED if self.gamma > 0.5 else Energy.CONSERVED
            contact = Contact.EXACT
        else:
            energy = (Energy.DISSIPATED if self.gamma > 0.5 and self.theta == 1
                      else Energy.MAY_GROW)
            contact = Contact.NITSCHE
        return Traits(implicit=self.beta > 0, massless_contact_node=massless, contact=contact,
                      energy=energy, order=2 if self.gamma == 0.5 else 1,
                      friction=self.beta > 0)

    def _blocks(self) -> tuple[np.ndarray, np.ndarray]:
        """First element's stiffness changes (units E/h): inactive, active."""
        g0, th = self.gamma0, float(self.theta)
        inactive = -(th / g0) * np.array([[1.0, -1.0], [-1.0, 1.0]])
        active = inactive + np.outer([g0 - th, th], [g0 - 1.0, 1.0]) / g0
        return inactive, active

    def stability_limit(self, problem) -> float | None:
        if banded(problem) is None:
            # a body: the law's eigenvalues on this mesh, inactive and all active
            # (`contact_bench.kernels.sparse_explicit.stable_dt`)
            try:
                law = self.contact_law(problem)
            except ValueError:  # prepare says what is missing
                return None
            return stable_dt(problem, self.beta, self.gamma, law)
        h, c = problem.hmin, problem.c_max
        limits = [element_limit(self.beta, self.gamma, h, c, self.mass, x) for x in self._blocks()]
        return None if limits[0] is None else float(min(limits))

    def penetration_bound(self, problem, dt: float) -> float:
        """|u0| <= (|S| + |sigma|) / gam with (1/2gam) S^2 <= W' and the first element's
        (1 - theta+/gamma0) h sigma^2 / 2E <= W', W' = 2|E(0)| + g m h (energy at most
        twice the initial one, penetration below one element). Exact (0) when massless."""
        if self.mass in MASSLESS_KINDS:
            return 0.0
        semi = banded(problem)
        h = float(semi.h[0])
        E = semi.E_contact
        gam = self.gamma0 * E / h
        W, gm = energy_budget(semi)
        W += gm * h
        soft = 1.0 - max(self.theta, 0) / self.gamma0
        return float((math.sqrt(2.0 * gam * W) + math.sqrt(2.0 * E * W / (h * soft))) / gam)

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        semi = banded(problem)
        return (massless_drift_bound(semi, dt)
                if self.mass in MASSLESS_KINDS and semi is not None else None)

    def contact_law(self, problem) -> ContactLaw:
        """The Nitsche term as a piecewise-linear `ContactLaw`.

        The bar: the first element's sigma = E (u1 - u0) / h, P = (gam - E/h, E/h), Q =
        (gam - theta E/h, theta E/h), c = 1 / gam, K's first block changed by the
        inactive block. A body: the problem's normal stress B at the contact points and
        nodal quadrature on the zone (weights w_i) for the contact term: P = gam G + B,
        Q = gam G + theta B; K' = K - (theta / gam) B^T M_f B with the zone's consistent
        mass M_f (coercive above a mesh-dependent gamma0, which the problem's h_contact =
        element size / degree^2 keeps near 1D's 1 for P1 and P2: docs/impact-scenes.md);
        gam = gamma0 E / h at the zone. With friction (`ContactSet.frictional`) the
        tangential rows: y_t = gam T (X - U^n) - Bt X (Bt the problem's tangential
        stress), the force (gam T - theta Bt)^T (w / gam) tau, K' also less (theta / gam)
        Bt^T M_f Bt (`contact_bench.kernels.sparse.newmark_nitsche_friction_step`).
        """
        semi = banded(problem)
        if semi is not None:
            h = float(semi.h[0])
            E = semi.E_contact
            gam = self.gamma0 * E / h
            th = float(self.theta)
            inactive, _ = self._blocks()
            return bar_law(semi.nfree, inactive * (E / h), 1.0 / gam, (gam - E / h, E / h),
                           (gam - th * E / h, th * E / h), th, 1.0, gam)
        B = problem.normal_stress
        if B is None or not (problem.E_contact > 0 and problem.h_contact > 0):
            raise ValueError("nitsche needs the problem's normal_stress, E_contact, h_contact")
        gam = self.gamma0 * problem.E_contact / problem.h_contact
        th = float(self.theta)
        c = problem.contact
        C = c.gap_operator(problem.nfree)
        B = sp.csr_matrix(B)
        w = np.asarray(c.weights, float)
        Mf = sp.diags(w) if c.face_mass is None else sp.csr_matrix(c.face_mass)
        K_extra = -(th / gam) * (B.T @ Mf @ B)
        tangential = {}
        if c.frictional:  # Chouly-Hild-Renard's tangential term (module docstring)
            Bt, T = problem.tangential_stress, sp.csr_matrix(c.tangents)
            if Bt is None:
                raise ValueError("nitsche with friction needs the problem's tangential_stress")
            Bt = sp.csr_matrix(Bt)
            Mt = sp.kron(Mf, sp.identity(T.shape[0] // c.size))  # the tangents' layout
            K_extra = K_extra - (th / gam) * (Bt.T @ Mt @ Bt)
            tangential = {"Pt": sp.csr_matrix(gam * T - Bt),
                          "Qt": sp.csr_matrix(gam * T - th * Bt), "St": gam * T}
        return ContactLaw(P=sp.csr_matrix(gam * C + B), Q=sp.csr_matrix(gam * C + th * B),
                          y0=gam * np.asarray(c.gap0, float), c=w / gam, ew=th, sc=w,
                          K_extra=sp.csr_matrix(K_extra), fscale=gam, **tangential)

    def adds_time_load(self) -> bool:
        return True  # implicit: Newmark's at t_{n+1}; explicit: A_{n+1} at U_{n+1}, t_{n+1}

    def prepare(self, problem, dt: float) -> Stepper:
        # the bar: the first element's boundary kernel; a body: implicit Newmark with
        # the law solved exactly at t_{n+1}, explicit: the law at U_{n+1}
        # (`contact_bench.kernels.sparse`, `contact_bench.kernels.sparse_explicit`)
        law = self.contact_law(problem)
        semi = banded(problem)
        if semi is not None:
            return CallStepper(lambda n, s: run_boundary_law(semi, dt, n, s, self.beta,
                                                             self.gamma, law))
        if self.beta == 0.0:
            return prepare_explicit_law(problem, dt, self.gamma, law)
        return prepare_newmark(problem, dt, self.beta, self.gamma, law=law)
