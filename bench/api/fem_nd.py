"""Linear elasticity in 2D (plane strain) and 3D with scikit-fem, as sparse matrices.

Lagrange elements on scikit-fem meshes: P1 and P2 triangles (`MeshTri1`, `MeshTri2`), P1
and P2 tetrahedra (`MeshTet1`, `MeshTet2`), Q1 quadrilaterals and hexahedra. The vector
unknown of scalar dof s, component c (0-based) is dof `dim * s + c` (scikit-fem's
`ElementVector` interleaves them), so every isotropic vector mass is the scalar mass
times the identity of the components, which is how the mass variants are built (`mass_matrix`).

Mass variants (see the project note "beyond the bar", sections 1 and 3):

=================  =================================================================
consistent         the assembled vector mass rho u.v
lumped             row sums on the diagonal (P1, Q1; P2 refused: negative masses)
kron:<kind>        Q1 tensor meshes: the 1D variant `<kind>` of `contact_bench.api.fem`
                   along x (node 0 at x = x0), Kronecker product with the consistent 1D
                   masses across (`lumped`: lumped across too, the Q1 row sums)
redistributed      Khenous, Laborde and Renard: zero rows and columns at the contact
                   nodes, their mass moved to the other entries so that the total mass,
                   first and second moments are kept (least-squares change; the rest
                   stays SPD or it is refused)
=================  =================================================================

Nothing here builds a dense n x n matrix: the redistribution solves a system of
1 + d + d (d + 1) / 2 constraints.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import skfem as fe
from skfem.helpers import ddot, sym_grad, trace

from contact_bench.api.fem import assemble as assemble_1d
from contact_bench.api.fem import mass_variant as mass_variant_1d

ND_MASS_KINDS = ("consistent", "lumped", "redistributed")
#: mesh type -> (degree -> scalar element)
_ELEMENTS: dict[type, dict[int, Callable[[], fe.Element]]] = {
    fe.MeshTri1: {1: fe.ElementTriP1, 2: fe.ElementTriP2},
    fe.MeshTri2: {1: fe.ElementTriP1, 2: fe.ElementTriP2},
    fe.MeshTet1: {1: fe.ElementTetP1, 2: fe.ElementTetP2},
    fe.MeshTet2: {1: fe.ElementTetP1, 2: fe.ElementTetP2},
    fe.MeshQuad1: {1: fe.ElementQuad1},
    fe.MeshHex1: {1: fe.ElementHex1},
}
_ROW_SUMMABLE = (fe.ElementTriP1, fe.ElementTetP1, fe.ElementQuad1, fe.ElementHex1)


def lame(E: float, nu: float) -> tuple[float, float]:
    """Lame's (lambda, mu) of Young's modulus E and Poisson's ratio nu (3D and plane
    strain)."""
    if not (E > 0 and -1.0 < nu < 0.5):
        raise ValueError(f"need E > 0 and -1 < nu < 1/2, got E = {E!r}, nu = {nu!r}")
    return E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))


@fe.BilinearForm
def _stiffness(u, v, w):
    eps_u, eps_v = sym_grad(u), sym_grad(v)
    return 2.0 * w.mu * ddot(eps_u, eps_v) + w.lam * trace(eps_u) * trace(eps_v)


@fe.BilinearForm
def _scalar_mass(u, v, w):
    return w.rho * u * v


@dataclass(frozen=True)
class Elasticity:
    """Stiffness and consistent scalar mass of a body, and the bases they came from.

    K is over the vector dofs (`dim * s + c`), Ms over the scalar dofs s.
    """

    mesh: fe.Mesh
    scalar: fe.Basis
    vector: fe.Basis
    K: sp.csr_matrix
    Ms: sp.csr_matrix
    lam: float
    mu: float
    rho: float

    @property
    def dim(self) -> int:
        return int(self.mesh.dim())

    @property
    def ndofs(self) -> int:
        return int(self.vector.N)

    @property
    def dof_coordinates(self) -> np.ndarray:
        """(dim, number of scalar dofs): where each scalar dof sits."""
        return np.asarray(self.scalar.doflocs)

    @property
    def wave_speed(self) -> float:
        """The P-wave speed sqrt((lambda + 2 mu) / rho)."""
        return float(np.sqrt((self.lam + 2 * self.mu) / self.rho))

    @property
    def hmin(self) -> float:
        """The shortest element edge."""
        p = self.mesh.p
        edges = self.mesh.edges if self.dim == 3 else self.mesh.facets
        return float(np.min(np.linalg.norm(p[:, edges[0]] - p[:, edges[1]], axis=0)))

    def dofs(self, component: int, where: Callable[[np.ndarray], np.ndarray] | None = None,
             facets: np.ndarray | None = None) -> np.ndarray:
        """Vector dofs of `component` (0-based) at the scalar dofs whose location
        satisfies `where` (all when None), or on the given facets."""
        if facets is not None:
            s = np.unique(self.scalar.get_dofs(facets).flatten())
        else:
            s = np.arange(self.scalar.N)
            if where is not None:
                s = s[np.asarray(where(self.dof_coordinates), bool)]
        return np.sort(self.dim * s + component)

    def boundary_facets(self, where: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        """Boundary facets whose every point satisfies `where` (a predicate on (dim, k)
        coordinates): the contact zone or a Dirichlet/sliding boundary."""
        return self.mesh.facets_satisfying(where, boundaries_only=True)


def element_for(mesh: fe.Mesh, degree: int) -> fe.Element:
    """The scalar Lagrange element of `degree` on this mesh type (ValueError if none)."""
    table = _ELEMENTS.get(type(mesh))
    if table is None or degree not in table:
        raise ValueError(f"no Lagrange element of degree {degree} for {type(mesh).__name__}")
    return table[degree]()


def assemble(mesh: fe.Mesh, E: float, nu: float, rho: float, degree: int = 1) -> Elasticity:
    """Plane strain (2D meshes) or 3D linear elasticity: sparse K and the scalar mass."""
    lam, mu = lame(float(E), float(nu))
    if not (rho > 0 and np.isfinite(rho)):
        raise ValueError(f"rho must be finite and > 0, got {rho!r}")
    elem = element_for(mesh, degree)
    scalar = fe.Basis(mesh, elem)
    vector = fe.Basis(mesh, fe.ElementVector(elem), quadrature=scalar.quadrature)
    K = _stiffness.assemble(vector, lam=lam, mu=mu).tocsr()
    Ms = _scalar_mass.assemble(scalar, rho=float(rho)).tocsr()
    return Elasticity(mesh, scalar, vector, K, Ms, lam, mu, float(rho))


def vector_mass(Ms: sp.spmatrix, dim: int) -> sp.csr_matrix:
    """The isotropic vector mass of a scalar mass: Ms times the identity of components."""
    return sp.kron(sp.csr_matrix(Ms), sp.identity(dim), format="csr")


def body_force(M: sp.spmatrix, dim: int, g: np.ndarray) -> np.ndarray:
    """Load of a body acceleration g (a dim vector) with the mass M: M (1 x g)."""
    n = M.shape[0] // dim
    return np.asarray(M @ np.tile(np.asarray(g, float), n))


def lumped(body: Elasticity) -> sp.csr_matrix:
    """Row sums of the scalar mass (P1/Q1 only: P2 row sums are negative at vertices)."""
    if not isinstance(body.scalar.elem, _ROW_SUMMABLE):
        raise ValueError(f"lumped mass refused for {type(body.scalar.elem).__name__}: row sums "
                         "of a P2 mass are negative at the vertices")
    return sp.diags(np.asarray(body.Ms.sum(axis=1)).ravel(), format="csr")


def tensor_mass(body: Elasticity, kind: str) -> sp.csr_matrix:
    """On a Q1 tensor mesh (first axis x, the others across): the 1D variant `kind`
    along x (its node 0 at the smallest x), Kronecker product with the consistent 1D
    masses across (lumped ones for `lumped`, so that it is the diagonal row-sum mass).
    `consistent` equals the assembled Q1 mass to round-off."""
    if not isinstance(body.scalar.elem, fe.ElementQuad1 | fe.ElementHex1):
        raise ValueError(f"kron:{kind} needs a Q1 tensor mesh, got "
                         f"{type(body.scalar.elem).__name__}")
    P = body.dof_coordinates
    axes = [np.unique(P[k]) for k in range(body.dim)]
    if np.prod([a.size for a in axes]) != P.shape[1]:
        raise ValueError("kron mass needs a tensor mesh (every node on the axes' grid)")
    idx = [np.searchsorted(a, P[k]) for k, a in enumerate(axes)]
    mats = [mass_variant_1d(assemble_1d(axes[0], body.rho, 1.0), kind).to_sparse()]
    across = "lumped" if kind == "lumped" else "consistent"
    mats += [mass_variant_1d(assemble_1d(a, 1.0, 1.0), across).to_sparse() for a in axes[1:]]
    T = mats[0]
    for A in mats[1:]:
        T = sp.kron(T, A, format="csr")
    # tensor index -> scalar dof
    tensor = idx[0]
    for k in range(1, body.dim):
        tensor = tensor * axes[k].size + idx[k]
    order = np.empty(P.shape[1], np.int64)
    order[tensor] = np.arange(P.shape[1])
    C = T.tocoo()
    return sp.csr_matrix((C.data, (order[C.row], order[C.col])), shape=T.shape)


def redistributed(body: Elasticity, contact_scalar: np.ndarray) -> sp.csr_matrix:
    """The Khenous-Laborde-Renard mass: rows and columns of the scalar dofs
    `contact_scalar` zeroed, the other nonzero entries changed least (in the 2-norm
    weighted by 1 / |entry|, so that each changes in proportion to its size) so that the
    total mass, first moments 1.M.x_k and second moments x_k.M.x_l are kept.

    The constraints are written for the symmetric unknowns (one per pair i <= j), so the
    result is symmetric and keeps every moment exactly; writing them for the unsymmetric
    entries and symmetrising afterwards would break the first moments. ValueError if
    the non-contact block is not positive definite.
    """
    Ms = sp.csr_matrix(body.Ms)
    n = Ms.shape[0]
    contact = np.zeros(n, bool)
    contact[np.asarray(contact_scalar, np.int64)] = True
    X = body.dof_coordinates
    d = body.dim
    vecs = [np.ones(n)] + [X[k] for k in range(d)]
    pairs = [(0, 0)] + [(0, k + 1) for k in range(d)] + [
        (k + 1, j + 1) for k in range(d) for j in range(k, d)]
    target = np.array([vecs[a] @ (Ms @ vecs[b]) for a, b in pairs])
    U = sp.triu(Ms, format="coo")
    keep = ~(contact[U.row] | contact[U.col]) & (U.data != 0)
    r, c, m0 = U.row[keep], U.col[keep], U.data[keep]
    diag = r == c
    A = np.empty((len(pairs), r.size))
    for q, (a, b) in enumerate(pairs):
        va, vb = vecs[a], vecs[b]
        A[q] = np.where(diag, va[r] * vb[r], va[r] * vb[c] + va[c] * vb[r])
    residual = target - A @ m0
    w = np.abs(m0)  # each entry changes in proportion to its size
    delta = w * (A.T @ np.linalg.solve((A * w) @ A.T, residual))
    m = m0 + delta
    rows = np.concatenate([r, c[~diag]])
    cols = np.concatenate([c, r[~diag]])
    vals = np.concatenate([m, m[~diag]])
    out = sp.csr_matrix((vals, (rows, cols)), shape=(n, n))
    free = np.flatnonzero(~contact)
    if not is_spd(out[free][:, free]):
        raise ValueError("redistributed mass: the non-contact block is not positive definite")
    return out


def is_spd(A: sp.spmatrix) -> bool:
    """Whether a sparse symmetric matrix is positive definite: SuperLU with diagonal
    pivots (a symmetric elimination) has only positive pivots."""
    from scipy.sparse.linalg import splu

    try:
        lu = splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                  options={"SymmetricMode": True})
    except RuntimeError:  # exactly singular
        return False
    return bool(np.all(lu.perm_r == lu.perm_c) and np.all(lu.U.diagonal() > 0))


def mass_matrix(body: Elasticity, kind: str, contact_scalar: np.ndarray | None = None
                ) -> sp.csr_matrix:
    """The vector mass of the given kind (module docstring)."""
    if kind == "consistent":
        Ms = body.Ms
    elif kind == "lumped":
        Ms = lumped(body)
    elif kind == "redistributed":
        if contact_scalar is None:
            raise ValueError("redistributed mass needs the contact dofs")
        Ms = redistributed(body, contact_scalar)
    elif kind.startswith("kron:"):
        Ms = tensor_mass(body, kind[5:])
    else:
        raise ValueError(f"mass must be one of {', '.join(ND_MASS_KINDS)} or kron:<1D kind>; "
                         f"got {kind!r}")
    return vector_mass(Ms, body.dim)


__all__ = ["Elasticity", "assemble", "body_force", "element_for", "lame", "lumped",
           "mass_matrix", "redistributed", "tensor_mass", "vector_mass"]
