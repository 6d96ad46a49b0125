"""A manufactured exact solution with a moving contact zone: the unit square (plane strain)
or cube on a rigid plane, P1 or P2 (`contact_bench.exact.manufactured`).

The body (0, 1)^dim rests on the plane x_{dim-1} = 0 (initial gap 0) under its whole
bottom face, frictionless; lambda = mu = 1, rho = 1. The displacement u(x, t) is a closed
form satisfying Signorini's conditions exactly on the bottom face, with the contact zone
{x_0 < 0.2 + 0.6 t} sweeping it over T = 1; the body force, the tractions on the other
faces and the initial data are derived from it (docs/manufactured.md). The load varies in
time (`time_load`: a `contact_bench.api.sparse.TimeLoad`, quadrature of the closed form):
schemes whose stepper does not add it are not applicable.

Errors against the closed form (`quantity_errors`): the standard columns of u and v, as
every exact scene fills them (err_u_linf_l2, err_u_l2_l2, err_u_linf_h1, err_u_l2_h1,
err_v_linf_l2, err_v_l2_l2: the nodal error against the interpolant, L2 in space with the
consistent mass, H1 adding the gradient's L2 norm, L_inf(0,T) the max over the samples,
L2(0,T) the trapezoidal rule, each relative to the same norm of the interpolant), and the
scene's own err_gap (largest gap error at the contact dofs over the samples, relative to
the largest gap) and err_contact_force (the mean contact stress over the face, l2 over the
samples after t = 0, relative).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import skfem as fe
from skfem.models import laplace

from contact_bench.api import fem_nd
from contact_bench.api.fem import LUMPED_KINDS, REDISTRIBUTED_KINDS, canonical_mass
from contact_bench.api.kept import built_once
from contact_bench.api.params import Param
from contact_bench.api.plugin import BodyCase, Footprint, StudyGrid
from contact_bench.api.sparse import SparseProblem, TimeLoad
from contact_bench.exact.manufactured import LAM, MU, RHO, T_END, Manufactured


class ManufacturedContact(BodyCase):
    name = "manufactured"
    summary = "manufactured exact solution, moving contact zone (unit square/cube, P1/P2)"
    params = {
        "dim": Param(2, "space dimension", choices=(2, 3)),
        "degree": Param(1, "polynomial degree of the elements", choices=(1, 2)),
    }
    T, nx, dt, stride = T_END, 8, 0.02, 1
    time_load = True
    #: the closed form gives u and v: the standard columns (`quantity_errors`)
    reference = "exact"
    provides = frozenset({"u", "v"})
    quantities = frozenset({"gap", "contact_force"})
    study = StudyGrid(specs=("manufactured[dim=2]", "manufactured[dim=3]"), nx=(4, 8, 16), T=None,
                      small="manufactured", small_nx=(2, 3), small_T=1.0)

    @property
    def size(self) -> float:
        """The box's side."""
        return 1.0

    @property
    def solution(self) -> Manufactured:
        return Manufactured(int(self.dim))

    def cannot_run(self, scheme) -> str | None:
        if int(self.degree) == 2 and canonical_mass(scheme.mass_kind()) in LUMPED_KINDS:
            return ("a lumped mass on P2 elements has negative row sums at the vertices: "
                    "use manufactured[degree=1] or the scheme's mass=consistent")
        return super().cannot_run(scheme)

    def footprint(self, nx: int) -> Footprint:
        """The tensor mesh: (nx + 1)^d vertices; P2 adds a node on each edge (in 2D 3 nx^2
        + 2 nx of them, in 3D those of the cubes' axes, face and inner diagonals)."""
        n, d = int(nx), int(self.dim)
        nodes = (n + 1) ** d
        if int(self.degree) == 2:
            nodes += (3 * n * n + 2 * n if d == 2
                      else 3 * n * (n + 1) ** 2 + 3 * n * n * (n + 1) + n**3)
        return Footprint(d * nodes, d, int(self.degree))

    @built_once
    def mesh(self, nx: int) -> fe.Mesh:
        """nx elements (squares cut in 2 triangles, cubes in tetrahedra) along each side."""
        x = np.linspace(0.0, 1.0, int(nx) + 1)
        return (fe.MeshTri.init_tensor(x, x) if int(self.dim) == 2
                else fe.MeshTet.init_tensor(x, x, x))

    @built_once
    def body(self, nx: int) -> fem_nd.Elasticity:
        nu = LAM / (2 * (LAM + MU))
        E = MU * (3 * LAM + 2 * MU) / (LAM + MU)
        return fem_nd.assemble(self.mesh(nx), E, nu, RHO, degree=int(self.degree))

    def load(self, body: fem_nd.Elasticity) -> tuple[TimeLoad, np.ndarray, np.ndarray]:
        """The body force and the tractions as a `TimeLoad`; and the bottom face's
        quadrature points and weights (the exact mean contact stress)."""
        ex, dim, mesh = self.solution, body.dim, body.mesh
        elem = body.scalar.elem
        order = 2 * int(self.degree) + 2
        parts = [(fe.Basis(mesh, elem, intorder=order), 0)]
        for r, (axis, side) in enumerate(ex.faces, start=1):
            facets = body.boundary_facets(
                lambda x, a=axis, s=side: np.abs(x[a] - s) < 1e-12)
            parts.append((fe.FacetBasis(mesh, elem, facets=facets, intorder=order), r))
        rows, cols, vals, pts, codes = [], [], [], [], []
        m = 0
        for basis, region in parts:
            B, X = quadrature_operator(basis)
            B = B.tocoo()
            for c in range(dim):  # vector dof dim s + c, point column dim j + c
                rows.append(dim * B.row + c)
                cols.append(dim * (m + B.col) + c)
                vals.append(B.data)
            Xp = np.zeros((3, X.shape[1]))
            Xp[:dim] = X
            pts.append(np.repeat(Xp, dim, axis=1))
            codes.append(np.tile(ex.codes["load"] + region * dim + np.arange(dim), X.shape[1]))
            m += X.shape[1]
        Bv = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(body.ndofs, dim * m))
        load = TimeLoad(B=Bv, points=np.ascontiguousarray(np.hstack(pts)),
                        codes=np.concatenate(codes).astype(np.int64), density=ex.density)
        bottom = body.boundary_facets(lambda x: np.abs(x[dim - 1]) < 1e-12)
        Bf, Xf = quadrature_operator(fe.FacetBasis(mesh, elem, facets=bottom, intorder=order))
        return load, Xf, np.asarray(Bf.sum(axis=0)).ravel()

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        if grading != 1.0:
            raise ValueError(f"grading = {grading!r}: the box's mesh is uniform (allowed: 1)")
        body = self.body(nx)
        dim, ex = body.dim, self.solution
        P = body.dof_coordinates
        facets = body.boundary_facets(lambda x: np.abs(x[dim - 1]) < 1e-12)
        scalar = np.unique(body.scalar.get_dofs(facets).flatten())
        kind = canonical_mass(mass_kind)
        M = fem_nd.mass_matrix(body, "redistributed" if kind in REDISTRIBUTED_KINDS else kind,
                               scalar)
        zone = fem_nd.contact_zone(body, facets, axis=dim - 1)
        load, Xf, wf = self.load(body)
        U0 = ex.u(P, 0.0).T.ravel()  # interleaved: dof dim s + c
        V0 = ex.ut(P, 0.0).T.ravel()
        return SparseProblem(
            M=M, K=body.K, F=np.zeros(body.ndofs), U0=U0, V0=V0, contact=zone.contact_set(),
            dim=dim, hmin=body.hmin, c_max=body.wave_speed, mass_kind=mass_kind,
            E_contact=LAM + 2 * MU, h_contact=fem_nd.contact_length(body, 1.0 / int(nx)),
            normal_stress=zone.normal_stress, load=load,
            extra={"mass": fem_nd.vector_mass(body.Ms, dim), "points": P,
                   "gradient": fem_nd.vector_mass(laplace.assemble(body.full_basis()), dim),
                   "face_points": Xf, "face_weights": wf})

    def quantity_errors(self, problem, traj, row) -> dict[str, float]:
        """The standard u and v columns, err_gap, err_contact_force against the closed
        form (module docstring)."""
        ex, dim = self.solution, int(self.dim)
        t = np.asarray(traj.t, float)
        if t.size < 2 or "points" not in problem.extra:
            return {}
        P = problem.extra["points"]
        Uex = ex.u(P[:, None, :], t[:, None])  # (dim, K, nodes)
        Uex = np.moveaxis(Uex, 0, -1).reshape(t.size, -1)
        Vex = np.moveaxis(ex.ut(P[:, None, :], t[:, None]), 0, -1).reshape(t.size, -1)
        M, D = problem.extra["mass"], problem.extra["gradient"]

        def per_sample(A, X):  # x A x for each sample (row) x of X, A symmetric
            return np.sum(X * (X @ A), axis=1)

        Eu, Ev = traj.U - Uex, traj.V - Vex
        eu, nu = per_sample(M, Eu), per_sample(M, Uex)
        eux, nux = per_sample(D, Eu), per_sample(D, Uex)
        ev, nv = per_sample(M, Ev), per_sample(M, Vex)
        out = {}
        for col, err2, ref2 in (("u_{}_l2", eu, nu), ("u_{}_h1", eu + eux, nu + nux),
                                ("v_{}_l2", ev, nv)):
            out["err_" + col.format("linf")] = float(np.sqrt(np.max(err2) / np.max(ref2)))
            out["err_" + col.format("l2")] = float(np.sqrt(np.trapezoid(err2, t)
                                                           / np.trapezoid(ref2, t)))
        cd = problem.contact.dofs
        face = P[:, cd // dim]
        phi = ex.gap(face[:, None, :], t[:, None])
        gap = problem.gaps(traj.U)
        out["err_gap"] = float(np.max(np.abs(gap - phi)) / np.max(np.abs(phi)))
        Xf, wf = problem.extra["face_points"], problem.extra["face_weights"]
        psi = ex.normal_stress(Xf[:, None, :], t[:, None]) @ wf / np.sum(wf)
        later = t > 0
        if np.any(psi[later]):
            out["err_contact_force"] = float(np.linalg.norm((traj.stress - psi)[later])
                                             / np.linalg.norm(psi[later]))
        return out


def quadrature_operator(basis: fe.AbstractBasis) -> tuple[sp.csr_matrix, np.ndarray]:
    """B (scalar dofs x quadrature points, CSR) with B_sj = w_j phi_s(X_j) and the points
    X (dim, m): the load of a density v sampled at X is B v (element by element)."""
    dx = np.asarray(basis.dx)  # (elements, points per element): the weights
    nel, nq = dx.shape
    X = np.asarray(basis.global_coordinates().value).reshape(-1, nel * nq)
    rows, vals = [], []
    for j in range(basis.Nbfun):
        phi = np.asarray(basis.basis[j][0].value)
        rows.append(np.repeat(basis.element_dofs[j], nq))
        vals.append((phi * dx).ravel())
    cols = np.tile(np.arange(nel * nq), basis.Nbfun)
    B = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), cols)),
                      shape=(basis.N, nel * nq))
    return B, X
