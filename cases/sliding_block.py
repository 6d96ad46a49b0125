"""An elastic block resting on a plane tilted by `angle`, with Coulomb friction `mu`.

The block (2D plane strain, 2 x 1, lambda = mu_L = 20, rho = 1, P1 or P2, structured
triangles, `nx` elements along the height) starts undeformed, moving downhill at `speed`,
its bottom on the plane, under vertical gravity g = 1. The plane is `slanted_drop`'s (its
rotation R of `angle`: K' = Q K Q^T, G' = G Q^T); each bottom node is a contact point with
its normal row R e_y and one tangent row, the downhill direction t.

K' does not act on a rigid translation and each point's rows are unit vectors on its
node, so while every contact point slides downhill (or is apart) its tangential impulse
is -mu times its normal one and, step by step,
    d(p_t + mu p_n) = dt (t.F + mu n.F) = dt m g (sin(angle) - mu cos(angle))
(p_t = t.M V, p_n = n.M V): `err_sliding_momentum` is its largest departure over the
sample intervals with every contact point moving downhill at both ends, relative to
|rate| T + |p_t + mu p_n| at T. With mu > tan(angle) the block sticks: its tangential
momentum stays within the elastic vibration's bound (tests/test_friction.py).
Derivation and measurements: docs/scenes.md.
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
from contact_bench.api.sparse import ContactSet, SparseProblem


class SlidingBlock(BodyCase):
    name = "sliding_block"
    summary = "elastic block on a tilted plane with Coulomb friction (slides or sticks)"
    params = {
        "angle": Param(30.0, "the plane's tilt, degrees", low=0.0, high=75.0),
        "mu": Param(0.0, "Coulomb's friction coefficient (0: frictionless, every scheme "
                    "runs it)", low=0.0, high=10.0),
        "degree": Param(1, "polynomial degree of the elements", choices=(1, 2)),
        "speed": Param(0.2, "initial speed downhill (0: at rest)", low=0.0, high=100.0),
    }
    width, height = 2.0, 1.0
    lam = mu_l = 20.0
    rho, g = 1.0, 1.0
    T, nx, dt, stride = 2.0, 2, 0.01, 1
    quantities = frozenset({"sliding_momentum"})
    study = StudyGrid(specs=("sliding_block[mu=0.3]",), nx=(2, 4), T=2.0, small="sliding_block",
                      small_nx=(2, 3), small_T=0.5, in_default_study=False)

    def validate(self) -> None:
        #: `slanted_drop` of the same angle, vertical gravity: its rotation and tangent
        self.tilt = make_case(f"slanted_drop[angle={float(self.angle)!r},tilt_gravity=0]")

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
        m = fe.MeshTri.init_tensor(np.linspace(-0.5 * self.width, 0.5 * self.width, 2 * n + 1),
                                   np.linspace(0.0, self.height, n + 1))
        nu = self.lam / (2 * (self.lam + self.mu_l))
        E = self.mu_l * (3 * self.lam + 2 * self.mu_l) / (self.lam + self.mu_l)
        return fem_nd.assemble(m, E, nu, self.rho, degree=int(self.degree))

    def normal(self, p: SparseProblem) -> np.ndarray:
        """n: the rigid translation along the plane's normal (R e_y), one value per dof."""
        return np.tile(self.tilt.rotation(2)[:, 1], p.nfree // 2)

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        if grading != 1.0:
            raise ValueError(f"grading = {grading!r}: the block's mesh is uniform (allowed: 1)")
        body = self.body(nx)
        facets = body.boundary_facets(lambda x: x[1] < 1e-12)
        zone = fem_nd.contact_zone(body, facets, axis=1)
        kind = canonical_mass(mass_kind)
        M = fem_nd.mass_matrix(body, "redistributed" if kind in REDISTRIBUTED_KINDS else kind,
                               zone.scalar)
        n = body.ndofs
        R = self.tilt.rotation(2)
        Q = sp.csr_matrix(sp.kron(sp.identity(n // 2), R))
        K = sp.csr_matrix(Q @ body.K @ Q.T)
        F = M @ np.tile([0.0, -self.g], n // 2)  # vertical gravity on the scheme's mass
        nc = zone.scalar.size
        G = sp.csr_matrix((np.ones(nc), (np.arange(nc), zone.dofs)), shape=(nc, n)) @ Q.T
        # the tangent rows: the downhill direction t on each contact node
        down = self.tilt.tangent(SimpleNamespace(nfree=n, dim=2))
        cols = np.stack([2 * zone.scalar, 2 * zone.scalar + 1], axis=1).ravel()
        rows = np.repeat(np.arange(nc), 2)
        T = sp.csr_matrix((down[cols], (rows, cols)), shape=(nc, n))
        G, T = sp.csr_matrix(G), sp.csr_matrix(T)
        G.eliminate_zeros()
        T.eliminate_zeros()
        contact = ContactSet(dofs=None, gap0=np.asarray(zone.gap0, float),
                             weights=np.asarray(zone.weights, float), face_mass=zone.face_mass,
                             operator=G, tangents=T,
                             friction=np.full(nc, float(self.mu)))
        shear = None
        if contact.frictional:  # Nitsche's friction term: the traction along t
            side = float((R.T @ down[:2])[0])  # t = side R e_x on every node
            shear = sp.csr_matrix(side * fem_nd.contact_shear(body, facets, 1, 0) @ Q.T)
        vertical = self.normal(SimpleNamespace(nfree=n))
        # the energy's zero: gravity's potential zero on the horizontal line through the
        # plane's point under the block's centre (E(0) = m g times the centre's height)
        X = Q @ np.asarray(body.dof_coordinates).T.ravel()
        V0 = float(self.speed) * down  # a rigid motion downhill
        return SparseProblem(M=M, K=K, F=F, U0=np.zeros(n), V0=V0, contact=contact,
                             dim=2, hmin=body.hmin, c_max=body.wave_speed,
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
        v = V @ problem.contact.tangents.T
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
