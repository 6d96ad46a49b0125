"""GetFEM's disc drop (`demo_dynamic_contact.m`, Renard and Chouly): an elastic disc falls
onto a rigid plane.

Disc of radius 20 centred at (0, 20) (touching y = 0), plane strain, lambda = mu = 20, rho
= 1, downward body force 0.1, lifted by `lift` (default 5; larger: a harder impact), v0 =
0; obstacle y >= 0 on the lower half of the boundary, with Coulomb friction `mu` (default
0: frictionless; GetFEM's dynamic friction setting, its tangent e_x); T = 40, dt = 0.01.
`degree` 1 or 2 on a P2-geometry ring mesh (`--nx` rings along the radius, mirror
symmetric about x = 0, boundary nodes on the circle).

Exact references: the free fall u = (0, lift - g t^2 / 2) until t = sqrt(2 lift / g)
(err_free_fall); E0 = m g lift; the impulse balance; the x -> -x symmetry (the symmetry
defect column). No closed form after the impact: the numerical reference is
`reference_scheme` on twice the rings with dt / 2 (err_u_numerical at the shared
vertices, err_contact_force_numerical); for degree 1, lift 5, the converged reference of
results/references/disc_drop.json (err_contact_duration, err_force_history, ...;
docs/production-cases.md). A scheme's 1D mass variant maps to its 2D kind:
consistent and lumped as named (lumped refused for P2), the redistributed ones to the
Khenous-Laborde-Renard redistribution.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import skfem as fe

from contact_bench.api import fem_nd
from contact_bench.api.fem import LUMPED_KINDS, REDISTRIBUTED_KINDS, canonical_mass
from contact_bench.api.kept import built_once
from contact_bench.api.params import Param
from contact_bench.api.plugin import BodyCase, Footprint, StudyGrid
from contact_bench.api.reference_run import ReferenceRun, ReferenceSamples
from contact_bench.api.sparse import SparseProblem, sample_blocks
from contact_bench.exact import converged


class DiscDrop(BodyCase):
    name = "disc_drop"
    summary = "GetFEM's elastic disc dropped on a plane (2D plane strain, P1/P2)"
    params = {
        "degree": Param(2, "polynomial degree of the elements", choices=(1, 2)),
        "lift": Param(5.0, "initial height above the plane (impact speed sqrt(2 g lift))",
                      low=1e-6, high=1e3),
        "mu": Param(0.0, "Coulomb's friction coefficient on the plane (0: frictionless, "
                    "every scheme runs it)", low=0.0, high=10.0),
    }
    R, centre_y = 20.0, 20.0
    dim = 2
    lam = mu_l = 20.0
    rho, g = 1.0, 0.1
    T, nx, dt, stride = 40.0, 5, 0.01, 1

    @property
    def size(self) -> float:
        """The disc's diameter."""
        return 2 * self.R

    @property
    def p_modulus(self) -> float:
        """The P-wave modulus lambda + 2 mu: the contact stiffness scale (`E_contact`)."""
        return self.lam + 2 * self.mu_l

    def friction(self) -> float:
        return float(self.mu)

    @property
    def impact_time(self) -> float:
        """The first impact of the free fall, sqrt(2 lift / g)."""
        return math.sqrt(2 * float(self.lift) / self.g)

    @property
    def exact_energy(self) -> float:
        """E0 = m g lift of the continuous disc (the mesh's m differs by its geometry)."""
        return math.pi * self.R**2 * self.rho * self.g * float(self.lift)

    quantities = frozenset({"free_fall", "u_numerical", "contact_force_numerical",
                            *converged.QUANTITIES})
    #: the study's grid: nx 5, 10, 20, the levels whose errors against the converged
    #: reference decrease (docs/production-cases.md)
    study = StudyGrid(specs=("disc_drop[degree=1]", "disc_drop[degree=1,lift=20]"),
                      nx=(5, 10, 20), T=30.0, small="disc_drop[degree=1,lift=0.5]",
                      small_nx=(2, 3), small_T=5.0)
    #: the numerical reference: this scheme on the mesh with twice the rings, dt / 2
    reference_scheme = "redistributed"

    def quantity_errors(self, problem, traj, row,
                        reference: ReferenceSamples | None = None) -> dict[str, float]:
        """err_free_fall: the largest vertical displacement error of any dof against the
        free fall over the samples before the impact, relative to the lift. Against the
        numerical reference (`reference_run`: `reference_scheme` at 2 nx, dt / 2, sampled
        at the run's times, computed and cached by the harness, given as `reference`):
        err_u_numerical, the largest error of u at the mesh's vertices (shared by both
        meshes) over the largest |u_ref| of any dof, and err_contact_force_numerical, the
        l2 error over the samples of the total contact force over its l2 norm. Against the
        converged reference of results/references/disc_drop.json when it is this
        variant's (`contact_bench.exact.converged.errors`): err_contact_start, _end,
        _duration, err_peak_force, err_contact_impulse, err_rebound_velocity,
        err_vibration_energy and err_force_history."""
        dt = float(row["dt"])
        out = converged.drop_errors(self, problem, traj, dt)
        nx = int(row["nx"])
        if (reference is None or traj.t.size < 2
                or problem.U0.size != 2 * self.scalar_dofs(nx).shape[1]):
            return out
        ref = reference
        k = min(ref.t.size, traj.t.size)
        nv = self.mesh(nx).nvertices  # scikit-fem numbers the vertices' dofs first
        cols = np.ravel(np.stack([2 * np.arange(nv), 2 * np.arange(nv) + 1], axis=1))
        du = max(float(np.max(np.abs(traj.U[b][:, cols] - ref.U[b])))  # ref.U: the fine
                 for b in sample_blocks(k, cols.size))  # dofs at these vertices
        out["err_u_numerical"] = du / float(np.max(ref.U_absmax[:k]))
        force = -traj.stress[:k] * float(np.sum(problem.contact.weights))
        rforce = -ref.stress[:k] * ref.contact_measure
        if np.any(rforce):
            out["err_contact_force_numerical"] = float(
                np.linalg.norm(force - rforce) / np.linalg.norm(rforce))
        return out

    def reference_run(self, nx: int, dt: float, T: float, stride: int) -> ReferenceRun:
        """The numerical reference of a run at (nx, dt, T, stride): `reference_scheme` on
        twice the rings with dt / 2 and 2 stride (the run's sample times), keeping the
        fine mesh's dofs at this mesh's vertices (both components, in this mesh's vertex
        order): what err_u_numerical reads."""
        P = self.scalar_dofs(nx)
        nv = self.mesh(nx).nvertices
        fineP = self.scalar_dofs(2 * nx)
        scale = float(self.R)
        where = {tuple(np.round(q / scale, 9)): s for s, q in enumerate(fineP.T)}
        fine = np.array([where[tuple(np.round(q / scale, 9))] for q in P[:, :nv].T])
        keep = np.ravel(np.stack([2 * fine, 2 * fine + 1], axis=1)).astype(np.int64)
        steps = int(round(T / dt))
        return ReferenceRun(self.reference_scheme, 2 * int(nx), dt / 2, 2 * steps,
                            2 * int(stride), keep,
                            f"{self.reference_scheme} at nx = {2 * int(nx)}, dt = {dt / 2:g}, "
                            f"{2 * steps} steps")

    def scalar_dofs(self, nx: int) -> np.ndarray:
        """(2, scalar dofs): where each scalar dof of the mesh with nx rings sits (the
        body's `dof_coordinates`, without assembling it)."""
        m = self.mesh(nx)
        return np.asarray(fe.Basis(m, fem_nd.element_for(m, int(self.degree))).doflocs)

    def free_fall(self, t: np.ndarray) -> np.ndarray:
        """The vertical displacement of every point before the first impact."""
        return float(self.lift) - 0.5 * self.g * np.asarray(t, float) ** 2

    def footprint(self, nx: int) -> Footprint:
        """nx rings: 1 + 3 nx (nx + 1) vertices, 9 nx^2 + 3 nx edges (P2 adds one node
        on each), two unknowns per node."""
        n = int(nx)
        nodes = 1 + 3 * n * (n + 1) + (9 * n * n + 3 * n if int(self.degree) == 2 else 0)
        return Footprint(2 * nodes, 2, int(self.degree))

    @built_once
    def mesh(self, nx: int) -> fe.MeshTri2:
        """The ring mesh: nx rings of 6 k nodes, triangulated on the half x >= 0 and
        mirrored; P2 geometry with the boundary's edge midpoints on the circle."""
        p, t = ring_disc(int(nx))
        p = p * self.R
        p[1] += self.centre_y
        m = fe.MeshTri2.from_mesh(fe.MeshTri1(p, t))
        D = m.dofs.get_facet_dofs(m.boundary_facets()).flatten()
        loc = m.doflocs.copy()
        c = np.array([[0.0], [self.centre_y]])
        r = loc[:, D] - c
        loc[:, D] = c + self.R * r / np.linalg.norm(r, axis=0)
        return replace(m, doflocs=loc)

    @built_once
    def body(self, nx: int) -> fem_nd.Elasticity:
        nu = self.lam / (2 * (self.lam + self.mu_l))
        E = self.mu_l * (3 * self.lam + 2 * self.mu_l) / (self.lam + self.mu_l)
        return fem_nd.assemble(self.mesh(nx), E, nu, self.rho, degree=int(self.degree))

    def cannot_run(self, scheme) -> str | None:
        if int(self.degree) == 2 and canonical_mass(scheme.mass_kind()) in LUMPED_KINDS:
            return ("a lumped mass on P2 elements has negative row sums at the vertices: "
                    "use disc_drop[degree=1] or the scheme's mass=consistent")
        return super().cannot_run(scheme)

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        if grading != 1.0:
            raise ValueError(f"grading = {grading!r}: the disc's ring mesh is uniform "
                             "(allowed: 1)")
        body = self.body(nx)
        P = body.dof_coordinates
        # the lower half: outward normal pointing down (GetFEM: n_y < -0.01)
        facets = body.boundary_facets(lambda x: x[1] < self.centre_y - 0.01 * self.R)
        scalar = np.unique(body.scalar.get_dofs(facets).flatten())  # for the mass
        kind = canonical_mass(mass_kind)
        M = fem_nd.mass_matrix(body, "redistributed" if kind in REDISTRIBUTED_KINDS else kind,
                               scalar)
        # the load of the scheme's mass (as gravity acts on it): a massless dof carries
        # none, so the free fall stays exact; every variant keeps the total mass
        F = fem_nd.body_force(M, 2, np.array([0.0, -self.g]))
        n = body.ndofs
        U0 = np.zeros(n)
        U0[1::2] = float(self.lift)
        zone = fem_nd.contact_zone(body, facets, axis=1)
        contact = zone.contact_set(mu=float(self.mu))
        shear = (fem_nd.tangential_stress(body, facets, 1, zone.tangent_directions)
                 if contact.frictional else None)  # Nitsche's friction term
        return SparseProblem(M=M, K=body.K, F=F, U0=U0, V0=np.zeros(n), contact=contact,
                             dim=2, hmin=body.hmin, c_max=body.wave_speed,
                             mass_kind=mass_kind,
                             equal_groups=tuple(g for g in (mirror_pairs(P) * 2 + 1,) if g.size),
                             E_contact=self.p_modulus,
                             h_contact=fem_nd.contact_length(body, self.R / int(nx)),
                             normal_stress=zone.normal_stress, tangential_stress=shear,
                             vertical=np.tile([0.0, 1.0], n // 2),
                             body_mass=float(np.sum(M @ np.tile([0.0, 1.0], n // 2))))


def ring_disc(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit disc centred at 0: node 0 the centre, ring k (1..n) of 6 k nodes from the
    bottom (angle -pi/2) counter-clockwise; triangles (3, 6 n^2), counter-clockwise,
    mirror symmetric about x = 0."""
    pts = [np.zeros((2, 1))]
    first = [0]
    for k in range(1, n + 1):
        a = -np.pi / 2 + 2 * np.pi * np.arange(6 * k) / (6 * k)
        first.append(first[-1] + (6 * (k - 1) if k > 1 else 1))
        pts.append(k / n * np.vstack([np.cos(a), np.sin(a)]))

    def node(k: int, j: int) -> int:
        return 0 if k == 0 else first[k] + j % (6 * k)

    def mirror(k: int, j: int) -> int:
        return 0 if k == 0 else node(k, 6 * k - j)

    tris: list[tuple[int, int, int]] = []
    for k in range(1, n + 1):  # the half x >= 0: inner 0..3(k-1), outer 0..3k
        half: list[tuple[tuple[int, int], ...]] = []
        i = j = 0
        ni, no = 3 * (k - 1), 3 * k
        while i < ni or j < no:
            if k == 1 or i == ni or (j < no and (j + 1) * ni <= (i + 1) * no):
                half.append(((k - 1, i), (k, j), (k, j + 1)))
                j += 1
            else:
                half.append(((k - 1, i), (k, j), (k - 1, i + 1)))
                i += 1
        for a, b, c in half:
            tris.append((node(*a), node(*b), node(*c)))
            tris.append((mirror(*a), mirror(*c), mirror(*b)))
    return np.hstack(pts), np.ascontiguousarray(np.array(tris, np.int64).T)


def mirror_pairs(P: np.ndarray) -> np.ndarray:
    """(pairs, 2) scalar dofs at (x, y) and (-x, y), x > 0 (those with a mirror image:
    all on the ring mesh, few or none on an external mesh)."""
    scale = float(np.max(np.abs(P)))
    key = {(round(x / scale, 9), round(y / scale, 9)): s for s, (x, y) in enumerate(P.T)}
    right = np.flatnonzero(P[0] > 1e-9 * scale)
    pairs = [[s, key.get((round(-P[0, s] / scale, 9), round(P[1, s] / scale, 9)), -1)]
             for s in right]
    return np.array([q for q in pairs if q[1] >= 0], np.int64).reshape(-1, 2)

