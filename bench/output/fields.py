"""A body run's fields at its samples, for ParaView and for pictures.

`BodyFields` maps a body's sampled state (the problem's U, V over every vector dof) to
the mesh's vertices: the displacement and velocity (3 components, z = 0 in 2D, so that
ParaView's "Warp By Vector" takes them), the von Mises stress (the stress evaluated at
each element's vertices from that element's strain, averaged over the elements sharing
the vertex; 2D plane strain with sigma_zz = lambda tr(eps)) and the contact pressure
(-sigma_nn at the contact zone's vertices, the problem's `normal_stress`: the body's
normal stress there, for every scheme; zero elsewhere). P2 bodies are written at their
vertices, on the vertices' linear cells (the edge nodes are left out).

`write_series` writes them as a VTU series (one .vtu a sample, through meshio) and its
ParaView collection `<name>.pvd` with the sample times: File > Open the .pvd.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

#: meshio's cell type of a scikit-fem mesh's vertex cells, and the node order from it
_CELL_TYPES = {(2, 3): "triangle", (2, 4): "quad", (3, 4): "tetra", (3, 8): "hexahedron"}
_HEX_TO_VTK = (0, 3, 6, 2, 1, 5, 7, 4)
#: samples whose fields are computed at once (a block of samples x elements x points)
BLOCK = 64


@dataclass(frozen=True)
class BodyFields:
    """A body's vertex fields of its samples (module docstring), built once per run."""

    points: np.ndarray  # (nv, dim) vertex coordinates
    cell_type: str
    cells: np.ndarray  # (elements, nodes) in meshio's order
    vertex_dofs: np.ndarray  # (nv, dim) the vector dof of vertex v, component c
    element_dofs: np.ndarray  # (local dofs, elements)
    dgrad: np.ndarray  # (local dofs, dim, dim, elements, vertices of an element)
    corners: np.ndarray  # (vertices of an element, elements): the mesh's t
    lam: float
    mu: float
    zone_vertices: np.ndarray  # contact rows whose dof is at a vertex
    zone_vertex: np.ndarray  # ... and that vertex
    normal_stress: Any  # (n_c, n) sparse, or None
    axis: int = -1  # the obstacle's normal axis (-1: none known)
    level: float = 0.0  # the obstacle plane's coordinate along it

    @property
    def dim(self) -> int:
        return int(self.points.shape[1])

    @property
    def nvertices(self) -> int:
        return int(self.points.shape[0])

    def displacement(self, U: np.ndarray) -> np.ndarray:
        """(samples, nv, 3) of (samples, n) vector-dof values."""
        U = np.atleast_2d(U)
        out = np.zeros((U.shape[0], self.nvertices, 3))
        out[:, :, :self.dim] = U[:, self.vertex_dofs]
        return out

    def von_mises(self, U: np.ndarray) -> np.ndarray:
        """(samples, nv) the vertex-averaged von Mises stress."""
        U = np.atleast_2d(U)
        out = np.empty((U.shape[0], self.nvertices))
        count = np.bincount(self.corners.ravel(), minlength=self.nvertices)
        for a in range(0, U.shape[0], BLOCK):
            Ue = U[a:a + BLOCK][:, self.element_dofs]  # (s, k, e)
            G = np.einsum("ske,kijep->sijep", Ue, self.dgrad)
            eps = 0.5 * (G + np.swapaxes(G, 1, 2))
            tr = np.einsum("siiep->sep", eps)
            s = 2 * self.mu * eps
            for i in range(self.dim):
                s[:, i, i] += self.lam * tr
            if self.dim == 2:
                szz = self.lam * tr
                vm2 = 0.5 * ((s[:, 0, 0] - s[:, 1, 1]) ** 2 + (s[:, 1, 1] - szz) ** 2
                             + (szz - s[:, 0, 0]) ** 2) + 3 * s[:, 0, 1] ** 2
            else:
                vm2 = 0.5 * ((s[:, 0, 0] - s[:, 1, 1]) ** 2 + (s[:, 1, 1] - s[:, 2, 2]) ** 2
                             + (s[:, 2, 2] - s[:, 0, 0]) ** 2) + 3 * (
                    s[:, 0, 1] ** 2 + s[:, 1, 2] ** 2 + s[:, 0, 2] ** 2)
            vm = np.sqrt(np.maximum(vm2, 0.0))  # (s, e, p): p the element's vertex p
            corner = self.corners.T  # (e, p)
            for k in range(vm.shape[0]):
                out[a + k] = np.bincount(corner.ravel(), weights=vm[k].ravel(),
                                         minlength=self.nvertices) / np.maximum(count, 1)
        return out

    def contact_pressure(self, U: np.ndarray) -> np.ndarray:
        """(samples, nv): -sigma_nn at the contact zone's vertices, zero elsewhere."""
        U = np.atleast_2d(U)
        out = np.zeros((U.shape[0], self.nvertices))
        if self.normal_stress is not None and self.zone_vertices.size:
            sn = np.asarray(self.normal_stress @ U.T).T  # (s, n_c)
            out[:, self.zone_vertex] = -sn[:, self.zone_vertices]
        return out

    def point_data(self, U: np.ndarray, V: np.ndarray) -> dict[str, np.ndarray]:
        """The four fields of the samples U, V (each (samples, n)): name -> (samples, nv,
        ...)."""
        return {"displacement": self.displacement(U), "velocity": self.displacement(V),
                "von_mises": self.von_mises(U), "contact_pressure": self.contact_pressure(U)}


