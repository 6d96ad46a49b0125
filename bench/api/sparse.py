"""The general space-discrete problem: sparse M and K, many contact dofs, 1D to 3D.

`Semidiscrete` (the bar's banded form, node 0 on the obstacle) stays what the 1D
kernels integrate; `SparseProblem` is the form of every other scene. A scheme declares
which forms it integrates (`Scheme.forms`), a case which one it produces (`Case.form`);
the harness matches the two, never a name.

Contact: a rigid plane, frictionless. Contact dof i (index `contact.dofs[i]` into the
free dofs) is the displacement along the obstacle's inward normal, with gap
`contact.gap0[i] + U[contact.dofs[i]] >= 0`; the obstacle's force on that dof is
lambda_i >= 0 (along the same normal), lambda_i * gap_i = 0.

Energy of a state: 1/2 V.M.V + 1/2 U.K.U - F.U + energy_offset (the offset accounts for
eliminated Dirichlet dofs, so that it equals kinetic + strain + load potential of the
whole body).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

#: the problem forms a scheme may integrate and a case may produce
BANDED_1D = "banded1d"
SPARSE = "sparse"
FORMS = (BANDED_1D, SPARSE)


@dataclass(frozen=True)
class ContactSet:
    """The potential contact zone: normal dofs, their initial gaps, the area each
    stands for (`weights`, summing to the zone's measure: the contact stress is
    -sum(lambda) / sum(weights))."""

    dofs: np.ndarray  # (n_c,) int64 indices into the free dofs
    gap0: np.ndarray  # (n_c,) initial gaps (the undeformed distance to the plane)
    weights: np.ndarray  # (n_c,) > 0
    #: the zone's consistent (scalar) mass over the contact dofs, n_c x n_c, whose row
    #: sums are the weights; None: diag(weights). Nitsche's stress-stress term uses it
    #: (with nodal weights there, coercivity would need gamma0 above 9 on Q1 faces)
    face_mass: sp.csr_matrix | None = None

    @property
    def size(self) -> int:
        return int(self.dofs.size)


@dataclass(frozen=True)
class AxisView:
    """How a 1D reference reads a sparse run: the free dofs carrying u(x) along an axis
    (in x order) and the 1D mesh x they sit on (with the clamped far node, if any, whose
    value is `u_fixed`): the error norms of 1D are taken there."""

    dofs: np.ndarray
    x: np.ndarray
    u_fixed: float | None

    @property
    def nfree(self) -> int:
        return int(self.dofs.size)


@dataclass(frozen=True)
class SparseProblem:
    """A space-discrete problem in the general form (module docstring).

    `M` is the scheme's mass variant (symmetric, positive semi-definite; zero rows are
    the massless dofs), `K` the stiffness (symmetric), both scipy CSR over the free dofs.
    `equal_groups` lists groups of free dofs that the scene's symmetry makes equal (the
    symmetry defect is their largest spread).
    """

    M: sp.csr_matrix
    K: sp.csr_matrix
    F: np.ndarray
    U0: np.ndarray
    V0: np.ndarray
    contact: ContactSet
    dim: int
    hmin: float
    c_max: float
    energy_offset: float = 0.0
    mass_kind: str = "consistent"
    axis: AxisView | None = None
    equal_groups: tuple[np.ndarray, ...] = ()
    #: the stiffness scale at the contact zone, for penalty and Nitsche parameters
    #: (kappa = gamma_p E / h): the P-wave modulus lambda + 2 mu there and the element
    #: size normal to the zone divided by the degree squared (`fem_nd.contact_length`:
    #: the trace inverse inequality scales with p^2 / h; 0: not given)
    E_contact: float = 0.0
    h_contact: float = 0.0
    #: the normal stress at each contact dof as a linear map of U (n_c x n, CSR;
    #: compression negative), for Nitsche; None: not given
    normal_stress: sp.csr_matrix | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def nfree(self) -> int:
        return int(self.M.shape[0])

    @property
    def massless(self) -> np.ndarray:
        """Boolean mask of the dofs without inertia (zero mass diagonal)."""
        return np.asarray(self.M.diagonal() == 0.0)

    @property
    def nbytes(self) -> int:
        mats = sum(A.data.nbytes + A.indices.nbytes + A.indptr.nbytes for A in (self.M, self.K))
        return int(mats + self.F.nbytes + self.U0.nbytes + self.V0.nbytes)

    def energy(self, U: np.ndarray, V: np.ndarray) -> float:
        """1/2 V.M.V + 1/2 U.K.U - F.U + energy_offset."""
        return float(0.5 * V @ (self.M @ V) + 0.5 * U @ (self.K @ U) - self.F @ U
                     + self.energy_offset)

    def gaps(self, U: np.ndarray) -> np.ndarray:
        """The contact set's gaps of a state (or of a stack of states, last axis)."""
        return self.contact.gap0 + U[..., self.contact.dofs]

    def check(self) -> None:
        """Shapes and symmetry; ValueError naming the first problem found."""
        n = self.nfree
        for name, A in (("M", self.M), ("K", self.K)):
            if A.shape != (n, n):
                raise ValueError(f"{name} has shape {A.shape}, expected {(n, n)}")
            if abs(A - A.T).max() > 1e-12 * max(abs(A).max(), 1e-300):
                raise ValueError(f"{name} is not symmetric")
        for name, v in (("F", self.F), ("U0", self.U0), ("V0", self.V0)):
            if v.shape != (n,) or not np.all(np.isfinite(v)):
                raise ValueError(f"{name} must be {n} finite values")
        c = self.contact
        if c.dofs.size and (c.dofs.min() < 0 or c.dofs.max() >= n):
            raise ValueError("contact dofs outside the free dofs")
        if np.any(self.gaps(self.U0) < 0):
            raise ValueError("the initial state penetrates the obstacle")
