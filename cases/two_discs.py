"""Two elastic discs meeting at +v and -v without gravity: two deformable bodies joined
by gap rows (node to node where the meshes match, node to segment where they do not).

Disc A is `disc_drop`'s disc (radius 20, lambda = mu = 20, rho = 1, P1/P2 ring mesh, its
lower half the contact zone), its bottom `lift` above the line y = 0, moving down at
`speed`; disc B is its mirror image below the line, moving up. Each zone node a of A is
projected along e_y on B's facets (`contact_bench.api.node_to_segment`, once, in the
reference configuration): the row +1 on a's y dof, -N_k on the y dofs of the facet's
nodes. B the exact mirror of A: each projection a node, node to node. `rings_b` (more
rings) or `turn_b` (degrees about B's centre) make B's mesh non-matching: the rows are
node to segment, their weights summing to one (the momentum kept: `err_pair_momentum`).
By symmetry each disc of a matching pair is one disc on a rigid plane at y = 0 (`half=1`):
every observable equal (energy: half), to round-off for a scheme whose run is Lipschitz
in the data; a non-matching pair approaches it as both are refined (docs/contact.md).
Penalty sizes are the half problem's (`h_contact` doubled: a spring on the two-body gap,
twice the half gap, gives its force); Nitsche's two-body stress term is not built.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from contact_bench.api import fem_nd, two_bodies
from contact_bench.api import node_to_segment as nts
from contact_bench.api.fem import REDISTRIBUTED_KINDS, canonical_mass
from contact_bench.api.params import Param
from contact_bench.api.plugin import BodyCase, Footprint, StudyGrid
from contact_bench.api.registry import make_case
from contact_bench.api.sparse import ContactSet, SparseProblem


class TwoDiscs(BodyCase):
    name = "two_discs"
    summary = "two elastic discs meeting at +v and -v (node-to-node or node-to-segment)"
    params = {
        "degree": Param(1, "polynomial degree of the elements", choices=(1, 2)),
        "speed": Param(1.0, "each disc's speed towards the other", low=1e-6, high=10.0),
        "lift": Param(0.5, "each disc's distance to the symmetry line", low=0.0, high=100.0),
        "half": Param(0, "1: disc A against a rigid plane on the symmetry line", choices=(0, 1)),
        "rings_b": Param(0, "disc B's mesh has this many more rings than A's (non-matching)",
                         low=0, high=20),
        "turn_b": Param(0.0, "disc B's mesh turned about its centre, degrees (non-matching)",
                        low=-180.0, high=180.0),
    }
    T, nx, dt, stride = 4.0, 5, 0.01, 1
    dim = 2
    study = StudyGrid(specs=("two_discs",), nx=(3, 5), T=4.0, small="two_discs",
                      small_nx=(2, 3), small_T=2.0, in_default_study=False)
    quantities = frozenset({"pair_momentum"})

    def validate(self) -> None:
        #: the disc: its mesh, material and contact zone
        self.disc = make_case(f"disc_drop[degree={int(self.degree)}]")

    @property
    def size(self) -> float:
        return self.disc.size

    @property
    def impact_time(self) -> float:
        return float(self.lift) / float(self.speed)

    def body(self, nx: int):
        return self.disc.body(nx)

    def footprint(self, nx: int) -> Footprint:
        one = self.disc.footprint(nx)
        if int(self.half):
            return one
        other = self.disc.footprint(int(nx) + int(self.rings_b))
        return one._replace(unknowns=one.unknowns + other.unknowns)

    def cannot_run(self, scheme) -> str | None:
        return two_bodies.nitsche_refusal(self, scheme) or self.disc.cannot_run(scheme)

    def quantity_errors(self, problem, traj, row) -> dict[str, float]:
        return two_bodies.pair_momentum_errors(self, problem, traj)

    def place_b(self, X: np.ndarray) -> np.ndarray:
        """Disc B's points (2, m) of disc A's mesh points X: mirrored about y = 0, then
        turned by `turn_b` about B's centre (0, -centre_y)."""
        Y = np.vstack([X[0], -X[1]])
        phi = np.radians(float(self.turn_b))
        if phi == 0.0:
            return Y
        c = np.array([[0.0], [-self.disc.centre_y]])
        R = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]])
        return c + R @ (Y - c)

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        one = self.disc.sparse_problem(nx, grading, mass_kind)
        n = one.nfree
        v, lift = float(self.speed), float(self.lift)
        U0 = np.zeros(n)
        U0[1::2] = lift
        V0 = np.zeros(n)
        V0[1::2] = -v
        c = one.contact
        if int(self.half):  # disc A on the rigid plane y = 0
            return SparseProblem(M=one.M, K=one.K, F=np.zeros(n), U0=U0, V0=V0, contact=c,
                                 dim=2, hmin=one.hmin, c_max=one.c_max, mass_kind=mass_kind,
                                 E_contact=one.E_contact, h_contact=one.h_contact,
                                 normal_stress=one.normal_stress, vertical=one.vertical,
                                 body_mass=one.body_mass)
        nx_b = int(nx) + int(self.rings_b)
        phi = np.radians(float(self.turn_b))
        matching = nx_b == int(nx) and phi == 0.0
        # the rows: A's zone nodes projected along e_y on B's facets facing them (B's
        # mesh points below its centre + R / 2 before the mirror: every facet a ray
        # from A's lower half can meet, those facing away skipped)
        slave = (np.asarray(c.dofs, np.int64) - 1) // 2
        body_a, body_b = self.disc.body(nx), self.disc.body(nx_b)
        top = self.disc.centre_y + 0.5 * self.disc.R
        master = nts.surface(body_b, lambda x: x[1] < top, place=self.place_b)
        proj = nts.project(body_a.dof_coordinates[:, slave], master, normal=[0.0, 1.0])
        nb = body_b.ndofs
        G = nts.gap_rows(proj, slave, master, n, nb)
        # disc B: A's disc (rings_b more rings) mirrored (y -> -y) and turned, its
        # stiffness Q K Q^T; its mass acts alike on both components (the mirror's and the
        # turned disc's), with the nodes its rows touch as its contact zone (massless for
        # a scheme that needs them so); matching: the mirror image of A's
        if matching:
            MB = one.M
        else:
            touched = np.unique(master.dofs[proj.facet][proj.weights != 0.0])
            kind = canonical_mass(mass_kind)
            MB = fem_nd.mass_matrix(
                body_b, "redistributed" if kind in REDISTRIBUTED_KINDS else kind, touched)
        turn = np.array([[np.cos(phi), np.sin(phi)], [np.sin(phi), -np.cos(phi)]])
        Q = sp.csr_matrix(sp.kron(sp.identity(nb // 2),
                                  np.diag([1.0, -1.0]) if phi == 0.0 else turn))
        M = sp.csr_matrix(sp.block_diag([one.M, MB]))
        K = sp.csr_matrix(sp.block_diag([one.K, Q @ body_b.K @ Q.T]))
        contact = ContactSet(dofs=None, gap0=proj.gap0, weights=np.asarray(c.weights, float),
                             face_mass=c.face_mass, operator=G)
        UB0, VB0 = np.zeros(nb), np.zeros(nb)  # A's, then mirrored
        UB0[1::2], VB0[1::2] = lift, -v
        up = np.tile([0.0, 1.0], nb // 2)
        return SparseProblem(M=M, K=K, F=np.zeros(n + nb), U0=np.r_[U0, -UB0],
                             V0=np.r_[V0, -VB0],
                             contact=contact, dim=2, hmin=min(one.hmin, body_b.hmin),
                             c_max=one.c_max, mass_kind=mass_kind, E_contact=one.E_contact,
                             h_contact=2.0 * one.h_contact, normal_stress=None,
                             vertical=np.r_[one.vertical, -up],
                             body_mass=one.body_mass + float(np.sum(MB @ up)))
