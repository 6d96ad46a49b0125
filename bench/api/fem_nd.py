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
                   nodes, their mass moved to the entries within two element
                   neighbourhoods of the contact zone so that the total mass, first and
                   second moments are kept (least-squares change; the rest of the mass
                   is the consistent one and stays SPD, or it is refused)
lumped_massless    the lumped mass with each contact node's mass moved to its
                   neighbours off the contact zone (`lumped_massless`; P1, Q1): diagonal,
                   massless contact nodes, total mass kept
=================  =================================================================

Boundaries (`constrain`): Dirichlet (chosen components prescribed on boundary facets)
and sliding (the normal component zero on facets in axis-aligned planes) are eliminated
with `skfem.condense`; the result keeps the energy of the whole body through its offset.
The contact zone (`contact_zone`): the weights, consistent face mass and normal stress
at the zone's dofs, the stress as the L2 projection onto the zone's trace space.

Nothing here builds a dense n x n matrix: the redistribution solves a system of
1 + d + d (d + 1) / 2 constraints.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import skfem as fe
from skfem.helpers import ddot, sym_grad, trace

from contact_bench.api.fem import LUMPED_KINDS, LUMPED_MASSLESS
from contact_bench.api.fem import assemble as assemble_1d
from contact_bench.api.fem import mass_variant as mass_variant_1d
from contact_bench.api.sparse import ContactSet
from contact_bench.core.ordering import is_spd

ND_MASS_KINDS = ("consistent", "lumped", "redistributed", LUMPED_MASSLESS)
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
    """Stiffness and consistent scalar mass of a body, and the dof maps they came from.

    K is over the vector dofs (`dim * s + c`), Ms over the scalar dofs s. `scalar` and
    `vector` are bases over the body's first element only: they carry the mesh's dofs,
    dof locations and element, not its integrals (a basis over every element holds each
    shape function at every quadrature point, the bulk of an assembly's memory, and a
    body is kept for the whole run). A form integrated over the body takes
    `full_basis()`, built for that call.
    """

    mesh: fe.Mesh
    scalar: fe.Basis
    vector: fe.Basis
    K: sp.csr_matrix
    Ms: sp.csr_matrix
    lam: float
    mu: float
    rho: float

    def full_basis(self, vector: bool = False) -> fe.CellBasis:
        """The scalar (or vector) basis over every element, with the assembly's
        quadrature and dofs: for integrating a form over the body; the caller owns it
        (it is not kept, see the class doc)."""
        dofs = self.vector if vector else self.scalar
        return fe.CellBasis(self.mesh, dofs.elem, quadrature=self.scalar.quadrature,
                            dofs=dofs.dofs)

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


def degree_of(body: Elasticity) -> int:
    """The polynomial degree of the body's scalar Lagrange element."""
    for table in _ELEMENTS.values():
        for degree, elem in table.items():
            if type(body.scalar.elem) is elem:
                return int(degree)
    raise ValueError(f"unknown element {type(body.scalar.elem).__name__}")


def contact_length(body: Elasticity, h: float) -> float:
    """The length of penalty and Nitsche parameters (`SparseProblem.h_contact`, gam =
    gamma0 E / length) for elements of size h normal to the zone: h / p^2, p the degree.
    The discrete trace inverse inequality (the normal stress on a facet bounded by the
    strain energy of its element) scales with p^2 / h, so that with this length the
    smallest coercive gamma0 of the symmetric Nitsche stiffness is alike for P1 and P2
    (docs/impact-scenes.md: benchmarks/nitsche_coercivity.py)."""
    return float(h) / degree_of(body) ** 2


def element_for(mesh: fe.Mesh, degree: int) -> fe.Element:
    """The scalar Lagrange element of `degree` on this mesh type (ValueError if none)."""
    table = _ELEMENTS.get(type(mesh))
    if table is None or degree not in table:
        raise ValueError(f"no Lagrange element of degree {degree} for {type(mesh).__name__}")
    return table[degree]()


#: the assembly's temporaries (a chunk's vector basis at every quadrature point, its COO
#: triplets and their CSR copy) are bounded by about this many bytes: the mesh is
#: assembled `chunk_elements` elements at a time, the chunks' matrices summed
ASSEMBLY_CHUNK_BYTES = 2**27


