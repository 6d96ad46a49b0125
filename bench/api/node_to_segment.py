"""Node-to-segment gap rows between two deformable bodies whose interfaces do not match.

Each contact node s of the slave body, at X_s, is projected on the master body's
boundary facets (segments in 2D, straight or quadratic: `Surface`), at the local
coordinate xi of one facet, and its row of the gap operator G is

    gap_s = (X_s + u_s - sum_k N_k(xi) (X_k + u_k)) . n  =  gap0_s + G_s U,

+n on the slave node's components, -N_k(xi) n on the facet's displacement nodes k (N_k
the master element's shape functions on the facet: P1 or P2), with n the master's
outward normal at the projection (closest-point projection) or a given direction (the
node projected along it). The weights N_k(xi) sum to one, so each row's coefficients sum
to zero per component: G^T lambda carries no net force and the pair's momentum is kept.

The rows are built once, in the reference configuration: the facet, xi and n are not
updated as the bodies move and slide (small sliding; docs/contact.md says why and its
limit). A projection within `SNAP` (in xi) of a facet's node is put on that node exactly,
so matching meshes give the node-to-node rows exactly (a weight of 1 on the one node).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from contact_bench.api.fem_nd import Elasticity, Facets, facets_of

#: a projection's local coordinate within this of a facet node's (0, 1 or 1/2) is put
#: on the node exactly
SNAP = 1e-10
#: a projection this far outside a facet's [0, 1] (in xi) still counts as on it
#: (a node hit at a facet's end by round-off)
REACH = 1e-9


@dataclass(frozen=True)
class Surface:
    """A body's boundary facets in 2D, as the master side of node-to-segment rows.

    `geometry` (n_f, q, 2): each facet's geometric nodes, vertex 0, vertex 1 and (q = 3,
    a quadratic edge) the midpoint node at xi = 1/2; `dofs` (n_f, k): the body's scalar
    dofs carrying the displacement on the facet, in the same order (k = 2: P1, k = 3: P2,
    the edge dof last); `inside` (n_f, 2): a point of the facet's element off the facet
    (its third vertex), which tells the outward side."""

    geometry: np.ndarray
    dofs: np.ndarray
    inside: np.ndarray

    def __post_init__(self) -> None:
        nf = self.geometry.shape[0]
        if self.geometry.ndim != 3 or self.geometry.shape[1:] not in ((2, 2), (3, 2)):
            raise ValueError(f"surface geometry of shape {self.geometry.shape}: need "
                             "(facets, 2 or 3 nodes, 2 coordinates)")
        if self.dofs.shape not in ((nf, 2), (nf, 3)) or self.inside.shape != (nf, 2):
            raise ValueError(f"surface dofs {self.dofs.shape} or inside points "
                             f"{self.inside.shape} do not match {nf} facets")


@dataclass(frozen=True)
class Projection:
    """Where each slave point lands on a `Surface`: the facet (index into the surface),
    its local coordinate `xi` in [0, 1], the displacement `weights` N_k(xi) (n_s, k),
    the projected `point` sum_k N_k(xi) X_k of the facet's geometry (n_s, 2), the row's
    unit `normal` (n_s, 2) and the reference gap `gap0` = (X_s - point) . normal. In 3D
    (`node_to_facet`) `xi` is (n_s, 3), the barycentric coordinates on a triangle, and
    the points and normals (n_s, 3)."""

    facet: np.ndarray
    xi: np.ndarray
    weights: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    gap0: np.ndarray


def master_facets(body: Elasticity, where: Facets, dim: int) -> np.ndarray:
    """The boundary facets `where` of a master surface (`fem_nd.facets_of`), checked:
    ValueError when the body is not `dim`-dimensional (node-to-segment rows are 2D,
    node-to-facet rows 3D) or when no facet is selected."""
    if body.dim != dim:
        kind = "node-to-segment" if dim == 2 else "node-to-facet"
        raise ValueError(f"{kind} rows are built in {dim}D; got a {body.dim}D body")
    facets = facets_of(body, where)
    if facets.size == 0:
        raise ValueError("the master surface has no boundary facet")
    return facets


def checked_points(points: np.ndarray, normal: np.ndarray | None, dim: int
                   ) -> tuple[np.ndarray, np.ndarray | None]:
    """The slave points as a (dim, n) float array and the projection direction made unit
    (None: closest-point projection); ValueError naming a bad shape or direction."""
    P = np.asarray(points, float)
    if P.ndim != 2 or P.shape[0] != dim:
        raise ValueError(f"points of shape {P.shape}: need ({dim}, n)")
    if normal is None:
        return P, None
    d = np.asarray(normal, float).reshape(dim)
    if not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0.0:
        raise ValueError(f"projection direction {d.tolist()!r}: need a nonzero vector")
    return P, d / np.linalg.norm(d)


def surface(body: Elasticity, where: Facets, place: Callable[[np.ndarray], np.ndarray] | None = None
            ) -> Surface:
    """The `Surface` of the body's boundary facets `where` (a predicate on points or
    facet indices, as `fem_nd.facets_of`), its coordinates mapped by `place` ((2, m) ->
    (2, m), e.g. the body mirrored or turned into its place in the scene; None: as
    meshed). The geometry is the mesh's (quadratic edges of a MeshTri2, whatever the
    displacement's degree)."""
    import skfem as fe

    mesh = body.mesh
    facets = master_facets(body, where, 2)
    geo = fe.Basis(mesh, mesh.elem())
    ends = mesh.facets[:, facets]  # (2, n_f) vertices
    X = np.asarray(geo.doflocs, float)
    if place is not None:
        X = np.asarray(place(X), float)
    gnodes = [geo.nodal_dofs[0, ends[0]], geo.nodal_dofs[0, ends[1]]]
    if geo.facet_dofs.shape[0]:
        gnodes.append(geo.facet_dofs[0, facets])
    geometry = np.stack([X[:, g].T for g in gnodes], axis=1)
    b = body.scalar
    dnodes = [b.nodal_dofs[0, ends[0]], b.nodal_dofs[0, ends[1]]]
    if b.facet_dofs.shape[0]:
        dnodes.append(b.facet_dofs[0, facets])
    dofs = np.stack(dnodes, axis=1).astype(np.int64)
    elems = mesh.t[:, mesh.f2t[0, facets]]  # (3, n_f) each facet's element
    third = np.where((elems != ends[0]) & (elems != ends[1]), elems, -1).max(axis=0)
    inside = X[:, geo.nodal_dofs[0, third]].T
    return Surface(geometry=geometry, dofs=dofs, inside=np.ascontiguousarray(inside))


