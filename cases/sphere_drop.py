"""GetFEM's 3D variant of the disc drop (`demo_dynamic_contact.m` with a sphere mesh): an
elastic ball falls onto a rigid plane.

Ball of radius 20 centred at (0, 0, 20) (it touches z = 0 undeformed), lambda = mu = 20,
rho = 1, downward body force 0.1, lifted by `lift` (default 5), v0 = 0; obstacle z >= 0
on the lower half of the boundary, with Coulomb friction `mu` (default 0: frictionless;
tangents e_x, e_y, the circular cone); T = 40, dt = 0.01. Tetrahedra:
scikit-fem's ball (an octahedron refined), straight-sided, `--nx` elements along the
radius (a power of two; default 8, 2499 dofs), P1 or P2 (`degree`, default 1: a default
run takes under a minute; the redistributed mass needs nx >= 4: docs/schemes.md).
`ball=lattice` takes any nx: the octahedral lattice mapped onto the ball (`lattice_ball`),
the same counts as the refined octahedron but not the same tetrahedra.

References it has exactly: the free fall u = (0, 0, lift - g t^2 / 2) until the impact at
sqrt(2 lift / g); E0 = m g lift of the mesh's ball (its volume is below 4/3 pi R^3: flat
faces); the impulse balance. For the study's variant (lift 0.5), the converged reference
of results/references/sphere_drop.json (contact start, peak force, force history;
docs/production-cases.md). No closed-form u after the impact; no mirror-symmetry column
(the refined octahedron is not mirror symmetric). A scheme's redistributed 1D mass
variants map to the Khenous-Laborde-Renard mass, as in disc_drop.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import skfem as fe

from contact_bench.api import fem_nd
from contact_bench.api.fem import LUMPED_KINDS, REDISTRIBUTED_KINDS, canonical_mass
from contact_bench.api.kept import built_once
from contact_bench.api.params import Param
from contact_bench.api.plugin import BodyCase, Footprint, StudyGrid
from contact_bench.api.sparse import SparseProblem
from contact_bench.exact import converged


class SphereDrop(BodyCase):
    name = "sphere_drop"
    summary = "GetFEM's elastic ball dropped on a plane (3D tetrahedra, P1/P2)"
    params = {
        "degree": Param(1, "polynomial degree of the elements", choices=(1, 2)),
        "lift": Param(5.0, "initial height above the plane (impact speed sqrt(2 g lift))",
                      low=1e-6, high=1e3),
        "ball": Param("octahedron", "the ball's tetrahedra: scikit-fem's refined octahedron "
                      "(nx a power of two) or the octahedral lattice (any nx)",
                      choices=("octahedron", "lattice")),
        "mu": Param(0.0, "Coulomb's friction coefficient on the plane (0: frictionless, "
                    "every scheme runs it)", low=0.0, high=10.0),
    }
    R, centre_z = 20.0, 20.0
    dim = 3
    lam = mu_l = 20.0
    rho, g = 1.0, 0.1
    T, nx, dt, stride = 40.0, 8, 0.01, 20

    @property
    def size(self) -> float:
        """The ball's diameter."""
        return 2 * self.R

    @property
    def p_modulus(self) -> float:
        """The P-wave modulus lambda + 2 mu: the contact stiffness scale (`E_contact`)."""
        return self.lam + 2 * self.mu_l

    def friction(self) -> float:
        return float(self.mu)

    @property
    def impact_time(self) -> float:
        return math.sqrt(2 * float(self.lift) / self.g)

    @property
    def exact_energy(self) -> float:
        return 4.0 / 3.0 * math.pi * self.R**3 * self.rho * self.g * float(self.lift)

    quantities = frozenset({"free_fall", *converged.QUANTITIES})
    study = StudyGrid(specs=("sphere_drop[lift=0.5]",), nx=(2, 4, 8), T=5.0,
                      small="sphere_drop[lift=0.1]", small_nx=(2, 4, 8), small_T=2.0)

    def quantity_errors(self, problem, traj, row) -> dict[str, float]:
        """err_free_fall: the largest vertical displacement error of any dof against the
        free fall over the samples before the impact, relative to the lift. Against the
        converged reference of results/references/sphere_drop.json when it is this
        variant's (`contact_bench.exact.converged.errors`): err_contact_start, _end,
        _duration, err_peak_force, err_contact_impulse, err_rebound_velocity,
        err_vibration_energy and err_force_history, those the run and the reference have."""
        return converged.drop_errors(self, problem, traj, float(row["dt"]))

    def free_fall(self, t: np.ndarray) -> np.ndarray:
        return float(self.lift) - 0.5 * self.g * np.asarray(t, float) ** 2

    def footprint(self, nx: int) -> Footprint:
        """The refined octahedron, nx elements along the radius: (2 nx + 1)(2 nx^2 + 2 nx
        + 3) / 3 vertices, 8 nx^3 tetrahedra, 8 nx^2 boundary faces, hence (Euler) V + 8
        nx^3 + 4 nx^2 - 1 edges (P2 adds one node on each); three unknowns per node."""
        n = int(nx)
        vertices = (2 * n + 1) * (2 * n * n + 2 * n + 3) // 3
        edges = vertices + 8 * n**3 + 4 * n * n - 1
        nodes = vertices + (edges if int(self.degree) == 2 else 0)
        return Footprint(3 * nodes, 3, int(self.degree))

    @built_once
    def mesh(self, nx: int) -> fe.MeshTet:
        if self.ball == "lattice":
            m = lattice_ball(int(nx))
            return fe.MeshTet(m.p * self.R + np.array([[0.0], [0.0], [self.centre_z]]), m.t)
        nrefs = int(nx).bit_length() - 1
        if nx < 1 or 2**nrefs != nx:
            raise ValueError(f"nx = {nx!r}: the refined octahedron's elements along the radius "
                             "are a power of two (1, 2, 4, 8, ...); sphere_drop[ball=lattice] "
                             "takes any nx")
        m = fe.MeshTet.init_ball(nrefs)
        return fe.MeshTet(m.p * self.R + np.array([[0.0], [0.0], [self.centre_z]]), m.t)

    @built_once
    def body(self, nx: int) -> fem_nd.Elasticity:
        return fem_nd.assemble(self.mesh(nx), self.mu_l * (3 * self.lam + 2 * self.mu_l)
                               / (self.lam + self.mu_l),
                               self.lam / (2 * (self.lam + self.mu_l)),
                               self.rho, degree=int(self.degree))

    def cannot_run(self, scheme) -> str | None:
        if int(self.degree) == 2 and canonical_mass(scheme.mass_kind()) in LUMPED_KINDS:
            return ("a lumped mass on P2 elements has negative row sums at the vertices: "
                    "use sphere_drop[degree=1] or the scheme's mass=consistent")
        return super().cannot_run(scheme)

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        if grading != 1.0:
            raise ValueError(f"grading = {grading!r}: the ball's mesh is uniform (allowed: 1)")
        body = self.body(nx)
        facets = body.boundary_facets(lambda x: x[2] < self.centre_z - 0.01 * self.R)
        scalar = np.unique(body.scalar.get_dofs(facets).flatten())  # for the mass
        kind = canonical_mass(mass_kind)
        M = fem_nd.mass_matrix(body, "redistributed" if kind in REDISTRIBUTED_KINDS else kind,
                               scalar)
        n = body.ndofs
        F = fem_nd.body_force(M, 3, np.array([0.0, 0.0, -self.g]))
        U0 = np.zeros(n)
        U0[2::3] = float(self.lift)
        zone = fem_nd.contact_zone(body, facets, axis=2)
        contact = zone.contact_set(mu=float(self.mu))
        shear = (fem_nd.tangential_stress(body, facets, 2, zone.tangent_directions)
                 if contact.frictional else None)  # Nitsche's friction term
        vertical = np.tile([0.0, 0.0, 1.0], n // 3)
        return SparseProblem(M=M, K=body.K, F=F, U0=U0, V0=np.zeros(n), contact=contact,
                             dim=3, hmin=body.hmin, c_max=body.wave_speed, mass_kind=mass_kind,
                             E_contact=self.p_modulus,
                             h_contact=fem_nd.contact_length(body, self.R / int(nx)),
                             normal_stress=zone.normal_stress, tangential_stress=shear,
                             vertical=vertical, body_mass=float(np.sum(M @ vertical)))


def lattice_ball(n: int) -> fe.MeshTet:
    """The unit ball with n elements along the radius, for any n >= 1: the octahedron
    |x|_1 <= 1 cut into 8 n^3 tetrahedra (in each octant, the Freudenthal tetrahedra of
    the grid of step 1/n that lie in the ordered simplex, mapped onto the octant's
    corner simplex and mirrored: the octants' faces match), each point then moved along
    its ray by |x|_1 / |x|_2, which maps the octahedron onto the ball (its boundary onto
    the sphere). The same counts as the refined octahedron at a power of two; its
    tetrahedra are not the same ones."""
    n = int(n)
    if n < 1:
        raise ValueError(f"nx = {n!r}: the ball needs nx >= 1")
    corner = np.array(list(itertools.product(range(n), repeat=3)))
    tets = []
    for order in itertools.permutations(range(3)):  # the 6 Freudenthal tetrahedra
        verts, cur = [corner], corner
        for axis in order:
            cur = cur.copy()
            cur[:, axis] += 1
            verts.append(cur)
        T = np.stack(verts, axis=1)
        c = T.mean(axis=1)
        tets.append(T[(c[:, 0] > c[:, 1]) & (c[:, 1] > c[:, 2])])  # n >= a >= b >= c
    T = np.concatenate(tets)
    X = np.stack([T[..., 0] - T[..., 1], T[..., 1] - T[..., 2], T[..., 2]], axis=-1)
    X = np.concatenate([X * np.array(s) for s in itertools.product((1, -1), repeat=3)])
    pts, inverse = np.unique(X.reshape(-1, 3), axis=0, return_inverse=True)
    t = inverse.reshape(-1, 4)
    p = pts.T / float(n)
    l1, l2 = np.abs(p).sum(axis=0), np.linalg.norm(p, axis=0)
    p = p * np.where(l2 > 0, l1 / np.where(l2 > 0, l2, 1.0), 1.0)
    a, b, c, d = (p[:, t[:, i]] for i in range(4))
    flip = np.einsum("ij,ij->j", b - a, np.cross(c - a, d - a, axis=0)) < 0
    t[flip, 0], t[flip, 1] = t[flip, 1], t[flip, 0].copy()
    return fe.MeshTet(np.ascontiguousarray(p), np.ascontiguousarray(t.T))