def chunk_elements(basis: fe.Basis) -> int:
    """How many elements of a vector `basis`'s mesh one chunk of the assembly takes: its
    estimated temporaries per element (each shape function's value and gradient at each
    quadrature point, 8 bytes each; the local matrix's COO triplets and their CSR copy,
    about 50 bytes an entry) into `ASSEMBLY_CHUNK_BYTES`, at least one."""
    d, nf, nq = basis.mesh.dim(), basis.Nbfun, basis.quadrature[1].size
    per_element = 8 * nf * nq * (d + d * d) + 50 * nf * nf
    return max(1, ASSEMBLY_CHUNK_BYTES // per_element)


def assemble(mesh: fe.Mesh, E: float, nu: float, rho: float, degree: int = 1) -> Elasticity:
    """Plane strain (2D meshes) or 3D linear elasticity: sparse K and the scalar mass.

    Assembled `chunk_elements` elements at a time (the whole mesh when it fits: one
    chunk), so that the temporaries stay near `ASSEMBLY_CHUNK_BYTES` at any size; the
    chunks' CSR matrices are summed pairwise (a chunk with its neighbour, then pairs of
    those, ...: each entry passes through about log2(chunks) sums, and at most one
    partial sum of each size waits). The same matrices as one whole-mesh assembly up to
    the order of the sums, except that an entry cancelling exactly across chunks is not
    stored (scipy's sum drops it). The `Elasticity` keeps one-element bases (its doc)."""
    lam, mu = lame(float(E), float(nu))
    if not (rho > 0 and np.isfinite(rho)):
        raise ValueError(f"rho must be finite and > 0, got {rho!r}")
    elem = element_for(mesh, degree)
    scalar = fe.CellBasis(mesh, elem, elements=np.array([0]))
    vector = fe.CellBasis(mesh, fe.ElementVector(elem), elements=np.array([0]),
                          quadrature=scalar.quadrature)
    step = chunk_elements(vector)
    sums: list[tuple[int, sp.csr_matrix, sp.csr_matrix]] = []  # (chunks summed, K, Ms)
    for start in range(0, mesh.nelements, step):
        part = np.arange(start, min(start + step, mesh.nelements))
        whole = part.size == mesh.nelements
        k = _stiffness.assemble(fe.CellBasis(
            mesh, vector.elem, elements=None if whole else part,
            quadrature=scalar.quadrature, dofs=vector.dofs, disable_doflocs=True),
            lam=lam, mu=mu)
        m = _scalar_mass.assemble(fe.CellBasis(
            mesh, elem, elements=None if whole else part, quadrature=scalar.quadrature,
            dofs=scalar.dofs, disable_doflocs=True), rho=float(rho))
        count, k, m = 1, k.tocsr(), m.tocsr()
        while sums and sums[-1][0] == count:  # pairwise: equal-sized partial sums merge
            _, k0, m0 = sums.pop()
            count, k, m = 2 * count, k0 + k, m0 + m
        sums.append((count, k, m))
        del k, m
    _, K, Ms = sums.pop()
    while sums:
        _, k0, m0 = sums.pop()
        K, Ms = k0 + K, m0 + Ms
    return Elasticity(mesh, scalar, vector, sp.csr_matrix(K), sp.csr_matrix(Ms), lam, mu,
                      float(rho))


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


def lumped_massless(body: Elasticity, contact_scalar: np.ndarray) -> sp.csr_matrix:
    """The row-sum lumped mass with massless contact dofs (Doyen, Ern, Piperno's
    semi-explicit scheme): each contact dof's lumped mass is moved to its neighbours
    that are not contact dofs (the dofs it shares an element with), in proportion to
    their consistent-mass coupling M_ij > 0, and its row is zeroed. Diagonal; the total
    mass is kept exactly; the first moments along the contact face are kept where the
    neighbours sit symmetrically about the dof (a structured face), the moment normal to
    the face is not (the mass moves one element inwards). P1/Q1 only (`lumped`);
    ValueError when a contact dof has no non-contact neighbour."""
    m = np.asarray(lumped(body).diagonal(), float).copy()
    Ms = sp.csr_matrix(body.Ms)
    contact = np.zeros(m.size, bool)
    contact[np.asarray(contact_scalar, np.int64)] = True
    gained = np.zeros(m.size)
    for i in np.flatnonzero(contact):
        cols = Ms.indices[Ms.indptr[i]:Ms.indptr[i + 1]]
        vals = Ms.data[Ms.indptr[i]:Ms.indptr[i + 1]]
        keep = ~contact[cols] & (vals > 0.0)
        if not np.any(keep):
            raise ValueError(f"contact dof {i} has no neighbour off the contact zone to "
                             "take its mass")
        gained[cols[keep]] += m[i] * vals[keep] / vals[keep].sum()
    m = np.where(contact, 0.0, m + gained)
    return sp.diags(m, format="csr")


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
    across = "lumped" if kind in LUMPED_KINDS else "consistent"
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


#: the redistribution changes the mass entries between dofs within this many element
#: neighbourhoods of the contact zone: one neighbourhood is not enough on a flat face,
#: where its nodes all lie at one height and the second moments cannot be kept
REDISTRIBUTION_LAYERS = 2
#: largest condition number of the constraints' normal matrix on the changed entries
#: before one more neighbourhood is taken
REDISTRIBUTION_CONDITION = 1e12


def redistributed(body: Elasticity, contact_scalar: np.ndarray,
                  layers: int = REDISTRIBUTION_LAYERS) -> sp.csr_matrix:
    """The Khenous-Laborde-Renard mass: rows and columns of the scalar dofs
    `contact_scalar` zeroed and their mass moved onto the entries near the contact zone,
    so that the total mass, first moments 1.M.x_k and second moments x_k.M.x_l are kept.

    The changed entries are those between dofs within `layers` element neighbourhoods of
    the contact dofs (neighbours: dofs that share an element, nonzeros of M); every other
    entry is the consistent mass's, as the redistribution is meant to change the inertia
    at the contact boundary only. Among them, the change is the least in the 2-norm
    weighted by 1 / |entry| (each entry changes in proportion to its size). A change
    spread over the whole body instead alters the inertia by O(h) everywhere and limits
    the space-time order to one (docs/manufactured.md). When the constraints cannot be
    met on those entries (rank-deficient) or the rest of the mass is not positive
    definite, one more neighbourhood is taken, up to the whole body.

    On a coarse mesh whose contact dofs carry much of the mass, even the least change
    of every entry is indefinite: it moves that mass onto a few interior dofs with
    negative couplings. The moments alone do not forbid a positive definite mass there:
    a positive diagonal mass on the non-contact dofs often keeps them too (a linear
    programme, `_positive_diagonal`). The mass is then the point of the segment from
    the least change to that diagonal closest to the least change whose non-contact
    block is as far from singular as the consistent mass's (smallest eigenvalue at
    least the consistent block's): on the segment every moment is kept, as the
    constraints are linear.

    The constraints are written for the symmetric unknowns (one per pair i <= j), so the
    result is symmetric and keeps every moment exactly; writing them for the unsymmetric
    entries and symmetrising afterwards would break the first moments. ValueError when
    no positive diagonal keeps the moments either (too few non-contact dofs, the ball
    at nx 2: docs/schemes.md "The redistributed mass on coarse meshes").
    """
    if layers < 1:
        raise ValueError(f"redistribution layers must be at least 1; got {layers!r}")
    moments = _MomentSystem(body, contact_scalar)
    contact, free = moments.contact, np.flatnonzero(~moments.contact)
    graph = sp.csr_matrix((body.Ms != 0).astype(np.int32))

    def grown(sel: np.ndarray) -> np.ndarray:
        """sel and every dof sharing an element with it (32-bit neighbour counts: 8-bit
        ones wrap past 127 neighbours, as a P2 tetrahedral mesh can have)."""
        return sel | (graph @ sel.astype(np.int32) > 0)

    near = contact.copy()
    for _ in range(layers):
        near = grown(near)
    while True:
        whole = bool(near.all())
        out = moments.least_change(near, check_condition=not whole)
        if out is not None and is_spd(out[free][:, free]):
            return out
        if whole:
            break
        near = grown(near)
    diagonal = moments.positive_diagonal()
    if out is None or diagonal is None:
        raise ValueError(
            f"redistributed mass: no positive definite mass on the {free.size} non-contact "
            f"scalar dofs (of {contact.size}) keeps the moments by this construction: the "
            f"least change is indefinite and no positive diagonal keeps them; refine the mesh")
    floor = _smallest_eigenvalue(sp.csr_matrix(body.Ms)[free][:, free])

    def margin(t: float) -> float:
        return _smallest_eigenvalue(((1.0 - t) * out + t * diagonal)[free][:, free]) - floor

    if margin(1.0) < 0.0:  # the diagonal itself is the farthest from singular we have
        return diagonal
    lo, hi = 0.0, 1.0  # margin(lo) < 0 <= margin(hi); concave in t: one crossing
    while hi - lo > 1e-6:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if margin(mid) >= 0.0 else (mid, hi)
    return sp.csr_matrix((1.0 - hi) * out + hi * diagonal)


def _smallest_eigenvalue(B: sp.spmatrix) -> float:
    """The smallest eigenvalue of the symmetric B (dense below 600 rows, else Lanczos)."""
    from scipy.sparse.linalg import eigsh

    if B.shape[0] < 600:
        return float(np.linalg.eigvalsh(B.toarray())[0])
    return float(eigsh(B, k=1, which="SA")[0][0])


class _MomentSystem:
    """The constraints of the redistribution (`redistributed`): the consistent mass's
    upper-triangle entries off the contact dofs (rows r, columns c, values m0) and the
    moments (total mass, first and second) they must carry, `A @ m = target`."""

    def __init__(self, body: Elasticity, contact_scalar: np.ndarray) -> None:
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
        self.n, self.contact, self.target = n, contact, target
        self.r, self.c, self.m0, self.diag, self.A = r, c, m0, diag, A
        self.residual = target - A @ m0

    def least_change(self, near: np.ndarray, check_condition: bool = True
                     ) -> sp.csr_matrix | None:
        """The symmetric mass with the moments kept and the least change (2-norm weighted
        by 1 / |entry|) of the entries between dofs of `near`; None when
        `check_condition` and the constraints' normal matrix is near singular there, or
        it is singular."""
        r, c, m0, diag, A = self.r, self.c, self.m0, self.diag, self.A
        w = np.abs(m0) * (near[r] & near[c])  # the entries allowed to change
        N = (A * w) @ A.T
        if check_condition and np.linalg.cond(N) >= REDISTRIBUTION_CONDITION:
            return None
        try:
            m = m0 + w * (A.T @ np.linalg.solve(N, self.residual))
        except np.linalg.LinAlgError:  # too few non-contact dofs to hold the moments
            return None
        rows = np.concatenate([r, c[~diag]])
        cols = np.concatenate([c, r[~diag]])
        vals = np.concatenate([m, m[~diag]])
        return sp.csr_matrix((vals, (rows, cols)), shape=(self.n, self.n))

    def positive_diagonal(self) -> sp.csr_matrix | None:
        """A diagonal mass on the non-contact dofs keeping the moments, with the largest
        smallest weight (a linear programme: maximise t with every weight >= t times the
        mean weight); None when no such mass has every weight positive."""
        from scipy.optimize import linprog

        free = np.flatnonzero(~self.contact)
        nf, q = free.size, self.target.size
        at = np.zeros((q, self.n))
        at[:, self.r[self.diag]] = self.A[:, self.diag]  # a diagonal entry's coefficients
        mean = self.target[0] / nf
        lp = linprog(np.r_[np.zeros(nf), -1.0],
                     A_ub=sp.hstack([-sp.eye(nf), sp.csr_matrix(np.full((nf, 1), mean))]),
                     b_ub=np.zeros(nf),
                     A_eq=sp.hstack([sp.csr_matrix(at[:, free]), sp.csr_matrix((q, 1))]),
                     b_eq=self.target,
                     bounds=[(0, None)] * nf + [(None, 1.0)])
        if lp.status != 0 or lp.x[-1] <= 1e-6:
            return None
        d = np.zeros(self.n)
        d[free] = lp.x[:nf]
        return sp.csr_matrix(sp.diags(d))


def redistribution_evidence(body: Elasticity, contact_scalar: np.ndarray) -> dict[str, float]:
    """Why the least-change redistribution is or is not positive definite on a body: the
    contact dofs' share of the dofs and of the mass (row sums), the smallest eigenvalue of
    the non-contact block of the least change with every entry free and of the
    consistent mass's non-contact block, and the smallest weight over the mean weight
    of the positive diagonal mass keeping the same moments (NaN: none has every weight
    positive)."""
    moments = _MomentSystem(body, contact_scalar)
    contact = moments.contact
    free = np.flatnonzero(~contact)
    Ms = sp.csr_matrix(body.Ms)
    whole = moments.least_change(np.ones(moments.n, bool), check_condition=False)
    diagonal = moments.positive_diagonal()
    rowsum = np.asarray(Ms.sum(axis=1)).ravel()
    return {"dofs": float(moments.n), "contact_dofs": float(contact.sum()),
            "contact_mass_share": float(rowsum[contact].sum() / rowsum.sum()),
            "lambda_min": (float("nan") if whole is None
                           else _smallest_eigenvalue(whole[free][:, free])),
            "lambda_min_consistent": _smallest_eigenvalue(Ms[free][:, free]),
            "diagonal_margin": (float("nan") if diagonal is None
                                else float(diagonal.diagonal()[free].min()
                                           / (moments.target[0] / free.size)))}


def mass_matrix(body: Elasticity, kind: str, contact_scalar: np.ndarray | None = None
                ) -> sp.csr_matrix:
    """The vector mass of the given kind (module docstring)."""
    if kind == "consistent":
        Ms = body.Ms
    elif kind == "lumped":
        Ms = lumped(body)
    elif kind in ("redistributed", LUMPED_MASSLESS):
        if contact_scalar is None:
            raise ValueError(f"{kind} mass needs the contact dofs")
        Ms = (redistributed(body, contact_scalar) if kind == "redistributed"
              else lumped_massless(body, contact_scalar))
    elif kind.startswith("kron:"):
        Ms = tensor_mass(body, kind[5:])
    else:
        raise ValueError(f"mass must be one of {', '.join(ND_MASS_KINDS)} or kron:<1D kind>; "
                         f"got {kind!r}")
    return vector_mass(Ms, body.dim)


#: boundary facets: a predicate on (dim, k) points (every point of a facet satisfies it)
#: or the facet indices
Facets = Callable[[np.ndarray], np.ndarray] | np.ndarray


def facets_of(body: Elasticity, where: Facets) -> np.ndarray:
    """Facet indices of `where` (a predicate: the boundary facets satisfying it)."""
    if callable(where):
        return body.boundary_facets(where)
    return np.asarray(where, np.int64)


@dataclass(frozen=True)
class Dirichlet:
    """Prescribed displacement components on boundary facets: `components` (0-based; None:
    all) take `values` (one per component, or one for all; zero by default)."""

    where: Facets
    components: Sequence[int] | None = None
    values: float | Sequence[float] = 0.0


@dataclass(frozen=True)
class Reduced:
    """A body's system on its free dofs: M, K, F restricted (F less the stiffness
    coupling to the prescribed values), `free` (free index -> dof), `lifted` (every dof:
    the prescribed values, zero at the free ones) and the energy offset of the
    eliminated dofs (1/2 Ud.K_dd.Ud - F_d.Ud: with it, the reduced energy of a state is
    that of the whole body at `expand` of it, the prescribed dofs at rest)."""

    M: sp.csr_matrix
    K: sp.csr_matrix
    F: np.ndarray
    free: np.ndarray
    lifted: np.ndarray
    energy_offset: float

    @property
    def index(self) -> np.ndarray:
        """dof -> free index (-1 at the eliminated dofs)."""
        out = np.full(self.lifted.size, -1, np.int64)
        out[self.free] = np.arange(self.free.size)
        return out

    def expand(self, U: np.ndarray) -> np.ndarray:
        """The whole body's vector of a free one (the prescribed values elsewhere)."""
        out = self.lifted.copy()
        out[self.free] = U
        return out


def sliding_dofs(body: Elasticity, where: Facets) -> np.ndarray:
    """The normal-component dofs of boundary facets each lying in an axis-aligned plane
    (its outward normal +-e_c at every quadrature point, so curved facets are refused
    too); ValueError naming a facet that lies in no such plane."""
    facets = facets_of(body, where)
    if facets.size == 0:
        return np.zeros(0, np.int64)
    normals = np.asarray(fe.FacetBasis(body.mesh, body.scalar.elem, facets=facets).normals)
    aligned = np.all(np.abs(normals) >= 1.0 - 1e-10, axis=2)  # (dim, facets)
    bad = np.flatnonzero(aligned.sum(axis=0) != 1)
    if bad.size:
        n = np.round(normals[:, bad[0], 0], 6).tolist()
        raise ValueError(f"sliding facet {int(facets[bad[0]])} (normal {n}) lies in no "
                         "axis-aligned plane; allowed: facets normal to an axis")
    normal = np.argmax(aligned, axis=0)
    dofs = [body.vector.get_dofs(facets[normal == c]).all(f"u^{c + 1}")
            for c in range(body.dim) if np.any(normal == c)]
    return np.unique(np.concatenate(dofs)).astype(np.int64)


def constrain(body: Elasticity, M: sp.spmatrix, F: np.ndarray,
              dirichlet: Sequence[Dirichlet] = (), sliding: Sequence[Facets] = ()) -> Reduced:
    """Eliminate Dirichlet and sliding dofs (`skfem.condense`) from the body's K, the mass
    M and the load F: the system on the free dofs (`Reduced`). A dof given two different
    values is refused (ValueError)."""
    n = body.ndofs
    value = np.full(n, np.nan)

    def put(dofs: np.ndarray, v: float) -> None:
        clash = dofs[~np.isnan(value[dofs]) & (value[dofs] != v)]
        if clash.size:
            raise ValueError(f"dof {int(clash[0])} is given two values: "
                             f"{float(value[clash[0]])!r} and {v!r}")
        value[dofs] = v

    for where in sliding:
        put(sliding_dofs(body, where), 0.0)
    for bc in dirichlet:
        facets = facets_of(body, bc.where)
        comps = range(body.dim) if bc.components is None else list(bc.components)
        vals = np.broadcast_to(np.asarray(bc.values, float), (len(comps),))
        for c, v in zip(comps, vals, strict=True):
            if not 0 <= c < body.dim:
                raise ValueError(f"component {c!r} outside 0..{body.dim - 1}")
            put(body.vector.get_dofs(facets).all(f"u^{c + 1}"), float(v))
    D = np.flatnonzero(~np.isnan(value))
    lifted = np.where(np.isnan(value), 0.0, value)
    K = sp.csr_matrix(body.K)
    F = np.asarray(F, float)
    Kf, Ff, _, free = fe.condense(K, F, x=lifted, D=D)
    Mf = fe.condense(sp.csr_matrix(M), D=D, expand=False)
    Ud = lifted[D]
    offset = float(0.5 * Ud @ (K[D][:, D] @ Ud) - F[D] @ Ud)
    return Reduced(M=sp.csr_matrix(Mf), K=sp.csr_matrix(Kf), F=np.asarray(Ff), free=free,
                   lifted=lifted, energy_offset=offset)


@dataclass(frozen=True)
class ContactZone:
    """A contact zone on boundary facets against the plane x_axis = `plane` (the body on
    the side x_axis >= plane: the obstacle's inward normal is +e_axis).

    `scalar`: the zone's scalar dofs; `dofs`: their vector dofs of component `axis`;
    `gap0`: their distance to the plane; `weights`: the integrals of their trace shape
    functions over the zone (row sums of `face_mass`, the zone's consistent scalar mass);
    `normal_stress` (n_c x every vector dof): sigma_nn at each zone dof as the L2
    projection onto the zone's trace space, M_f^-1 G with G_ij = int sigma_nn(phi_j) psi_i
    (compression negative), exact for uniform strains.
    """

    scalar: np.ndarray
    dofs: np.ndarray
    gap0: np.ndarray
    weights: np.ndarray
    face_mass: sp.csr_matrix
    normal_stress: sp.csr_matrix

    #: the body's dimension and the zone's normal axis (obstacle normal +e_axis)
    dim: int = 0
    axis: int = 0

    @property
    def tangent_directions(self) -> np.ndarray:
        """The zone's tangents (dim - 1 x dim): the unit axes other than `axis`, in
        order (e_x in 2D; e_x, e_y in 3D for axis z)."""
        return np.delete(np.eye(self.dim), self.axis, axis=0)

    def contact_set(self, free: np.ndarray | None = None, mu: float = 0.0) -> ContactSet:
        """The `ContactSet` over the free dofs `free` (free index -> dof; None: all);
        mu > 0: Coulomb friction of coefficient mu at every point, its tangent rows along
        `tangent_directions` (`tangent_rows`; every dof free). mu = 0 is the frictionless
        set itself (no tangent rows)."""
        dofs = self.dofs if free is None else _free_index(free, self.dofs)
        if not float(mu) > 0.0:
            return ContactSet(dofs=dofs, gap0=self.gap0, weights=self.weights,
                              face_mass=self.face_mass)
        if free is not None:
            raise ValueError("a frictional contact set is built on every dof (free: None)")
        n = self.normal_stress.shape[1]
        return ContactSet(dofs=dofs, gap0=self.gap0, weights=self.weights,
                          face_mass=self.face_mass,
                          tangents=tangent_rows(self.scalar, self.tangent_directions, n),
                          friction=np.full(self.scalar.size, float(mu)))

    def stress(self, free: np.ndarray | None = None) -> sp.csr_matrix:
        """The normal stress as a map of the free dofs' U (the others held at zero)."""
        return self.normal_stress if free is None else sp.csr_matrix(
            self.normal_stress[:, free])


def _free_index(free: np.ndarray, dofs: np.ndarray) -> np.ndarray:
    index = np.searchsorted(free, dofs)
    if np.any(index >= free.size) or np.any(free[np.minimum(index, free.size - 1)] != dofs):
        raise ValueError("a contact dof is eliminated (Dirichlet or sliding)")
    return index.astype(np.int64)


def contact_zone(body: Elasticity, where: Facets, axis: int, plane: float = 0.0,
                 axisymmetric: bool = False) -> ContactZone:
    """The contact zone of the boundary facets `where` against the plane x_axis = plane
    (`ContactZone`). `axisymmetric`: the body is a meridian section (x_0 the radius):
    every integral weighted by 2 pi r and the hoop strain u_0 / r in the trace."""

    if not 0 <= axis < body.dim:
        raise ValueError(f"axis {axis!r} outside 0..{body.dim - 1}")
    facets = facets_of(body, where)
    if facets.size == 0:
        raise ValueError("the contact zone has no boundary facet")
    lam, mu, c = body.lam, body.mu, int(axis)

    def weight(x: np.ndarray) -> np.ndarray:
        return 2 * np.pi * x[0] if axisymmetric else 1.0

    @fe.BilinearForm
    def sigma_nn(u, v, w):
        eps = sym_grad(u)
        tr = trace(eps) + (u.value[0] / w.x[0] if axisymmetric else 0.0)
        return weight(w.x) * (lam * tr + 2 * mu * eps[c, c]) * v

    fb = fe.FacetBasis(body.mesh, body.scalar.elem, facets=facets)
    fv = fe.FacetBasis(body.mesh, fe.ElementVector(body.scalar.elem), facets=facets,
                       quadrature=(fb.X, fb.W))
    scalar = np.unique(body.scalar.get_dofs(facets).flatten()).astype(np.int64)
    gap0 = body.dof_coordinates[c, scalar] - float(plane)
    if np.any(gap0 < 0):
        raise ValueError(f"the contact zone crosses the plane x_{c} = {plane!r}")
    Mf = fe.BilinearForm(lambda u, v, w: weight(w.x) * u * v).assemble(fb).tocsr()
    Mf = sp.csr_matrix(Mf[scalar][:, scalar])
    weights = np.asarray(fe.LinearForm(lambda v, w: weight(w.x) * v).assemble(fb))[scalar]
    G = sigma_nn.assemble(fv, fb).tocsr()[scalar]
    B = _projection(Mf, G, body.ndofs)
    return ContactZone(scalar=scalar, dofs=body.dim * scalar + c, gap0=gap0, weights=weights,
                       face_mass=Mf, normal_stress=B, dim=body.dim, axis=c)


def contact_shear(body: Elasticity, where: Facets, axis: int, direction: int) -> sp.csr_matrix:
    """The shear traction e_direction . sigma(u) n at the scalar dofs of the contact zone
    of `contact_zone(body, where, axis)` (same rows), n = -e_axis the body's outward
    normal there: the L2 projection onto the zone's trace space, as the zone's
    `normal_stress` (n_c x every vector dof; exact for uniform strains). Nitsche's
    friction term reads it (`SparseProblem.tangential_stress`)."""
    if not (0 <= axis < body.dim and 0 <= direction < body.dim and direction != axis):
        raise ValueError(f"axis {axis!r} and direction {direction!r}: two different "
                         f"components in 0..{body.dim - 1}")
    facets = facets_of(body, where)
    mu, a, d = body.mu, int(axis), int(direction)

    @fe.BilinearForm
    def shear(u, v, w):
        return -2.0 * mu * sym_grad(u)[d, a] * v

    fb = fe.FacetBasis(body.mesh, body.scalar.elem, facets=facets)
    fv = fe.FacetBasis(body.mesh, fe.ElementVector(body.scalar.elem), facets=facets,
                       quadrature=(fb.X, fb.W))
    scalar = np.unique(body.scalar.get_dofs(facets).flatten()).astype(np.int64)
    Mf = sp.csr_matrix(fe.BilinearForm(lambda u, v, w: u * v).assemble(fb).tocsr()[scalar][
        :, scalar])
    G = shear.assemble(fv, fb).tocsr()[scalar]
    return _projection(Mf, G, body.ndofs)


#: a zone's projection M_f^-1 G (n_c x the columns G touches, dense) is solved in blocks
#: of columns of at most this many entries (32 MB): the ball at nx 32 has 2,113 zone dofs
#: x about 12,000 columns, a million-dof ball 8,000 x 48,000 (3 GB dense)
ZONE_BLOCK_ENTRIES = 2**22


def _projection(Mf: sp.csr_matrix, G: sp.csr_matrix, n: int) -> sp.csr_matrix:
    """M_f^-1 G (n_c x n CSR), solved on the columns G touches (the zone's layer of
    elements) only, its entries below 1e-14 of the largest dropped (M_f^-1 is dense but
    decays away from the diagonal). Solved a block of columns at a time (at most
    `ZONE_BLOCK_ENTRIES` dense entries; a small zone in one block); each block's entries
    below 1e-14 of the largest so far are dropped at once (they are below the final cut
    too), the final cut applied at the end: the same entries at any block size."""
    from scipy.sparse.linalg import splu

    cols = np.unique(G.indices)
    lu = splu(sp.csc_matrix(Mf))
    block = max(1, ZONE_BLOCK_ENTRIES // Mf.shape[0])
    rows, where, vals, top = [], [], [], 1e-300
    for start in range(0, cols.size, block):
        c = cols[start:start + block]
        X = lu.solve(G[:, c].toarray())
        size = np.abs(X)
        top = max(top, float(size.max()))
        r, k = np.nonzero(size >= 1e-14 * top)
        rows.append(r.astype(np.int32))
        where.append(c[k].astype(np.int32) if n < 2**31 else c[k])
        vals.append(X[r, k])
        del X, size
    v = np.concatenate(vals)
    keep = (np.abs(v) >= 1e-14 * top) & (v != 0.0)
    out = sp.csr_matrix((v[keep], (np.concatenate(rows)[keep], np.concatenate(where)[keep])),
                        shape=(Mf.shape[0], n))
    out.sort_indices()
    return out


def tangent_rows(scalar: np.ndarray, directions: np.ndarray, n: int) -> sp.csr_matrix:
    """The tangent rows T of a frictional `ContactSet` (n_c n_t x n): row j n_t + k is
    the direction `directions[k]` (n_t x dim, in the problem's frame) on the dofs of the
    zone's scalar dof `scalar[j]` (vector dof dim s + c), point by point, the layout
    `contact_bench.kernels.contact.friction_ops` reads. One owner for every scene with
    Coulomb friction on a zone of nodes."""
    dirs = np.atleast_2d(np.asarray(directions, float))
    nt, d = dirs.shape
    scalar = np.asarray(scalar, np.int64)
    nc = scalar.size
    rows = np.repeat(np.arange(nc * nt), d)
    cols = np.repeat(d * scalar[:, None] + np.arange(d)[None, :], nt, axis=0).ravel()
    T = sp.csr_matrix((np.tile(dirs.ravel(), nc), (rows, cols)), shape=(nc * nt, int(n)))
    T.eliminate_zeros()
    return T


def tangential_stress(body: Elasticity, where: Facets, axis: int,
                      directions: np.ndarray) -> sp.csr_matrix:
    """The shear traction e_k . sigma(u) n along each direction e_k of `directions` (n_t
    x dim, in the body's frame, orthogonal to e_axis) at the scalar dofs of the contact
    zone of `contact_zone(body, where, axis)`, rows point by point as `tangent_rows`:
    sum over the components c != axis of e_k[c] `contact_shear(body, where, axis, c)`
    (the components that are zero are not added). Nitsche's friction term reads it
    (`SparseProblem.tangential_stress`)."""
    dirs = np.atleast_2d(np.asarray(directions, float))
    nt = dirs.shape[0]
    if np.any(dirs[:, int(axis)] != 0.0):
        raise ValueError(f"directions {dirs.tolist()!r}: a tangent has a component along "
                         f"the zone's normal axis {axis!r}")
    blocks = []
    for e in dirs:
        S = None
        for c in np.flatnonzero(e):
            term = float(e[c]) * contact_shear(body, where, axis, int(c))
            S = term if S is None else S + term
        blocks.append(sp.csr_matrix(S))
    nc = blocks[0].shape[0]
    order = np.arange(nc * nt).reshape(nt, nc).T.ravel()  # point by point
    return sp.csr_matrix(sp.vstack(blocks, format="csr")[order])


__all__ = ["ContactZone", "Dirichlet", "Elasticity", "Reduced", "assemble", "body_force",
           "constrain", "contact_length", "contact_shear", "contact_zone", "degree_of",
           "element_for", "facets_of", "lame", "lumped", "mass_matrix", "redistributed",
           "sliding_dofs", "tangent_rows", "tangential_stress", "tensor_mass",
           "vector_mass"]
