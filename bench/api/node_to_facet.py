"""Node-to-facet gap rows between two deformable 3D bodies whose interfaces do not match:
the 3D counterpart of `node_to_segment`, with triangles as the master facets.

Each contact node s of the slave body, at X_s, is projected on the master body's
boundary triangles (`TriangleSurface`), at the barycentric coordinates l = (l0, l1, l2)
of one triangle, and its row of the gap operator G is

    gap_s = (X_s + u_s - sum_k N_k(l) (X_k + u_k)) . n  =  gap0_s + G_s U,

+n on the slave node's three components, -N_k(l) n on the triangle's displacement nodes
k: P1, N_k = l_k at the three vertices; P2, the quadratic triangle's six functions
l_i (2 l_i - 1) at the vertices and 4 l_i l_j at the edge midpoints (edges 01, 12, 02).
n is the master's outward unit normal (closest-point projection) or a given direction
(each node projected along it). The weights sum to one, so each row's coefficients sum
to zero per component: G^T lambda carries no net force and the pair's momentum is kept.

The facets are the mesh's straight-sided triangles (scikit-fem's tetrahedra; a P2
displacement on them keeps the facet flat), so the projection is linear in l. As in
2D the rows are built once, in the reference configuration (small sliding:
docs/contact.md), and a projection within `SNAP` of a facet node (a vertex or, on
either degree, an edge midpoint) or of an edge is put on it exactly: matching meshes
give the node-to-node rows exactly (a weight of 1 on the one node). `gap_rows` is
`node_to_segment`'s, which takes rows of any dimension.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from contact_bench.api.fem_nd import Elasticity, Facets
from contact_bench.api.node_to_segment import (
    REACH,
    SNAP,
    Projection,
    checked_points,
    gap_rows,
    master_facets,
)

#: the P2 triangle's nodes in (l1, l2): the vertices, then the edge midpoints 01, 12, 02
NODES = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]])
#: the vertex pairs of the P2 triangle's edge nodes, in `NODES`' order
EDGES = ((0, 1), (1, 2), (0, 2))


@dataclass(frozen=True)
class TriangleSurface:
    """A body's boundary triangles in 3D, as the master side of node-to-facet rows.

    `geometry` (n_f, 3, 3): each facet's three vertices (rows); `dofs` (n_f, k): the
    body's scalar dofs carrying the displacement on the facet (k = 3: P1, the vertices;
    k = 6: P2, the vertices then the edge nodes 01, 12, 02); `inside` (n_f, 3): the
    fourth vertex of the facet's tetrahedron, which tells the outward side."""

    geometry: np.ndarray
    dofs: np.ndarray
    inside: np.ndarray

    def __post_init__(self) -> None:
        nf = self.geometry.shape[0]
        if self.geometry.ndim != 3 or self.geometry.shape[1:] != (3, 3):
            raise ValueError(f"surface geometry of shape {self.geometry.shape}: need "
                             "(facets, 3 vertices, 3 coordinates)")
        if self.dofs.shape not in ((nf, 3), (nf, 6)) or self.inside.shape != (nf, 3):
            raise ValueError(f"surface dofs {self.dofs.shape} or inside points "
                             f"{self.inside.shape} do not match {nf} facets")

    def normals(self) -> np.ndarray:
        """(n_f, 3) each facet's outward unit normal (away from its `inside` point)."""
        a, b, c = (self.geometry[:, i] for i in range(3))
        n = np.cross(b - a, c - a)
        n /= np.linalg.norm(n, axis=1)[:, None]
        flip = np.einsum("ij,ij->i", n, a - self.inside) < 0
        n[flip] *= -1.0
        return n


