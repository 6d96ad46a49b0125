"""An elastic sphere hitting a rigid plane at speed v, axisymmetric, against Hertz's law.

Sphere R = 1, E = 1, nu = 0.3, rho = 1 (c_p about 1.16), touching the plane z = 0 at its
pole at t = 0 with velocity -v (`v`, default 0.01), no gravity; T = 1.25 x Hertz's contact
time (15.4 at v = 0.01), dt = 0.01. The meridian half-disc r >= 0: the disc's ring mesh
graded towards the pole (`grade`: distances from the pole along each chord raised to that
power), its nodes then moved by the disc automorphism z -> (z - i s) / (1 + i s z) (`pole`
= s: element sizes at the pole x (1 - s) / (1 + s), its boundary included), P2 on P2
geometry, `--nx` rings. Axisymmetric forms: weight 2 pi r, hoop strain u_r / r, u_r = 0
on the axis. Contact set: the vertical dofs of the lower half of the meridian; their
forces sum to the total force.

Reference quantities: Hertz's contact time and peak force (`hertz`,
`contact_bench.exact.hertz`), the limit v / c -> 0, not an exact solution of this problem:
err_hertz_contact_time and err_hertz_peak_force are gaps to a model (benchmarks/hertz_gap.py
tabulates them). The errors proper (err_contact_duration, err_force_history, ...) are against
the default variant's converged reference, results/references/hertz_sphere.json
(`contact_bench.exact.converged`). Exactly: the energy 1/2 m v^2 and the impulse balance
(vertical momentum change = contact impulse).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import skfem as fe
from skfem.helpers import ddot, sym_grad, trace

from contact_bench.api import fem_nd
from contact_bench.api.fem import LUMPED_KINDS, REDISTRIBUTED_KINDS, canonical_mass
from contact_bench.api.params import Param
from contact_bench.api.plugin import BodyCase, StudyGrid
from contact_bench.api.sparse import SparseProblem
from contact_bench.exact import converged
from contact_bench.exact.hertz import HertzImpact


class HertzSphere(BodyCase):
    name = "hertz_sphere"
    summary = "axisymmetric ball hits a plane at speed v; Hertz contact time, peak force"
    params = {
        "v": Param(0.01, "impact speed", low=1e-6, high=1.0),
        "grade": Param(2.0, "mesh grading exponent towards the pole (1: uniform)", low=1.0,
                       high=4.0),
        "pole": Param(0.6, "conformal zoom s on the pole: element sizes there x (1 - s) / "
                      "(1 + s), on the boundary too (0: none)", low=0.0, high=0.9),
    }
    R, Young, nu, rho = 1.0, 1.0, 0.3, 1.0
    dim = 2  # the meridian section (axisymmetric)
    nx, dt, stride = 8, 0.01, 1

    @property
    def T(self) -> float:
        return round(1.25 * self.hertz().contact_time, 1)

    @property
    def lam_mu(self) -> tuple[float, float]:
        return fem_nd.lame(self.Young, self.nu)

    @property
    def size(self) -> float:
        """The ball's diameter."""
        return 2 * self.R

    @property
    def p_modulus(self) -> float:
        """The P-wave modulus lambda + 2 mu: the contact stiffness scale (`E_contact`)."""
        lam, mu = self.lam_mu
        return lam + 2 * mu

    quantities = frozenset({"hertz_contact_time", "hertz_peak_force", *converged.QUANTITIES})
    study = StudyGrid(specs=("hertz_sphere",), nx=(2, 3, 4), T=None, small="hertz_sphere",
                      small_nx=(2,), small_T=15.4)

    def quantity_errors(self, problem, traj, row) -> dict[str, float]:
        """The relative gaps to Hertz's contact time (first contact start to end, both
        interpolated within their steps) and peak force (the row's contact columns),
        and the errors against the stored converged reference
        (`converged.stored_errors`)."""
        h = self.hertz()
        out = {}
        if row.get("first_contact_end") is not None and np.isfinite(row["first_contact_end"]):
            tc = row["first_contact_end"] - row["first_contact_start"]
            out["err_hertz_contact_time"] = abs(tc / h.contact_time - 1.0)
        if row.get("peak_contact_force") is not None:
            out["err_hertz_peak_force"] = abs(row["peak_contact_force"] / h.peak_force - 1.0)
        out.update(converged.stored_errors(self, problem, traj, float(row["dt"])))
        return out

    def hertz(self) -> HertzImpact:
        return HertzImpact(R=self.R, E=self.Young, nu=self.nu, rho=self.rho, v=float(self.v))

    @property
    def exact_energy(self) -> float:
        return 0.5 * self.rho * 4.0 / 3.0 * math.pi * self.R**3 * float(self.v) ** 2

    def mesh(self, nx: int) -> fe.MeshTri2:
        """The meridian half-disc (r >= 0) of the ring mesh, graded towards the pole
        (0, 0) along the chords from it (interior nodes), zoomed on it by a conformal map
        of the disc onto itself (every node: shapes kept, the circle and the axis mapped
        onto themselves), its curved boundary on the circle."""
        p, t = ring_half_disc(int(nx))
        pole = np.array([[0.0], [-1.0]])
        d = p - pole
        dist = np.linalg.norm(d, axis=0)
        chord = np.where(dist > 0, 2 * d[1] / np.where(dist > 0, dist, 1.0), 0.0)
        scale = np.where(dist > 0, (dist / np.where(chord > 0, chord, 1.0))
                         ** (float(self.grade) - 1.0), 0.0)
        p = pole + d * scale
        z = (p[0] + 1j * p[1] - 1j * float(self.pole)) / (1 + 1j * float(self.pole)
                                                          * (p[0] + 1j * p[1]))
        p = np.vstack([np.where(p[0] == 0.0, 0.0, z.real), z.imag])
        p = p * self.R + np.array([[0.0], [self.R]])
        m = fe.MeshTri2.from_mesh(fe.MeshTri1(p, t))
        loc = m.doflocs.copy()
        D = m.dofs.get_facet_dofs(m.boundary_facets()).flatten()
        D = D[loc[0, D] > 1e-12 * self.R]  # the circle, not the axis
        c = np.array([[0.0], [self.R]])
        r = loc[:, D] - c
        loc[:, D] = c + self.R * r / np.linalg.norm(r, axis=0)
        return replace(m, doflocs=loc)

    def cannot_run(self, scheme) -> str | None:
        if canonical_mass(scheme.mass_kind()) in LUMPED_KINDS:
            return ("a lumped mass on P2 elements has negative row sums at the vertices: "
                    "use the scheme's mass=consistent")
        return None

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        if grading != 1.0:
            raise ValueError(f"grading = {grading!r}: the sphere's mesh grades by its "
                             "`grade` parameter (allowed: 1)")
        mesh = self.mesh(nx)
        lam, mu = self.lam_mu
        elem = fe.ElementTriP2()
        scalar = fe.Basis(mesh, elem)
        vector = fe.Basis(mesh, fe.ElementVector(elem), quadrature=scalar.quadrature)
        K = _axi_stiffness.assemble(vector, lam=lam, mu=mu).tocsr()
        Ms = _axi_mass.assemble(scalar, rho=self.rho).tocsr()
        body = fem_nd.Elasticity(mesh, scalar, vector, K, Ms, lam, mu, self.rho)
        facets = mesh.facets_satisfying(
            lambda x: (x[1] < self.R * 0.99) & (x[0] > 1e-9 * self.R), boundaries_only=True)
        contact_s = np.unique(scalar.get_dofs(facets).flatten())
        kind = canonical_mass(mass_kind)
        M = fem_nd.mass_matrix(body, "redistributed" if kind in REDISTRIBUTED_KINDS else kind,
                               contact_s)
        n = vector.N
        # u_r = 0 on the axis: it slides along it
        red = fem_nd.constrain(body, M, np.zeros(n),
                               sliding=[lambda x: x[0] < 1e-12 * self.R])
        free = red.free
        V0 = np.zeros(n)
        V0[1::2] = -float(self.v)
        # the zone's axisymmetric face mass, weights and normal stress sigma_zz (Nitsche)
        zone = fem_nd.contact_zone(body, facets, axis=1, axisymmetric=True)
        contact = zone.contact_set(free)
        mass = float(np.sum(M @ np.tile([0.0, 1.0], n // 2)))
        return SparseProblem(M=red.M, K=red.K, F=red.F,
                             U0=np.zeros(free.size), V0=V0[free], contact=contact, dim=2,
                             hmin=body.hmin, c_max=body.wave_speed, mass_kind=mass_kind,
                             E_contact=self.p_modulus,
                             h_contact=fem_nd.contact_length(body, body.hmin),
                             normal_stress=zone.stress(free),
                             vertical=(np.arange(n)[free] % 2 == 1).astype(float),
                             body_mass=mass,
                             extra={"dof_points": np.asarray(vector.doflocs)[:, free]})


@fe.BilinearForm
def _axi_stiffness(u, v, w):
    r = w.x[0]
    eu, ev = sym_grad(u), sym_grad(v)
    hu, hv = u.value[0] / r, v.value[0] / r  # hoop strains
    return 2 * np.pi * r * (w.lam * (trace(eu) + hu) * (trace(ev) + hv)
                            + 2 * w.mu * (ddot(eu, ev) + hu * hv))


@fe.BilinearForm
def _axi_mass(u, v, w):
    return 2 * np.pi * w.x[0] * w.rho * u * v





def ring_half_disc(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The x >= 0 half of the unit disc's ring mesh (`disc_drop.ring_disc`'s right half,
    rebuilt here: plugins do not import each other), nodes renumbered."""
    pts = [np.zeros((2, 1))]
    first = [0]
    for k in range(1, n + 1):
        a = -np.pi / 2 + np.pi * np.arange(3 * k + 1) / (3 * k)
        first.append(first[-1] + (3 * (k - 1) + 1 if k > 1 else 1))
        pts.append(k / n * np.vstack([np.cos(a), np.sin(a)]))

    def node(k: int, j: int) -> int:
        return 0 if k == 0 else first[k] + j

    tris = []
    for k in range(1, n + 1):
        i = j = 0
        ni, no = 3 * (k - 1), 3 * k
        while i < ni or j < no:
            if k == 1 or i == ni or (j < no and (j + 1) * ni <= (i + 1) * no):
                tris.append((node(k - 1, i), node(k, j), node(k, j + 1)))
                j += 1
            else:
                tris.append((node(k - 1, i), node(k, j), node(k - 1, i + 1)))
                i += 1
    p = np.hstack(pts)
    p[0, np.abs(p[0]) < 1e-14] = 0.0  # the axis exactly
    return p, np.ascontiguousarray(np.array(tris, np.int64).T)
