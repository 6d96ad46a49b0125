"""Two identical elastic bars meeting at +v and -v (Cirak and West's example): two 1D
bodies in contact through a gap operator whose row joins their ends.

Bar A is `fast_impact`'s bar on (0, L) (rho = E = 1, free ends, the gap 0.01 L, speed
`mach` c towards x = 0); bar B is its mirror image on (-L, 0), moving the other way. The
one contact row is +1 on A's end dof and -1 on B's: gap = 2 gap_A (u_B = -u_A by
symmetry). By symmetry the point x = 0 does not move and each bar is a bar hitting a
rigid wall there: contact for 2 L / c, the stress -rho c v, the velocities reversed
after. The exact solution is `fast_impact`'s, by characteristics
(`contact_bench.exact.uniform_impact`); the errors are bar A's, on its nodes (the axis
view), against it, and the table's orders come from the grids nx 20, 40, 80.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.params import Param
from contact_bench.api.plugin import BodyCase, Contact, StudyGrid
from contact_bench.api.problem import BarProblem, discretise
from contact_bench.api.registry import make_case
from contact_bench.api.sparse import ContactSet, SparseProblem


class TwoBars(BodyCase):
    name = "two_bars"
    summary = "two bars meeting at +v and -v (two 1D bodies; exact: fast_impact's solution)"
    reference = "exact"
    provides = frozenset({"u", "v", "stress", "energy"})
    params = {"mach": Param(0.01, "each bar's speed / wave speed c", low=1e-3, high=0.5)}
    study = StudyGrid(specs=("two_bars",), nx=(20, 40, 80), T=None, small="two_bars",
                      small_nx=(20,), small_T=2.5, in_default_study=False)
    dim = 1  # two bars joined end to end

    def validate(self) -> None:
        #: bar A's scene: its bar, data and exact solution are this scene's
        self.bar = make_case(f"fast_impact[mach={float(self.mach)!r}]")
        self.T, self.nx, self.dt, self.stride = self.bar.T, self.bar.nx, self.bar.dt, 1
        self.provides = self.bar.provides

    @property
    def size(self) -> float:
        return float(self.bar.L)

    def exact(self, T: float):
        return self.bar.exact(T)

    @property
    def exact_energy(self) -> float | None:
        e = self.bar.exact_energy
        return None if e is None else 2.0 * e

    def cannot_run(self, scheme) -> str | None:
        if scheme.traits().contact == Contact.NITSCHE:
            return ("Nitsche's method between two bodies (the mean of their normal "
                    "stresses) is not built")
        return None

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        bar = self.bar
        a = BarProblem(discretise(bar, mesh_nodes(float(bar.L), int(nx), grading), mass_kind),
                       mass_kind)
        n = a.nfree
        G = sp.csr_matrix(([1.0, -1.0], ([0, 0], [0, n])), shape=(1, 2 * n))
        contact = ContactSet(dofs=None, gap0=2.0 * np.asarray(a.contact.gap0, float),
                             weights=np.ones(1), operator=G)
        U0, V0 = np.asarray(a.U0, float), np.asarray(a.V0, float)
        return SparseProblem(M=sp.csr_matrix(sp.block_diag([a.M, a.M])),
                             K=sp.csr_matrix(sp.block_diag([a.K, a.K])),
                             F=np.r_[a.F, -np.asarray(a.F, float)], U0=np.r_[U0, -U0],
                             V0=np.r_[V0, -V0], contact=contact, dim=1, hmin=a.hmin,
                             c_max=a.c_max, energy_offset=2.0 * a.energy_offset,
                             mass_kind=mass_kind, axis=a.axis, E_contact=a.E_contact,
                             h_contact=2.0 * a.h_contact, normal_stress=None)