def surface(body: Elasticity, where: Facets, place: Callable[[np.ndarray], np.ndarray] | None = None
            ) -> TriangleSurface:
    """The `TriangleSurface` of the 3D body's boundary facets `where` (a predicate on
    points or facet indices, as `fem_nd.facets_of`), its coordinates mapped by `place`
    ((3, m) -> (3, m), e.g. the body mirrored or turned into its place in the scene;
    None: as meshed). The displacement's degree is the body's (P1 or P2 dofs)."""
    mesh = body.mesh
    facets = master_facets(body, where, 3)
    X = np.asarray(mesh.p, float)
    if place is not None:
        X = np.asarray(place(X), float)
    verts = mesh.facets[:, facets]  # (3, n_f)
    geometry = np.ascontiguousarray(np.stack([X[:, v].T for v in verts], axis=1))
    b = body.scalar
    dnodes = [b.nodal_dofs[0, v] for v in verts]
    if b.edge_dofs.shape[0]:  # P2: the edge nodes of the facet's edges 01, 12, 02
        key = {(int(i), int(j)): e for e, (i, j) in enumerate(np.sort(mesh.edges, axis=0).T)}
        for i, j in EDGES:
            lo, hi = np.minimum(verts[i], verts[j]), np.maximum(verts[i], verts[j])
            edge = np.array([key[(int(p), int(q))] for p, q in zip(lo, hi, strict=True)])
            dnodes.append(b.edge_dofs[0, edge])
    dofs = np.stack(dnodes, axis=1).astype(np.int64)
    elems = mesh.t[:, mesh.f2t[0, facets]]  # (4, n_f) each facet's tetrahedron
    off = (elems != verts[0]) & (elems != verts[1]) & (elems != verts[2])
    fourth = np.where(off, elems, -1).max(axis=0)
    return TriangleSurface(geometry=geometry, dofs=dofs,
                           inside=np.ascontiguousarray(X[:, fourth].T))


def shape(k: int, lam: np.ndarray) -> np.ndarray:
    """(n, k) values of the triangle's Lagrange shape functions at barycentric
    coordinates lam (n, 3): k = 3 (P1) the coordinates themselves; k = 6 (P2) the
    vertices' l_i (2 l_i - 1), then the edge nodes' 4 l_i l_j (edges 01, 12, 02)."""
    lam = np.atleast_2d(np.asarray(lam, float))
    if k == 3:
        return lam.copy()
    if k == 6:
        corner = lam * (2.0 * lam - 1.0)
        edge = np.stack([4.0 * lam[:, i] * lam[:, j] for i, j in EDGES], axis=1)
        return np.concatenate([corner, edge], axis=1)
    raise ValueError(f"triangle shape functions with {k!r} nodes: allowed 3 (P1), 6 (P2)")


def _snap(s: float, t: float) -> np.ndarray:
    """Barycentric (l0, l1, l2) of the local coordinates (l1, l2) = (s, t): put on a
    facet node within SNAP, else on an edge within SNAP (the other two renormalised),
    else clipped into the triangle."""
    near = np.max(np.abs(NODES - [s, t]), axis=1)
    if near.min() <= SNAP:
        s, t = NODES[int(np.argmin(near))]
        return np.array([1.0 - s - t, s, t])
    lam = np.array([1.0 - s - t, s, t])
    lam[lam <= SNAP] = 0.0
    return lam / lam.sum()


def _hits(p: np.ndarray, d: np.ndarray, surf: TriangleSurface, normals: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where the line p + tau d meets each facet's plane (Moller-Trumbore, every facet
    at once): (s, t, tau, facing), facing the facets whose outward normal faces d
    (n . d > 0) and which the line meets within REACH of their edges."""
    a = surf.geometry[:, 0]
    e1, e2 = surf.geometry[:, 1] - a, surf.geometry[:, 2] - a
    h = np.cross(np.broadcast_to(d, e2.shape), e2)
    det = np.einsum("ij,ij->i", e1, h)
    ok = (normals @ d > 0.0) & (det != 0.0)
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    sv = p - a
    s = inv * np.einsum("ij,ij->i", sv, h)
    q = np.cross(sv, e1)
    t = inv * (q @ d)
    tau = inv * np.einsum("ij,ij->i", e2, q)
    ok &= (s >= -REACH) & (t >= -REACH) & (s + t <= 1.0 + REACH)
    return s, t, tau, ok


def _closest(p: np.ndarray, surf: TriangleSurface
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(n_f, 2) local coordinates (l1, l2) of the point of each facet nearest to p,
    (n_f,) the distances and (n_f,) whether it is the plane's foot (inside the facet;
    otherwise the nearest point of the three edges)."""
    a = surf.geometry[:, 0]
    e1, e2 = surf.geometry[:, 1] - a, surf.geometry[:, 2] - a
    # the plane's foot: the normal equations of min |a + s e1 + t e2 - p|
    g11, g12, g22 = (np.einsum("ij,ij->i", x, y) for x, y in ((e1, e1), (e1, e2), (e2, e2)))
    r1, r2 = (np.einsum("ij,ij->i", p - a, e) for e in (e1, e2))
    det = g11 * g22 - g12 * g12
    cands = [np.stack([(g22 * r1 - g12 * r2) / det, (g11 * r2 - g12 * r1) / det], axis=1)]
    inside = (cands[0][:, 0] >= 0) & (cands[0][:, 1] >= 0) & (cands[0].sum(axis=1) <= 1)
    for u, v in (((0, 0), (1, 0)), ((1, 0), (0, 1)), ((0, 1), (0, 0))):  # the edges
        u, v = np.array(u, float), np.array(v, float)
        x0 = a + u[0] * e1 + u[1] * e2
        dx = (v[0] - u[0]) * e1 + (v[1] - u[1]) * e2
        w = np.clip(np.einsum("ij,ij->i", p - x0, dx) / np.einsum("ij,ij->i", dx, dx),
                    0.0, 1.0)
        cands.append(u + w[:, None] * (v - u))
    dist = np.stack([np.linalg.norm(a + c[:, :1] * e1 + c[:, 1:] * e2 - p, axis=1)
                     for c in cands], axis=1)
    dist[~inside, 0] = np.inf
    best = np.argmin(dist, axis=1)
    rows = np.arange(a.shape[0])
    st = np.stack(cands, axis=1)[rows, best]
    return st, dist[rows, best], best == 0