def shape(k: int, xi: np.ndarray) -> np.ndarray:
    """(len(xi), k) values of the 1D Lagrange shape functions on [0, 1] with nodes 0, 1
    (k = 2) and 1/2 (k = 3, last)."""
    xi = np.asarray(xi, float)
    if k == 2:
        return np.stack([1.0 - xi, xi], axis=-1)
    if k == 3:
        return np.stack([(1.0 - xi) * (1.0 - 2.0 * xi), xi * (2.0 * xi - 1.0),
                         4.0 * xi * (1.0 - xi)], axis=-1)
    raise ValueError(f"facet shape functions with {k!r} nodes: allowed 2 (P1), 3 (P2)")


def _coefficients(G: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x(xi) = a0 + a1 xi + a2 xi^2 of a facet's geometric nodes (q, 2)."""
    if G.shape[0] == 2:
        return G[0], G[1] - G[0], np.zeros(2)
    return G[0], -3.0 * G[0] - G[1] + 4.0 * G[2], 2.0 * G[0] + 2.0 * G[1] - 4.0 * G[2]


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _roots(c: np.ndarray, f: Callable[[float], float], df: Callable[[float], float]
           ) -> list[float]:
    """The real roots in [-REACH, 1 + REACH] of the polynomial with coefficients c
    (lowest first), polished by Newton's method on f."""
    c = np.trim_zeros(np.asarray(c, float), "b")
    if c.size <= 1:
        return []
    out = []
    for r in np.roots(c[::-1]):
        if abs(r.imag) > 1e-8 or not -0.5 <= r.real <= 1.5:
            continue
        x = float(r.real)
        for _ in range(3):
            d = df(x)
            if d == 0.0:
                break
            x -= f(x) / d
        if -REACH <= x <= 1.0 + REACH:
            out.append(x)
    return out


def _snap(xi: float, q: int) -> float:
    nodes = (0.0, 1.0, 0.5) if q == 3 else (0.0, 1.0)
    for x in nodes:
        if abs(xi - x) <= SNAP:
            return x
    return min(max(xi, 0.0), 1.0)


def project(points: np.ndarray, surf: Surface, normal: np.ndarray | None = None
            ) -> Projection:
    """Project each point of `points` (2, n_s) on the surface.

    normal None: closest-point projection, the row's normal the master's outward unit
    normal at the projected point (the nearest facet; a tie, the first). normal given
    (a 2-vector, made unit): each point projected along it, on the facet whose outward
    normal faces it (n_m . normal > 0) nearest along the line; the row's normal is
    `normal`; a point whose line meets no facet facing it (past the master's edge) is
    put on the nearest facing facet end within a facet's length of its line.
    ValueError naming the first point that lands on no facet."""
    P, d = checked_points(points, normal, 2)
    q, k = surf.geometry.shape[1], surf.dofs.shape[1]
    coeffs = [_coefficients(g) for g in surf.geometry]
    n_s = P.shape[1]
    facet, xis = np.zeros(n_s, np.int64), np.zeros(n_s)
    point, nrm, gap0 = np.zeros((n_s, 2)), np.zeros((n_s, 2)), np.zeros(n_s)
    for s in range(n_s):
        p = P[:, s]
        best: tuple[float, int, float, np.ndarray, np.ndarray] | None = None
        for f, (a0, a1, a2) in enumerate(coeffs):
            b0 = a0 - p
            if d is None:  # stationary points of |x(xi) - p|^2, and the ends
                c = [b0 @ a1, a1 @ a1 + 2.0 * (b0 @ a2), 3.0 * (a1 @ a2), 2.0 * (a2 @ a2)]
                cands = [0.0, 1.0, *_roots(
                    np.array(c), lambda x, c=c: c[0] + x * (c[1] + x * (c[2] + x * c[3])),
                    lambda x, c=c: c[1] + x * (2.0 * c[2] + 3.0 * x * c[3]))]
            else:  # (x(xi) - p) x d = 0
                c = [_cross(b0, d), _cross(a1, d), _cross(a2, d)]
                cands = _roots(np.array(c), lambda x, c=c: c[0] + x * (c[1] + x * c[2]),
                               lambda x, c=c: c[1] + 2.0 * x * c[2])
            for x in cands:
                xi = _snap(x, q)
                xp = shape(q, np.array([xi]))[0] @ surf.geometry[f]
                tangent = a1 + 2.0 * xi * a2
                nm = np.array([tangent[1], -tangent[0]]) / np.linalg.norm(tangent)
                if nm @ (xp - surf.inside[f]) < 0:
                    nm = -nm
                if d is None:
                    dist = float(np.linalg.norm(p - xp))
                    row_n = nm
                else:
                    if nm @ d <= 0.0:
                        continue  # a facet facing away from the point
                    dist = abs(float((p - xp) @ d))
                    row_n = d
                if best is None or dist < best[0]:
                    best = (dist, f, xi, xp, row_n)
        if best is None and d is not None:
            best = _past_the_edge(p, d, surf, coeffs)
        if best is None:
            raise ValueError(f"slave point {s} at {np.round(p, 6).tolist()} projects on "
                             "no master facet")
        _, facet[s], xis[s], point[s], nrm[s] = best
        diff = p - point[s]
        gap0[s] = diff[0] * nrm[s, 0] + diff[1] * nrm[s, 1]
    weights = shape(k, xis)
    return Projection(facet=facet, xi=xis, weights=weights, point=point, normal=nrm,
                      gap0=gap0)


def _past_the_edge(p: np.ndarray, d: np.ndarray, surf: Surface, coeffs: list
                   ) -> tuple[float, int, float, np.ndarray, np.ndarray] | None:
    """A point whose line along d meets no facet facing it (it lies past the master's
    edge): the facing facets' end nearest to the line, if it is within that facet's
    length of it (the row then joins the point to that end node; its gap is the
    distance along d, large: such a point does not reach the master while sliding is
    small). None: no end that near."""
    best = None
    for f, (_, a1, a2) in enumerate(coeffs):
        length = float(np.linalg.norm(surf.geometry[f, 1] - surf.geometry[f, 0]))
        for xi in (0.0, 1.0):
            xp = surf.geometry[f, int(xi)]
            tangent = a1 + 2.0 * xi * a2
            nm = np.array([tangent[1], -tangent[0]])
            if nm @ (xp - surf.inside[f]) < 0:
                nm = -nm
            off = abs(_cross(xp - p, d))
            if nm @ d > 0.0 and off <= length and (best is None or off < best[0]):
                best = (off, f, xi, xp.copy(), d)
    return None if best is None else (abs(float((p - best[3]) @ d)), *best[1:])


def gap_rows(proj: Projection, slave_scalar: np.ndarray, surf: Any, n_slave: int,
             n_master: int) -> sp.csr_matrix:
    """G (n_s x (n_slave + n_master), CSR) over the slave body's vector dofs followed by
    the master's (d s + c, as `fem_nd`; d = 2 or 3, the normals' length): row i +normal
    on slave scalar dof slave_scalar[i], -weights * normal on its facet's master dofs
    (offset by n_slave); exact zeros dropped. `surf` is a `Surface` or a 3D
    `node_to_facet.TriangleSurface` (its `dofs` per facet)."""
    s = np.asarray(slave_scalar, np.int64)
    if s.size != proj.facet.size:
        raise ValueError(f"{s.size} slave dofs for {proj.facet.size} projections")
    n_s, k = proj.weights.shape
    dim = proj.normal.shape[1]
    rows, cols, vals = [], [], []
    for c in range(dim):
        nc = proj.normal[:, c]
        rows.append(np.arange(n_s))
        cols.append(dim * s + c)
        vals.append(nc)
        m = surf.dofs[proj.facet]  # (n_s, k)
        rows.append(np.repeat(np.arange(n_s), k))
        cols.append((n_slave + dim * m + c).ravel())
        vals.append((-proj.weights * nc[:, None]).ravel())
    G = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n_s, int(n_slave) + int(n_master)))
    G.eliminate_zeros()
    G.sort_indices()
    return G


__all__ = ["REACH", "SNAP", "Projection", "Surface", "checked_points", "gap_rows",
           "master_facets", "project", "shape", "surface"]
