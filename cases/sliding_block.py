"""An elastic block resting on a plane tilted by `angle`, with Coulomb friction `mu`.

The block (`dim` 2: plane strain, 2 x 1, structured triangles; `dim` 3: a 2 x 1 x 1 box,
its bottom a shallow V resting on its ridge y = 0, mirrored tetrahedra: `keeled_box`;
lambda = mu_L = 20, rho = 1, P1 or P2, `nx` elements along the height) starts undeformed,
moving downhill at `speed`, under vertical gravity g = 1, on `slanted_drop`'s plane
tilted about the axis across the slope (K' = Q K Q^T, G' = G Q^T). Each bottom node is a
contact point: its normal row and dim - 1 tangent rows (downhill t; in 3D also e_y).

K' does not act on a rigid translation, so while every contact point slides downhill (or
is apart) its tangential impulse is -mu times its normal one and, step by step,
    d(p_t + mu p_n) = dt (t.F + mu n.F) = dt m g (sin(angle) - mu cos(angle))
(p_t = t.M V, p_n = n.M V): `err_sliding_momentum` is its largest departure over the
sample intervals with every contact point moving downhill at both ends, relative to
|rate| T + |p_t + mu p_n| at T. With mu > tan(angle) the block sticks: its tangential
momentum stays within the elastic vibration's bound (tests/test_friction.py).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import scipy.sparse as sp
import skfem as fe

from contact_bench.api import fem_nd
from contact_bench.api.fem import REDISTRIBUTED_KINDS, canonical_mass
from contact_bench.api.kept import built_once
from contact_bench.api.params import Param
from contact_bench.api.plugin import BodyCase, StudyGrid
from contact_bench.api.registry import make_case
from contact_bench.api.sparse import ContactSet, SparseProblem, tangent_rows


class SlidingBlock(BodyCase):
    name = "sliding_block"
    summary = "elastic block on a tilted plane with Coulomb friction (slides or sticks)"
    params = {
        "angle": Param(30.0, "the plane's tilt, degrees", low=0.0, high=75.0),
        "mu": Param(0.0, "Coulomb's friction coefficient (0: frictionless, every scheme "
                    "runs it)", low=0.0, high=10.0),
        "degree": Param(1, "polynomial degree of the elements", choices=(1, 2)),
        "speed": Param(0.2, "initial speed downhill (0: at rest)", low=0.0, high=100.0),
        "dim": Param(2, "2: plane strain block; 3: a box (two tangents, the circular cone)",
                     choices=(2, 3)),
    }
    width, height, depth, keel = 2.0, 1.0, 1.0, 0.3
    lam = mu_l = 20.0
    rho, g = 1.0, 1.0
    T, nx, dt, stride = 2.0, 2, 0.01, 1
    quantities = frozenset({"sliding_momentum"})
    study = StudyGrid(specs=("sliding_block[mu=0.3]",), nx=(2, 4), T=2.0, small="sliding_block",
                      small_nx=(2, 3), small_T=0.5, in_default_study=False)

    def validate(self) -> None:
        #: `slanted_drop` of the same angle, vertical gravity: its rotation and tangent
        of = "sphere_drop" if int(self.dim) == 3 else "disc_drop[degree=1]"
        self.tilt = make_case(f"slanted_drop[of={of},angle={float(self.angle)!r},"
                              "tilt_gravity=0]")

    @property
    def size(self) -> float:
        return self.width

    @property
    def impact_time(self) -> float:
        return 0.0

    def friction(self) -> float:
        return float(self.mu)

    @built_once
    def body(self, nx: int) -> fem_nd.Elasticity:
        n = int(nx)
        x = np.linspace(-0.5 * self.width, 0.5 * self.width, 2 * n + 1)
        z = np.linspace(0.0, self.height, n + 1)
        m = (fe.MeshTri.init_tensor(x, z) if int(self.dim) == 2
             else keeled_box(x, z, n, self.depth, self.keel))
        nu = self.lam / (2 * (self.lam + self.mu_l))
        E = self.mu_l * (3 * self.lam + 2 * self.mu_l) / (self.lam + self.mu_l)
        return fem_nd.assemble(m, E, nu, self.rho, degree=int(self.degree))

    def normal(self, p: SparseProblem) -> np.ndarray:
        """n: the rigid translation along the plane's normal (R e_vertical), one value per
        dof."""
        d = int(self.dim)
        return np.tile(self.tilt.rotation(d)[:, d - 1], p.nfree // d)

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        if grading != 1.0:
            raise ValueError(f"grading = {grading!r}: the block's mesh is uniform (allowed: 1)")
        body = self.body(nx)
        d = int(self.dim)
        # the bottom (in 3D the V under the ridge: z <= keel 2 |y| / depth)
        facets = body.boundary_facets(
            lambda x: x[d - 1] < 1e-12 + (0.0 if d == 2 else
                                          self.keel * 2.0 * np.abs(x[1]) / self.depth))
        zone = fem_nd.contact_zone(body, facets, axis=d - 1)
        kind = canonical_mass(mass_kind)
        M = fem_nd.mass_matrix(body, "redistributed" if kind in REDISTRIBUTED_KINDS else kind,
                               zone.scalar)
        n = body.ndofs
        R = self.tilt.rotation(d)
        Q = sp.csr_matrix(sp.kron(sp.identity(n // d), R))
        K = sp.csr_matrix(Q @ body.K @ Q.T)
        down = np.zeros(d)
        down[d - 1] = -self.g
        F = M @ np.tile(down, n // d)  # vertical gravity on the scheme's mass
        nc = zone.scalar.size
        G = sp.csr_matrix((np.ones(nc), (np.arange(nc), zone.dofs)), shape=(nc, n)) @ Q.T
        # the tangent rows, point by point (row j n_t + k: point j's k-th tangent on its
        # node's dofs): the downhill direction t, and in 3D the horizontal across the
        # slope (R e_y = e_y)
        slope = self.tilt.tangent(SimpleNamespace(nfree=n, dim=d))[:d]
        dirs = np.array([slope] + ([R[:, 1]] if d == 3 else []))
        T = tangent_rows(zone.scalar, dirs, n)
        G = sp.csr_matrix(G)
        G.eliminate_zeros()
        contact = ContactSet(dofs=None, gap0=np.asarray(zone.gap0, float),
                             weights=np.asarray(zone.weights, float), face_mass=zone.face_mass,
                             operator=G, tangents=T,
                             friction=np.full(nc, float(self.mu)))
        shear = None
        if contact.frictional and d == 2:  # Nitsche's friction term (2D): the traction along t
            side = float((R.T @ slope)[0])  # t = side R e_x on every node
            shear = sp.csr_matrix(side * fem_nd.contact_shear(body, facets, 1, 0) @ Q.T)
        vertical = self.normal(SimpleNamespace(nfree=n))
        # the energy's zero: gravity's potential zero on the horizontal line through the
        # plane's point under the block's centre (E(0) = m g times the centre's height)
        X = Q @ np.asarray(body.dof_coordinates).T.ravel()
        V0 = float(self.speed) * np.tile(slope, n // d)  # a rigid motion downhill
        return SparseProblem(M=M, K=K, F=F, U0=np.zeros(n), V0=V0, contact=contact,
                             dim=d, hmin=body.hmin, c_max=body.wave_speed,
                             energy_offset=float(-F @ X),
                             mass_kind=mass_kind, E_contact=self.lam + 2 * self.mu_l,
                             h_contact=fem_nd.contact_length(body, self.height / int(nx)),
                             normal_stress=sp.csr_matrix(zone.normal_stress @ Q.T),
                             tangential_stress=shear,
                             vertical=vertical, body_mass=float(vertical @ (M @ vertical)))

    def sliding(self, problem: SparseProblem, V: np.ndarray) -> np.ndarray:
        """Per sample: every contact point moves downhill (its velocity along t above
        1e-8 of the sample's largest speed: a stuck point's is round-off)."""
        V = np.asarray(V)
        nt = problem.contact.tangents.shape[0] // problem.contact.size
        v = (V @ problem.contact.tangents.T)[:, ::nt]  # along t
        return np.all(v > 1e-8 * np.max(np.abs(V), axis=1, keepdims=True), axis=1)

    def quantity_errors(self, problem, traj, row) -> dict[str, float]:
        """err_sliding_momentum (module docstring): max over the sample intervals with
        every contact point moving downhill at both ends of |d(p_t + mu p_n) - dt_k (t.F
        + mu n.F)|, relative to |rate| T + |p_t + mu p_n| at the last sample; NaN when no
        interval slides (the block sticks)."""
        t, nv = self.tilt.tangent(problem), self.normal(problem)
        mu = float(self.mu)
        P = traj.V @ (problem.M @ (t + mu * nv))
        rate = float(t @ problem.F + mu * (nv @ problem.F))
        both = self.sliding(problem, traj.V)
        both = both[1:] & both[:-1]
        if not np.any(both):
            return {"err_sliding_momentum": math.nan}
        drift = np.diff(P) - np.diff(traj.t) * rate
        scale = abs(rate) * float(traj.t[-1]) + abs(float(P[-1]))
        return {"err_sliding_momentum": float(np.max(np.abs(drift[both])) / scale)}


def keeled_box(x: np.ndarray, z: np.ndarray, n: int, depth: float, keel: float
               ) -> fe.MeshTet:
    """The 3D block: the box x by [-depth/2, depth/2] by z in tetrahedra, skfem's
    structured half y >= 0 (ceil(n / 2) layers) and its mirror image joined on y = 0
    (the same triangles on both sides), its bottom raised into a shallow V, z -> z + keel
    (2 |y| / depth) (1 - z / z_top): it rests on the ridge y = 0 alone. Why: a flat box
    spreads sideways under its weight (Poisson), so its bottom points slip across the
    slope and the circular cone turns their friction off the downhill direction; on the
    ridge of a mirror-symmetric mesh the slip across the slope is zero (round-off) and
    each point's friction is exactly mu times its normal force, downhill."""
    y = np.linspace(0.0, 0.5 * depth, max(1, -(-int(n) // 2)) + 1)
    half = fe.MeshTet.init_tensor(x, y, z)
    p, t = half.p, half.t
    mirror = p * np.array([[1.0], [-1.0], [1.0]])
    on_plane = np.flatnonzero(p[1] == 0.0)
    new = np.setdiff1d(np.arange(p.shape[1]), on_plane)
    index = np.empty(p.shape[1], np.int64)
    index[on_plane] = on_plane
    index[new] = p.shape[1] + np.arange(new.size)
    points = np.hstack([p, mirror[:, new]])
    top = float(z[-1])
    points[2] += keel * (2.0 * np.abs(points[1]) / depth) * (1.0 - points[2] / top)
    return fe.MeshTet(np.ascontiguousarray(points), np.ascontiguousarray(np.hstack([t, index[t]])))