def project(points: np.ndarray, surf: TriangleSurface, normal: np.ndarray | None = None
            ) -> Projection:
    """Project each point of `points` (3, n_s) on the triangles (`Projection` with
    `xi` (n_s, 3) the barycentric coordinates).

    normal None: closest-point projection, the row's normal the nearest facet's outward
    unit normal (a tie, the first facet), or, where the nearest point is on the facet's
    edge or vertex, the unit vector from it to the point (in the normal cone there, so
    that the reference gap is the distance; oriented outward). normal given (a
    3-vector, made unit): each point projected along it on the facet facing it (n_m .
    normal > 0) nearest along the line; the row's normal is `normal`; a point whose line
    meets no facing facet (past the master's edge) is put on the facing facets' vertex
    nearest to its line, if within that facet's longest edge of it. ValueError naming
    the first point that lands on no facet."""
    P, d = checked_points(points, normal, 3)
    normals = surf.normals()
    n_s = P.shape[1]
    facet, lams = np.zeros(n_s, np.int64), np.zeros((n_s, 3))
    point, nrm, gap0 = np.zeros((n_s, 3)), np.zeros((n_s, 3)), np.zeros(n_s)
    for j in range(n_s):
        p = P[:, j]
        if d is None:
            st, dist, foot = _closest(p, surf)
            f = int(np.argmin(dist))
            lam, row_n = _snap(*st[f]), normals[f]
            if not foot[f] and dist[f] > 0.0:  # on an edge or a vertex: the normal
                row_n = p - lam @ surf.geometry[f]  # cone's direction towards p
                row_n = (-1.0 if row_n @ normals[f] < 0 else 1.0) * row_n / dist[f]
        else:
            s, t, tau, ok = _hits(p, d, surf, normals)
            if ok.any():
                f = int(np.flatnonzero(ok)[np.argmin(np.abs(tau[ok]))])
                lam, row_n = _snap(s[f], t[f]), d
            else:
                f, lam = _past_the_edge(p, d, surf, normals)
                if f < 0:
                    raise ValueError(f"slave point {j} at {np.round(p, 6).tolist()} projects "
                                     "on no master facet")
                row_n = d
        facet[j], lams[j], nrm[j] = f, lam, row_n
        point[j] = lam @ surf.geometry[f]
        gap0[j] = float((p - point[j]) @ row_n)
    return Projection(facet=facet, xi=lams, weights=shape(surf.dofs.shape[1], lams),
                      point=point, normal=nrm, gap0=gap0)


def _past_the_edge(p: np.ndarray, d: np.ndarray, surf: TriangleSurface, normals: np.ndarray
                   ) -> tuple[int, np.ndarray]:
    """A point whose line along d meets no facing facet: (facet, barycentric) of the
    facing facets' vertex nearest to the line, if within that facet's longest edge of
    it; (-1, zeros) when none is that near."""
    facing = np.flatnonzero(normals @ d > 0.0)
    if facing.size == 0:
        return -1, np.zeros(3)
    V = surf.geometry[facing]  # (m, 3, 3)
    rel = V - p
    off = np.linalg.norm(rel - (rel @ d)[..., None] * d, axis=2)  # (m, 3) to the line
    edge = np.max(np.linalg.norm(V - np.roll(V, 1, axis=1), axis=2), axis=1)
    k = int(np.argmin(off))
    f, v = divmod(k, 3)
    if off[f, v] > edge[f]:
        return -1, np.zeros(3)
    lam = np.zeros(3)
    lam[v] = 1.0
    return int(facing[f]), lam


__all__ = ["EDGES", "NODES", "TriangleSurface", "gap_rows", "project", "shape", "surface"]
