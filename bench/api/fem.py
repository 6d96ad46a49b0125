"""P1 finite elements for a bar: meshes, scikit-fem assembly, mass variants, as bands.

In 1D with nodes numbered in x order the P1 mass and stiffness matrices are
tridiagonal; every kernel receives them as two bands (`Tridiag`). Nothing here builds
a dense n x n matrix.

Mass variants (node 0 is the contact node; see the project note, section 3):

======================  ========================================================
consistent              M as assembled (the *standard* mass)
lumped                  row sums on the diagonal
first_element_massless  M^mod_ij = int_h^L rho phi_i phi_j: the first element carries
                        no mass (Dabaghi, Petrov, Pousin, Renard 2014; total L - h)
getfem                  M11 += M00 + M01, then row and column 0 zeroed (GetFEM's 1D
                        demo; total mass L - h/6)
mass_conserving         M11 += M00 + 2 M01, row and column 0 zeroed: total mass kept
singular                first element's local mass [[0, 0], [0, rho h / 4]]
                        (M11 = 7h/12, Renard 2010)
lumped_massless         row sums on the diagonal, node 0's (rho h / 2) moved to node
                        1: a diagonal mass with a massless contact node, total mass
                        kept (Doyen, Ern, Piperno's semi-explicit scheme; not one of
                        the other schemes' `MASS_KINDS` choices)
======================  ========================================================

Older spellings still parse (`MASS_ALIASES`): ``seed`` is ``first_element_massless`` and
``conservative`` is ``mass_conserving``.
"""

from __future__ import annotations

import gc
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from skfem import Basis, BilinearForm, ElementLineP1, MeshLine
from skfem.helpers import dot, grad

from contact_bench.core.tridiag import ROWSUM_RTOL

Coefficient = float | Callable[[np.ndarray], np.ndarray]

MASS_KINDS = ("consistent", "lumped", "first_element_massless", "getfem", "mass_conserving",
              "singular")
#: the lumped mass with a massless contact node (module docstring; semi_explicit's)
LUMPED_MASSLESS = "lumped_massless"
MASSLESS_KINDS = frozenset({"first_element_massless", "getfem", "mass_conserving", "singular",
                            LUMPED_MASSLESS})
#: the diagonal (row-sum) masses: refused on P2 elements, whose row sums are negative
LUMPED_KINDS = frozenset({"lumped", LUMPED_MASSLESS})
#: the redistributed variants (massless contact node, no singular mass)
REDISTRIBUTED_KINDS = ("first_element_massless", "getfem", "mass_conserving")
#: older names of mass kinds, accepted wherever a kind is parsed: (old, canonical)
MASS_ALIASES = (("seed", "first_element_massless"), ("conservative", "mass_conserving"))


def canonical_mass(kind: str) -> str:
    """The canonical name of a mass kind (an old spelling of `MASS_ALIASES` mapped)."""
    return dict(MASS_ALIASES).get(kind, kind)


@dataclass(frozen=True)
class Tridiag:
    """Symmetric tridiagonal matrix: `diag[i] = A[i, i]`, `off[i] = A[i, i+1] = A[i+1, i]`."""

    diag: np.ndarray
    off: np.ndarray

    @property
    def n(self) -> int:
        return self.diag.size

    def matvec(self, x: np.ndarray) -> np.ndarray:
        """A @ x, along the last axis of x (so a stack of vectors works too)."""
        y = self.diag * x
        y[..., :-1] += self.off * x[..., 1:]
        y[..., 1:] += self.off * x[..., :-1]
        return y

    def quad(self, x: np.ndarray) -> np.ndarray:
        """x^T A x along the last axis, without cancellation: the sum of
        `contact_bench.core.tridiag.tri_quad` (row sums times x_i^2, rounding-level
        row sums taken as 0, minus off-diagonal times squared differences)."""
        x = np.asarray(x, float)
        d, e = self.diag, self.off
        r = d.copy()
        a = np.abs(d)
        r[1:] += e
        r[:-1] += e
        a[1:] += np.abs(e)
        a[:-1] += np.abs(e)
        r[np.abs(r) <= ROWSUM_RTOL * a] = 0.0
        dx = np.diff(x, axis=-1)
        return np.sum(r * x * x, axis=-1) - np.sum(e * dx * dx, axis=-1)

    def head(self, m: int) -> Tridiag:
        """The leading m x m block."""
        return Tridiag(self.diag[:m].copy(), self.off[: m - 1].copy())

    def to_sparse(self) -> sp.csr_matrix:
        return sp.diags([self.off, self.diag, self.off], [-1, 0, 1], format="csr")

    @classmethod
    def from_sparse(cls, A: sp.spmatrix) -> Tridiag:
        A = sp.csr_matrix(A)
        bandwidth = np.abs(A.tocoo().row - A.tocoo().col).max(initial=0)
        if bandwidth > 1:
            raise ValueError(
                f"matrix is not tridiagonal (bandwidth {bandwidth}): nodes not in x order")
        return cls(np.asarray(A.diagonal(0), float).copy(), np.asarray(A.diagonal(1), float).copy())


def mesh_nodes(L: float, nx: int, grading: float = 1.0) -> np.ndarray:
    """Sorted node coordinates of a mesh of (0, L) with nx elements.

    grading = 1 is uniform; grading > 1 refines towards the obstacle at x = 0
    (x_i = L (i/nx)^grading), so the first element is the smallest.
    """
    if not isinstance(nx, int | np.integer) or isinstance(nx, bool) or nx < 1:
        raise ValueError(f"nx must be an integer >= 1, got {nx!r}")
    if not (np.isfinite(L) and L > 0):
        raise ValueError(f"L must be finite and > 0, got {L!r}")
    if not (np.isfinite(grading) and grading >= 1.0):
        raise ValueError(f"grading must be >= 1, got {grading!r}")
    s = np.linspace(0.0, 1.0, int(nx) + 1)
    return L * s**grading