def body_fields(body: Any, problem: Any) -> BodyFields:
    """The `BodyFields` of an assembled body (`contact_bench.api.fem_nd.Elasticity`) and
    its problem; ValueError when the problem's unknowns are not the body's every vector
    dof (a body with eliminated Dirichlet or sliding dofs)."""
    import skfem as fe

    if problem.nfree != body.ndofs:
        raise ValueError(f"fields need the body's every dof as unknowns: the problem has "
                         f"{problem.nfree} of {body.ndofs} (eliminated boundary dofs)")
    mesh = body.mesh
    d = body.dim
    t = np.asarray(mesh.t, np.int64)
    nv = int(mesh.nvertices)  # a P2 mesh's `p` holds its edge nodes too
    ctype = _CELL_TYPES[(d, t.shape[0])]
    cells = (t[list(_HEX_TO_VTK)] if ctype == "hexahedron" else t).T
    if ctype in ("triangle", "tetra"):  # positively oriented, as ParaView draws them
        P = mesh.doflocs[:, t]
        E = np.stack([P[:, k] - P[:, 0] for k in range(1, d + 1)], axis=0)  # (d, d, e)
        flip = np.linalg.det(np.moveaxis(E, -1, 0)) < 0
        cells = cells.copy()
        cells[flip, 1], cells[flip, 2] = cells[flip, 2].copy(), cells[flip, 1].copy()
    ref = np.asarray(mesh.elem.refdom.p, float)
    elem = fe.ElementVector(body.scalar.elem)
    basis = fe.CellBasis(mesh, elem, quadrature=(ref, np.ones(ref.shape[1])))
    dgrad = np.stack([np.asarray(basis.basis[k][0].grad) for k in range(len(basis.basis))])
    vertex_dofs = d * np.arange(nv)[:, None] + np.arange(d)[None, :]
    dofs = np.asarray(problem.contact.dofs) if problem.contact.dofs is not None else \
        np.zeros(0, np.int64)
    scalar = dofs // d
    rows = np.flatnonzero(scalar < nv)
    axis, level = -1, 0.0
    if problem.vertical is not None and dofs.size:
        axis = int(np.argmax(np.abs(np.asarray(problem.vertical)[:d])))
        X = np.asarray(body.dof_coordinates)[axis, scalar]
        level = float(np.mean(X - np.asarray(problem.contact.gap0)))
    return BodyFields(points=np.ascontiguousarray(mesh.doflocs[:, :nv].T), cell_type=ctype,
                      cells=np.ascontiguousarray(cells), vertex_dofs=vertex_dofs,
                      element_dofs=np.asarray(basis.element_dofs, np.int64), dgrad=dgrad,
                      corners=t, lam=float(body.lam), mu=float(body.mu),
                      zone_vertices=rows, zone_vertex=scalar[rows],
                      normal_stress=problem.normal_stress, axis=axis, level=level)


def write_series(folder: str | Path, name: str, fields: BodyFields, t: np.ndarray,
                 U: np.ndarray, V: np.ndarray) -> Path:
    """`folder/name/name_NNNNN.vtu` (one a sample) and `folder/name.pvd` (ParaView's
    collection with the sample times); returns the .pvd."""
    import meshio

    folder = Path(folder)
    sub = folder / name
    sub.mkdir(parents=True, exist_ok=True)
    points = np.zeros((fields.nvertices, 3))
    points[:, :fields.dim] = fields.points
    entries = []
    for a in range(0, len(t), BLOCK):
        data = fields.point_data(U[a:a + BLOCK], V[a:a + BLOCK])
        for k in range(data["displacement"].shape[0]):
            i = a + k
            vtu = sub / f"{name}_{i:05d}.vtu"
            meshio.write(vtu, meshio.Mesh(points, [(fields.cell_type, fields.cells)],
                                          point_data={key: v[k] for key, v in data.items()}))
            entries.append(f'    <DataSet timestep="{float(t[i])!r}" part="0" '
                           f'file="{name}/{vtu.name}"/>')
    pvd = folder / f"{name}.pvd"
    pvd.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
                   "  <Collection>\n" + "\n".join(entries) + "\n  </Collection>\n"
                   "</VTKFile>\n", encoding="utf-8")
    return pvd


def read_series(pvd: str | Path) -> tuple[np.ndarray, list[Any]]:
    """The times and meshio meshes of a .pvd written by `write_series` (for checks)."""
    import xml.etree.ElementTree as ET

    import meshio

    pvd = Path(pvd)
    sets = ET.parse(pvd).getroot().iter("DataSet")
    times, meshes = [], []
    for ds in sets:
        times.append(float(ds.get("timestep")))
        meshes.append(meshio.read(pvd.parent / ds.get("file")))
    return np.array(times), meshes


def file_stem(case_spec: str, scheme_spec: str) -> str:
    """A file name of a run: its case and scheme specs with [], =, / and commas
    replaced."""
    text = f"{case_spec}__{scheme_spec}"
    for a, b in (("[", "_"), ("]", ""), (",", "_"), ("=", "-"), ("/", "_"), (" ", "")):
        text = text.replace(a, b)
    return text[:150]
