"""The general space-discrete problem: sparse M and K, many contact dofs, 1D to 3D.

This is the one problem form every scheme receives (`Scheme.prepare`). A 2D/3D body's is
a `SparseProblem`; the bar's is `contact_bench.api.problem.BarProblem`, the same
attributes with its tridiagonal form (`Semidiscrete`, node 0 on the obstacle) inside as
the 1D kernels' fast backend. A case says which it produces (`Case.form`).

Contact: a rigid obstacle, frictionless, as a gap operator: the gaps of the n_c contact
points are g = g0 + G U >= 0 with G a sparse n_c x n operator (row i: the obstacle's
inward normal at point i applied to the displacement there), the obstacle's force
G^T lambda with lambda >= 0, lambda . g = 0. A plane whose normal is a coordinate axis
makes each row of G pick one dof (`ContactSet.dofs`: contact dof i is `dofs[i]`, gap
`gap0[i] + U[dofs[i]]`), which the compiled kernels use; a slanted or curved obstacle,
and later two bodies, give a general G (`ContactSet.operator`) in the same contract.

Energy of a state: 1/2 V.M.V + 1/2 U.K.U - F.U + energy_offset (the offset accounts for
eliminated Dirichlet dofs, so that it equals kinetic + strain + load potential of the
whole body).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from contact_bench.core.obstacle import Sphere, sphere_gaps

#: what a case's problem is built from (`Case.form`): the bar's banded form (its
#: `BarProblem`) or a body's sparse assembly; every scheme receives the one problem form
BANDED_1D = "banded1d"
SPARSE = "sparse"
FORMS = (BANDED_1D, SPARSE)


@dataclass(frozen=True)
class ContactSet:
    """The potential contact zone: its gap operator (module docstring), the initial
    gaps, the area each contact point stands for (`weights`, summing to the zone's
    measure: the contact stress is -sum(lambda) / sum(weights)).

    `dofs` gives G as a selection (row i picks dof dofs[i] with coefficient 1: a plane
    normal to a coordinate axis); `operator` gives a general G (n_c x n CSR), and then
    `dofs` is None. `gap_operator(n)` is G either way.
    """

    dofs: np.ndarray | None  # (n_c,) int64 indices into the free dofs; None: `operator`
    gap0: np.ndarray  # (n_c,) initial gaps (the undeformed distance to the obstacle)
    weights: np.ndarray  # (n_c,) > 0
    #: the zone's consistent (scalar) mass over the contact dofs, n_c x n_c, whose row
    #: sums are the weights; None: diag(weights). Nitsche's stress-stress term uses it
    #: (with nodal weights there, coercivity would need gamma0 above 9 on Q1 faces)
    face_mass: sp.csr_matrix | None = None
    #: a general gap operator G (n_c x n, CSR), when the rows are not dof selections
    operator: sp.csr_matrix | None = None
    #: a rigid curved obstacle (`contact_bench.core.obstacle.Sphere`): the gaps are its
    #: exact nonlinear ones, `operator` and `gap0` their tangent at U = 0 (a stepper
    #: updates the tangent every step, or refuses: `SparseStepper.follows_curved`)
    obstacle: Sphere | None = None
    #: friction (`contact_bench.kernels.contact.friction_ops`): the tangent rows T
    #: (n_t n_c x n, CSR, point by point: row j n_t + k is point j's k-th unit tangent
    #: on its dofs; n_t = dim - 1), Coulomb's coefficient per point (`friction`) and
    #: Tresca's threshold per point (`tresca`, an impulse or force as the scheme's law
    #: reads it); None: frictionless
    tangents: sp.csr_matrix | None = None
    friction: np.ndarray | None = None
    tresca: np.ndarray | None = None

    @property
    def frictional(self) -> bool:
        """Whether a friction law acts: tangents given and some mu or threshold > 0 (mu
        = 0 everywhere is the frictionless contact, on its own exact path)."""
        if self.tangents is None:
            return False
        return bool(any(v is not None and np.any(np.asarray(v) > 0)
                        for v in (self.friction, self.tresca)))

    @property
    def size(self) -> int:
        return int(np.asarray(self.gap0).size)

    def gap_operator(self, n: int) -> sp.csr_matrix:
        """G, n_c x n (CSR): the general operator, or the selection of `dofs`."""
        if self.operator is not None:
            return sp.csr_matrix(self.operator)
        return sp.csr_matrix((np.ones(self.size), (np.arange(self.size), self.dofs)),
                             shape=(self.size, n))

    def selected_dofs(self, who: str) -> np.ndarray:
        """The contact dofs of a selection G, for a kernel that steps dof by dof; a
        one-line ValueError naming `who` when G is a general operator."""
        if self.dofs is None:
            raise ValueError(f"{who} needs contact dofs along coordinate normals; this "
                             "problem's gap operator is general (a slanted or curved "
                             "obstacle)")
        return np.asarray(self.dofs, np.int64)


@dataclass(frozen=True)
class TimeLoad:
    """A load that varies in time, added to the problem's constant F: F(t) = B v(t) with
    v_j(t) = density(X[0, j], X[1, j], X[2, j], t, codes[j]): a closed form evaluated at m
    points (quadrature points of the volume and of loaded faces, padded to 3
    coordinates), B (n x m, CSR) the quadrature weights times the shape functions.
    `density` is a numba cfunc float64(float64, float64, float64, float64, int64), so a
    compiled kernel calls it every step (memory: B and the points, not n x steps)."""

    B: sp.csr_matrix
    points: np.ndarray  # (3, m)
    codes: np.ndarray  # (m,) int64
    density: Any

    def at(self, t: float) -> np.ndarray:
        """B v(t) (python calls of the density: for set-up, not for stepping)."""
        f = self.density
        X = self.points
        v = np.array([f(X[0, j], X[1, j], X[2, j], float(t), int(c))
                      for j, c in enumerate(self.codes)])
        return np.asarray(self.B @ v)


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
    #: the tangential traction t . sigma(U) n at each contact point along each of its
    #: tangent rows (n_t n_c x n, CSR, `ContactSet.tangents`' layout; n the body's
    #: outward normal), for Nitsche's friction term; None: not given
    tangential_stress: sp.csr_matrix | None = None
    #: the rigid translation along the obstacle's normal, one value per free dof (1 on
    #: the normal components): the body's momentum V.M.vertical and free fall read it
    #: (impact by impact metrics, the momentum balance); None: the body has none (a
    #: clamped one)
    vertical: np.ndarray | None = None
    #: the body's mass as that translation sees it (vertical . M . 1 over the whole
    #: body), for the impact metrics; None with `vertical`
    body_mass: float | None = None
    #: a time-dependent load added to F (`TimeLoad`); None: the load is F. Kernels that
    #: cannot add it refuse the problem (`contact_bench.kernels.stepper`)
    load: TimeLoad | None = None
    #: anything else a scene wants to keep with its problem (read by that scene only)
    extra: dict[str, Any] = field(default_factory=dict)
    #: the bar's tridiagonal form of the same problem (`contact_bench.api.problem.
    #: BarProblem`), the fast backend of the 1D kernels; None for a 2D/3D body
    banded: Any = None
    #: the seconds the harness took to build this problem (the `assembly_s` column; set
    #: by `contact_bench.harness.runner.problem_for`); None: built elsewhere
    assembly_s: float | None = None

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
        c = self.contact
        if c.obstacle is not None:
            return sphere_gaps(c.obstacle, U)
        if c.dofs is not None:
            return c.gap0 + U[..., c.dofs]
        return c.gap0 + np.asarray(U) @ c.gap_operator(self.nfree).T

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
        if c.dofs is None and c.operator is None:
            raise ValueError("the contact set has neither dofs nor a gap operator")
        if c.dofs is not None and c.dofs.size and (c.dofs.min() < 0 or c.dofs.max() >= n):
            raise ValueError("contact dofs outside the free dofs")
        if c.operator is not None and c.operator.shape != (c.size, n):
            raise ValueError(f"the gap operator has shape {c.operator.shape}, expected "
                             f"{(c.size, n)}")
        if c.tangents is not None and (c.size == 0 or c.tangents.shape[0] % c.size
                                       or c.tangents.shape[1] != n):
            raise ValueError(f"the tangent operator has shape {c.tangents.shape}, expected "
                             f"(n_t {c.size}, {n})")
        ts = self.tangential_stress
        if ts is not None and (c.tangents is None or ts.shape != c.tangents.shape):
            raise ValueError(f"the tangential stress has shape {ts.shape}, expected the "
                             "tangent operator's "
                             f"{None if c.tangents is None else c.tangents.shape}")
        for name in ("friction", "tresca"):
            v = getattr(c, name)
            if v is not None and (np.shape(v) != (c.size,) or not np.all(np.asarray(v) >= 0)):
                raise ValueError(f"contact {name} must be {c.size} values >= 0")
        if np.any(self.gaps(self.U0) < 0):
            raise ValueError("the initial state penetrates the obstacle")


#: values of one block of samples in `sample_blocks` (a norm over many samples of a large
#: problem reads them block by block instead of copying them all at once)
SAMPLE_BLOCK_VALUES = 4_000_000


def sample_blocks(samples: int, width: int) -> list[slice]:
    """Consecutive slices covering `samples` samples of `width` values each, at most
    `SAMPLE_BLOCK_VALUES` values a block: an error norm over a trajectory's samples that
    indexes or subtracts them works block by block, so its temporaries stay a block's
    size (a run's memory is its samples, not a few copies of them)."""
    rows = max(1, SAMPLE_BLOCK_VALUES // max(1, int(width)))
    return [slice(a, min(samples, a + rows)) for a in range(0, int(samples), rows)]