def _coefficient_at_quadrature(basis: Basis, value: Coefficient) -> np.ndarray:
    X = basis.global_coordinates().value[0]  # (n_elements, n_quadrature)
    if callable(value):
        out = np.asarray(value(X), dtype=float)
        return np.broadcast_to(out, X.shape).copy()
    return np.full(X.shape, float(value))


@BilinearForm
def _mass_form(u, v, w):
    return w.rho * u * v


@BilinearForm
def _stiffness_form(u, v, w):
    return w.E * dot(grad(u), grad(v))


@dataclass(frozen=True)
class Assembly:
    """Consistent P1 mass and stiffness of a bar, and the first element's local mass."""

    x: np.ndarray
    M: Tridiag
    K: Tridiag
    first_element_mass: np.ndarray  # 2 x 2 local mass of element (x0, x1)

    @property
    def h(self) -> np.ndarray:
        return np.diff(self.x)


_ASSEMBLY_BLOCK = 10_000  # elements per scikit-fem assembly call (bounds memory)


def _assemble_block(x: np.ndarray, rho: Coefficient, E: Coefficient):
    basis = Basis(MeshLine(x), ElementLineP1(), intorder=4)
    rho_q = _coefficient_at_quadrature(basis, rho)
    E_q = _coefficient_at_quadrature(basis, E)
    if np.any(rho_q <= 0) or not np.all(np.isfinite(rho_q)):
        raise ValueError(f"rho must be finite and > 0, got min {rho_q.min()!r}")
    if np.any(E_q <= 0) or not np.all(np.isfinite(E_q)):
        raise ValueError(f"E must be finite and > 0, got min {E_q.min()!r}")
    M = Tridiag.from_sparse(_mass_form.assemble(basis, rho=rho_q))
    K = Tridiag.from_sparse(_stiffness_form.assemble(basis, E=E_q))
    return basis, rho_q, M, K


def assemble(x: np.ndarray, rho: Coefficient, E: Coefficient) -> Assembly:
    """Assemble the consistent mass and stiffness on sorted nodes x with scikit-fem.

    Long meshes are assembled in blocks of elements (each a MeshLine of its own
    nodes) whose bands are added where blocks share a node: the result equals one
    global assembly, and memory grows with the block, not with the mesh.
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or x.size < 2 or np.any(np.diff(x) <= 0):
        raise ValueError("mesh nodes must be a strictly increasing 1D array with at least 2 nodes")
    nel = x.size - 1
    Md, Mo, Kd, Ko = np.zeros(nel + 1), np.zeros(nel), np.zeros(nel + 1), np.zeros(nel)
    M1 = None
    for e0 in range(0, nel, _ASSEMBLY_BLOCK):
        e1 = min(nel, e0 + _ASSEMBLY_BLOCK)
        basis, rho_q, M, K = _assemble_block(x[e0 : e1 + 1], rho, E)
        Md[e0 : e1 + 1] += M.diag
        Kd[e0 : e1 + 1] += K.diag
        Mo[e0:e1] = M.off
        Ko[e0:e1] = K.off
        if M1 is None:
            only_first = np.zeros_like(rho_q)
            only_first[0] = rho_q[0]
            M1 = _mass_form.assemble(basis, rho=only_first).tocsr()[:2, :2].toarray()
    if nel > _ASSEMBLY_BLOCK:
        # scikit-fem's bases hold reference cycles: free the blocks' arrays now rather
        # than at some later collection (12 MB at 1e6 elements, live while a run steps)
        del basis, rho_q, M, K
        gc.collect()
    return Assembly(x=x, M=Tridiag(Md, Mo), K=Tridiag(Kd, Ko), first_element_mass=M1)


def mass_variant(asm: Assembly, kind: str) -> Tridiag:
    """The mass matrix of the given kind (see the module docstring) as bands."""
    kind = canonical_mass(kind)
    if kind not in MASS_KINDS and kind != LUMPED_MASSLESS:
        raise ValueError(f"mass must be one of {', '.join(MASS_KINDS)}, {LUMPED_MASSLESS}; "
                         f"got {kind!r}")
    d = asm.M.diag.copy()
    o = asm.M.off.copy()
    if kind == "consistent":
        return Tridiag(d, o)
    if kind in LUMPED_KINDS:
        d = asm.M.matvec(np.ones_like(d))
        if kind == LUMPED_MASSLESS:
            if d.size < 2:
                raise ValueError("a massless contact node needs at least one element "
                                 "besides the first")
            d[1] += d[0]
            d[0] = 0.0
        return Tridiag(d, np.zeros_like(o))
    m00, m01, m11 = (
        asm.first_element_mass[0, 0],
        asm.first_element_mass[0, 1],
        asm.first_element_mass[1, 1],
    )
    if d.size < 2:
        raise ValueError("a massless contact node needs at least one element besides the first")
    if kind == "first_element_massless":
        d[1] -= m11
    elif kind == "getfem":
        d[1] += m00 + m01
    elif kind == "mass_conserving":
        d[1] += m00 + 2.0 * m01
    elif kind == "singular":
        d[1] += -m11 + 0.75 * m11  # first element's local mass becomes [[0, 0], [0, rho h / 4]]
    d[0] = 0.0
    o[0] = 0.0
    return Tridiag(d, o)
