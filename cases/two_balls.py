"""Two elastic balls meeting at +v and -v without gravity: the 3D counterpart of
`two_discs`, two tetrahedral bodies joined by node-to-facet rows.

Ball A is `sphere_drop`'s ball (radius 20, lambda = mu = 20, rho = 1, P1/P2 tetrahedra,
the refined octahedron or the lattice (`ball`), its lower half the contact zone), its
bottom `lift` above the plane z = 0, moving down at `speed`; ball B is its mirror image
below the plane, moving up. Each zone node a of A is projected along e_z on B's boundary
triangles (`contact_bench.api.node_to_facet`, once, in the reference configuration):
the row +1 on a's z dof, -N_k on the z dofs of the triangle's nodes (P1: its vertices;
P2: the quadratic triangle's six). B the exact mirror of A: each projection a node, node
to node. `turn_b` (degrees about B's vertical axis) or `ball_b` (B meshed by the other
kind of tetrahedra) makes B's mesh non-matching: the rows are node to facet, their weights
summing to one (the momentum kept: `err_pair_momentum`). By symmetry each ball of a
matching pair is one ball on a rigid plane at z = 0 without gravity (`half=1`): every
observable equal (energy: half), to round-off for a scheme whose run is Lipschitz in the
data; a non-matching pair approaches it as both are refined (docs/contact.md).
Penalty sizes are the half problem's (`h_contact` doubled, as two_discs); Nitsche's
two-body stress term is not built.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from contact_bench.api import fem_nd, two_bodies
from contact_bench.api import node_to_facet as ntf
from contact_bench.api.fem import REDISTRIBUTED_KINDS, canonical_mass
from contact_bench.api.params import Param
from contact_bench.api.plugin import BodyCase, Footprint, StudyGrid
from contact_bench.api.registry import make_case
from contact_bench.api.sparse import ContactSet, SparseProblem

#: the mirror z -> -z
MIRROR = np.diag([1.0, 1.0, -1.0])


class TwoBalls(BodyCase):
    name = "two_balls"
    summary = "two elastic balls meeting at +v and -v (node-to-node or node-to-facet)"
    params = {
        "degree": Param(1, "polynomial degree of the elements", choices=(1, 2)),
        "speed": Param(1.0, "each ball's speed towards the other", low=1e-6, high=10.0),
        "lift": Param(0.5, "each ball's distance to the symmetry plane", low=0.0, high=100.0),
        "half": Param(0, "1: ball A against a rigid plane on the symmetry plane",
                      choices=(0, 1)),
        "ball": Param("octahedron", "the balls' tetrahedra (as sphere_drop): the refined "
                      "octahedron (nx a power of two) or the lattice (any nx)",
                      choices=("octahedron", "lattice")),
        "ball_b": Param("same", "ball B's tetrahedra: as A's, or the other kind "
                        "(non-matching)", choices=("same", "octahedron", "lattice")),
        "turn_b": Param(0.0, "ball B's mesh turned about its vertical axis, degrees "
                        "(non-matching)", low=-180.0, high=180.0),
    }
    T, nx, dt, stride = 4.0, 4, 0.01, 1
    dim = 3
    #: the small grid's nx 8: the first the redistributed mass runs on (as sphere_drop)
    study = StudyGrid(specs=("two_balls",), nx=(4, 8), T=4.0, small="two_balls",
                      small_nx=(2, 8), small_T=2.0, in_default_study=False)
    quantities = frozenset({"pair_momentum"})

    def validate(self) -> None:
        #: ball A: its mesh, material and contact zone
        self.ball_a = make_case(f"sphere_drop[degree={int(self.degree)},ball={self.ball}]")
        kind_b = self.ball if self.ball_b == "same" else self.ball_b
        #: ball B before it is mirrored and turned
        self.ball_b_case = make_case(f"sphere_drop[degree={int(self.degree)},ball={kind_b}]")

    @property
    def size(self) -> float:
        return self.ball_a.size

    @property
    def impact_time(self) -> float:
        return float(self.lift) / float(self.speed)

    def body(self, nx: int):
        return self.ball_a.body(nx)

    def footprint(self, nx: int) -> Footprint:
        one = self.ball_a.footprint(nx)
        if int(self.half):
            return one
        return one._replace(unknowns=one.unknowns + self.ball_b_case.footprint(nx).unknowns)

    def cannot_run(self, scheme) -> str | None:
        return two_bodies.nitsche_refusal(self, scheme) or self.ball_a.cannot_run(scheme)

    def quantity_errors(self, problem, traj, row) -> dict[str, float]:
        return two_bodies.pair_momentum_errors(self, problem, traj)

    def turn(self) -> np.ndarray:
        """The 3 x 3 map of ball B's reference displacement to the scene's: the mirror
        z -> -z, then the turn by `turn_b` about the vertical axis."""
        phi = np.radians(float(self.turn_b))
        if phi == 0.0:
            return MIRROR
        R = np.array([[np.cos(phi), -np.sin(phi), 0.0], [np.sin(phi), np.cos(phi), 0.0],
                      [0.0, 0.0, 1.0]])
        return R @ MIRROR

    def place_b(self, X: np.ndarray) -> np.ndarray:
        """Ball B's points (3, m) of its reference mesh points X (centred at (0, 0,
        centre_z)): mirrored about z = 0 and turned about the vertical axis x = y = 0."""
        return self.turn() @ X

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        one = self.ball_a.sparse_problem(nx, grading, mass_kind)
        n = one.nfree
        v, lift = float(self.speed), float(self.lift)
        U0 = np.zeros(n)
        U0[2::3] = lift
        V0 = np.zeros(n)
        V0[2::3] = -v
        c = one.contact
        if int(self.half):  # ball A on the rigid plane z = 0, without gravity
            return SparseProblem(M=one.M, K=one.K, F=np.zeros(n), U0=U0, V0=V0, contact=c,
                                 dim=3, hmin=one.hmin, c_max=one.c_max, mass_kind=mass_kind,
                                 E_contact=one.E_contact, h_contact=one.h_contact,
                                 normal_stress=one.normal_stress, vertical=one.vertical,
                                 body_mass=one.body_mass)
        matching = self.ball_b_case.ball == self.ball_a.ball and float(self.turn_b) == 0.0
        # the rows: A's zone nodes projected along e_z on B's triangles facing them (B's
        # boundary below its centre + R / 2 before the mirror: every facet a vertical
        # line from A's lower half can meet, those facing away skipped)
        slave = (np.asarray(c.dofs, np.int64) - 2) // 3
        body_a, body_b = self.ball_a.body(nx), self.ball_b_case.body(nx)
        top = self.ball_a.centre_z + 0.5 * self.ball_a.R
        master = ntf.surface(body_b, lambda x: x[2] < top, place=self.place_b)
        proj = ntf.project(body_a.dof_coordinates[:, slave], master, normal=[0.0, 0.0, 1.0])
        nb = body_b.ndofs
        G = ntf.gap_rows(proj, slave, master, n, nb)
        # ball B: its stiffness Q K Q^T (Q the mirror and turn on each node); its mass
        # acts alike on the three components, with the nodes its rows touch as its
        # contact zone (massless for a scheme that needs them so); matching: A's
        if matching:
            MB = one.M
        else:
            touched = np.unique(master.dofs[proj.facet][proj.weights != 0.0])
            kind = canonical_mass(mass_kind)
            MB = fem_nd.mass_matrix(
                body_b, "redistributed" if kind in REDISTRIBUTED_KINDS else kind, touched)
        Q = sp.csr_matrix(sp.kron(sp.identity(nb // 3), self.turn()))
        M = sp.csr_matrix(sp.block_diag([one.M, MB]))
        K = sp.csr_matrix(sp.block_diag([one.K, Q @ body_b.K @ Q.T]))
        contact = ContactSet(dofs=None, gap0=proj.gap0, weights=np.asarray(c.weights, float),
                             face_mass=c.face_mass, operator=G)
        up = np.tile([0.0, 0.0, 1.0], nb // 3)
        return SparseProblem(M=M, K=K, F=np.zeros(n + nb), U0=np.r_[U0, -lift * up],
                             V0=np.r_[V0, v * up], contact=contact, dim=3,
                             hmin=min(one.hmin, body_b.hmin), c_max=one.c_max,
                             mass_kind=mass_kind, E_contact=one.E_contact,
                             h_contact=2.0 * one.h_contact, normal_stress=None,
                             vertical=np.r_[one.vertical, -up],
                             body_mass=one.body_mass + float(np.sum(MB @ up)))
