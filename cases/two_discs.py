"""Two identical elastic discs meeting at +v and -v without gravity: two deformable bodies
in contact through a gap operator whose rows join them (node to node).

Disc A is `disc_drop`'s disc (radius 20, lambda = mu = 20, rho = 1, P1/P2 ring mesh, its
lower half the contact zone), its bottom `lift` above the line y = 0, moving down at
`speed`; disc B is its mirror image below the line, moving up. Each contact row pairs a
zone node a of A with its mirror image b of B: gap = (X_a + u_a - X_b - u_b) . e_y, the
row +1 on a's y dof and -1 on b's. By symmetry (u_B the mirror of u_A) the line y = 0
does not move and each disc is one disc hitting a rigid plane there at `speed`: the
scene with `half=1`, every observable of which (contact start and end, peak force,
impulse, disc A's displacement) equals the two discs' (energy: half of it), up to
round-off for a scheme whose run is Lipschitz in the data. The two-body penalty and
Nitsche sizes are those of the half problem (`h_contact` twice the disc's: a spring on
the two-body gap, twice the half gap, gives the half problem's force). Nitsche's
stress term on two bodies (the mean of the two sides' normal stresses) is not built:
nitsche refuses the two discs in one line.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from contact_bench.api.params import Param
from contact_bench.api.plugin import BodyCase, Contact, Footprint, StudyGrid
from contact_bench.api.registry import make_case
from contact_bench.api.sparse import ContactSet, SparseProblem


class TwoDiscs(BodyCase):
    name = "two_discs"
    summary = "two elastic discs meeting at +v and -v (two bodies, node-to-node contact)"
    params = {
        "degree": Param(1, "polynomial degree of the elements", choices=(1, 2)),
        "speed": Param(1.0, "each disc's speed towards the other", low=1e-6, high=10.0),
        "lift": Param(0.5, "each disc's distance to the symmetry line", low=0.0, high=100.0),
        "half": Param(0, "1: disc A against a rigid plane on the symmetry line", choices=(0, 1)),
    }
    T, nx, dt, stride = 4.0, 5, 0.01, 1
    study = StudyGrid(specs=("two_discs",), nx=(3, 5), T=4.0, small="two_discs",
                      small_nx=(2, 3), small_T=2.0, in_default_study=False)

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
        return one if int(self.half) else one._replace(unknowns=2 * one.unknowns)

    def cannot_run(self, scheme) -> str | None:
        if not int(self.half) and scheme.traits().contact == Contact.NITSCHE:
            return ("Nitsche's method between two bodies (the mean of their normal "
                    "stresses) is not built: use two_discs[half=1]")
        return self.disc.cannot_run(scheme)

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
        # disc B: A mirrored (y -> -y); its mass is A's (it acts alike on both components),
        # its stiffness A's reflected
        Q = sp.csr_matrix(sp.kron(sp.identity(n // 2), np.diag([1.0, -1.0])))
        M = sp.csr_matrix(sp.block_diag([one.M, one.M]))
        K = sp.csr_matrix(sp.block_diag([one.K, Q @ one.K @ Q.T]))
        dofs = np.asarray(c.dofs, np.int64)
        rows = np.arange(dofs.size)
        G = sp.csr_matrix((np.r_[np.ones(dofs.size), -np.ones(dofs.size)],
                           (np.r_[rows, rows], np.r_[dofs, n + dofs])), shape=(dofs.size, 2 * n))
        contact = ContactSet(dofs=None, gap0=2.0 * np.asarray(c.gap0, float),
                             weights=np.asarray(c.weights, float), face_mass=c.face_mass,
                             operator=G)
        return SparseProblem(M=M, K=K, F=np.zeros(2 * n), U0=np.r_[U0, -U0],
                             V0=np.r_[V0, -V0], contact=contact, dim=2, hmin=one.hmin,
                             c_max=one.c_max, mass_kind=mass_kind, E_contact=one.E_contact,
                             h_contact=2.0 * one.h_contact, normal_stress=None,
                             vertical=np.r_[one.vertical, -one.vertical],
                             body_mass=2.0 * one.body_mass)
