"""A body's mesh from a file: read through meshio, checked, as a scikit-fem mesh with its
named boundary groups; and a scikit-fem mesh written to Gmsh's .msh with its groups.

What is read: one kind of body element, of the mesh's top dimension: triangles
(`triangle`, `triangle6`) and quadrilaterals (`quad`) in 2D (points in the plane z = 0),
tetrahedra (`tetra`, `tetra10`) and hexahedra (`hexahedron`) in 3D; P2 geometry for the
6- and 10-node ones. The named groups are Gmsh's physical groups (`field_data` and the
`gmsh:physical` tags of the facet blocks: `line`/`line3` in 2D, `triangle`/`triangle6`/
`quad` in 3D), or a format's named cell sets; a group is kept as the indices of the
scikit-fem mesh's facets it covers. Points no body element uses are dropped.

Every check raises `MeshFileError` (a `BenchError`: one line, exit 2 from the CLI) before
anything is assembled: a missing or unreadable file, an unknown format, no body elements,
mixed or unsupported element kinds, non-finite or out-of-plane coordinates, inverted or
degenerate elements (the Jacobian determinant at the element's nodes and quadrature
points: a sign that differs from the mesh's, or a size below `DEGENERATE` times the
element's edge length to the power dim), a group that is missing, holds no facets of the
body or lies off its boundary.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import skfem as fe

from contact_bench.core.errors import BenchError, shown

#: meshio cell type -> (dimension, scikit-fem mesh class, vertices per cell)
BODY_CELLS: dict[str, tuple[int, type, int]] = {
    "triangle": (2, fe.MeshTri1, 3),
    "triangle6": (2, fe.MeshTri2, 3),
    "quad": (2, fe.MeshQuad1, 4),
    "tetra": (3, fe.MeshTet1, 4),
    "tetra10": (3, fe.MeshTet2, 4),
    "hexahedron": (3, fe.MeshHex1, 8),
}
#: meshio cell types read as facets of a body of each dimension (their first vertices)
FACET_CELLS: dict[int, dict[str, int]] = {
    2: {"line": 2, "line3": 2},
    3: {"triangle": 3, "triangle6": 3, "quad": 4, "quad8": 4, "quad9": 4},
}
#: cell types of each dimension that are body elements we do not read
UNSUPPORTED: dict[str, int] = {
    "triangle7": 2, "triangle10": 2, "quad8": 2, "quad9": 2, "polygon": 2,
    "tetra20": 3, "hexahedron20": 3, "hexahedron27": 3, "wedge": 3, "wedge15": 3,
    "pyramid": 3, "pyramid13": 3, "polyhedron": 3,
}
#: smallest |det J| / h^dim of an element (h its longest edge) that is not degenerate
DEGENERATE = 1e-10
#: meshio's (VTK's) hexahedron node order from scikit-fem's, and back (HEX_MAPPING[:8]
#: of `skfem.io.meshio` and its inverse)
HEX_TO_VTK = (0, 3, 6, 2, 1, 5, 7, 4)
HEX_FROM_VTK = tuple(HEX_TO_VTK.index(i) for i in range(8))


class MeshFileError(BenchError):
    """A mesh file that cannot make a body (one line naming the file and the problem)."""


@dataclass(frozen=True)
class MeshFile:
    """A checked body mesh: the scikit-fem `mesh`, its geometry `order` (1, or 2 for
    6- and 10-node elements), the meshio cell type it came from and its named boundary
    groups (`groups`: name -> the mesh's facet indices; only groups of facets)."""

    path: str
    mesh: fe.Mesh
    order: int
    cell_type: str
    groups: dict[str, np.ndarray]

    @property
    def dim(self) -> int:
        return int(self.mesh.dim())


def _fail(path: str, what: str) -> MeshFileError:
    return MeshFileError(f"mesh {shown(path)}: {what}")


def _read_meshio(path: str):  # -> meshio.Mesh
    try:
        import meshio
    except ImportError:  # pragma: no cover - meshio is a dependency
        raise _fail(path, "reading a mesh file needs meshio (pip install meshio)") from None
    p = Path(path)
    if not p.is_file():
        raise _fail(path, "no such file")
    try:
        return meshio.read(p)
    except meshio.ReadError as exc:
        text = " ".join(str(exc).split())
        if "extension" in text.lower() or "format" in text.lower():
            raise _fail(path, f"unknown mesh format ({text}); allowed: what meshio reads "
                        "(.msh, .vtu, .vtk, .xdmf, .med, .inp, ...)") from None
        raise _fail(path, f"not a readable mesh ({text})") from None
    except Exception as exc:  # noqa: BLE001 - a corrupt file is bad input, in one line
        text = " ".join(f"{type(exc).__name__}: {exc}".split())[:160]
        raise _fail(path, f"not a readable mesh ({text})") from None


def _body_block(path: str, m) -> tuple[str, np.ndarray, int]:
    """The body's cell type, cells and dimension (the top dimension's only kind)."""
    kinds = {}
    for block in m.cells:
        if block.type in BODY_CELLS or block.type in UNSUPPORTED:
            dim = BODY_CELLS[block.type][0] if block.type in BODY_CELLS else UNSUPPORTED[
                block.type]
            kinds.setdefault(dim, []).append(block)
    if not kinds:
        found = ", ".join(sorted({b.type for b in m.cells})) or "none"
        raise _fail(path, f"no 2D or 3D elements (cell types: {found}); allowed: "
                    f"{', '.join(BODY_CELLS)}")
    dim = max(kinds)
    if dim == 2 and 3 in kinds:  # pragma: no cover - max() took 3
        dim = 3
    # in 3D, 2D cells are facets (groups), not body elements
    types = sorted({b.type for b in kinds[dim]})
    if len(types) > 1:
        raise _fail(path, f"mixed elements ({' and '.join(types)}); allowed: one kind of "
                    f"element per mesh, among {', '.join(BODY_CELLS)}")
    ctype = types[0]
    if ctype not in BODY_CELLS:
        raise _fail(path, f"unsupported element {ctype!r}; allowed: "
                    f"{', '.join(BODY_CELLS)}")
    cells = np.concatenate([np.asarray(b.data, np.int64) for b in kinds[dim]])
    return ctype, cells, dim


def _points(path: str, m, dim: int) -> np.ndarray:
    P = np.asarray(m.points, float)
    if P.ndim != 2 or P.shape[1] < dim:
        raise _fail(path, f"points have {P.shape[-1]} coordinates for {dim}D elements")
    if not np.all(np.isfinite(P)):
        raise _fail(path, "a point has a non-finite coordinate")
    if dim == 2 and P.shape[1] > 2:
        scale = float(np.max(np.abs(P[:, :2]))) or 1.0
        off = np.max(np.abs(P[:, 2:]))
        if off > 1e-12 * scale:
            raise _fail(path, f"2D elements with points off the plane z = 0 (|z| up to "
                        f"{off:.3g}); allowed: plane meshes in x, y")
    return np.ascontiguousarray(P[:, :dim].T)


def _jacobians(mesh: fe.Mesh) -> np.ndarray:
    """(elements, points) signed det J at the reference element's vertices and at the
    points of a degree-4 rule (a curved element's Jacobian can vanish inside)."""
    from skfem.quadrature import get_quadrature

    ref = mesh.elem.refdom
    X, _ = get_quadrature(ref, 4)
    X = np.hstack([np.asarray(ref.p, float), X])
    try:
        with np.errstate(divide="ignore", invalid="ignore"):  # the affine inverse of a
            return np.asarray(mesh._mapping().detDF(X))  # flat element: found below  # noqa: SLF001 - skfem's mapping
    except Exception:  # noqa: BLE001 - scikit-fem refuses an exact zero: degenerate
        return np.zeros((mesh.t.shape[1], X.shape[1]))


def _check_elements(path: str, mesh: fe.Mesh, ctype: str) -> None:
    J = _jacobians(mesh)
    p = mesh.p
    t = mesh.t
    d = mesh.dim()
    nv = t.shape[0]
    h = np.zeros(t.shape[1])
    for a in range(nv):
        for b in range(a + 1, nv):
            h = np.maximum(h, np.linalg.norm(p[:, t[a]] - p[:, t[b]], axis=0))
    size = np.where(h > 0, h, 1.0) ** d
    small = (np.min(np.abs(J), axis=1) <= DEGENERATE * size) | (h == 0)
    if np.any(small):
        e = int(np.flatnonzero(small)[0])
        raise _fail(path, f"degenerate element {e} ({ctype}, nodes "
                    f"{t[:, e].tolist()}): zero volume; {int(small.sum())} such element(s)")
    sign = np.sign(J)
    mixed = np.any(sign != sign[:, :1], axis=1)
    if np.any(mixed):
        e = int(np.flatnonzero(mixed)[0])
        raise _fail(path, f"inverted element {e} ({ctype}): its Jacobian changes sign "
                    f"inside; {int(mixed.sum())} such element(s)")
    positive = sign[:, 0] > 0
    minority = ~positive if positive.sum() * 2 >= positive.size else positive
    if np.any(minority):
        e = int(np.flatnonzero(minority)[0])
        raise _fail(path, f"inverted element {e} ({ctype}, nodes {t[:, e].tolist()}): its "
                    f"orientation is opposite to the others'; {int(minority.sum())} such "
                    "element(s)")


def _group_cells(m, dim: int) -> dict[str, list[tuple[str, np.ndarray]]]:
    """name -> [(cell type, cells)] of every named group (Gmsh physical groups, or cell
    sets), of any dimension."""
    out: dict[str, list[tuple[str, np.ndarray]]] = {}
    tags = m.cell_data.get("gmsh:physical")
    if tags is not None and m.field_data:
        names = {}
        for name, value in m.field_data.items():
            v = np.asarray(value).ravel()
            names.setdefault(int(v[0]), []).append((name, int(v[1]) if v.size > 1 else -1))
        for block, tag in zip(m.cells, tags, strict=True):
            tag = np.asarray(tag).ravel()
            for k in np.unique(tag):
                for name, gdim in names.get(int(k), []):
                    bdim = _cell_dim(block.type)
                    if gdim in (-1, bdim):
                        out.setdefault(name, []).append(
                            (block.type, np.asarray(block.data, np.int64)[tag == k]))
    for name, sets in (m.cell_sets or {}).items():
        if name.startswith("gmsh:") or name in out:
            continue
        for block, idx in zip(m.cells, sets, strict=False):
            if idx is not None and len(idx):
                out.setdefault(name, []).append(
                    (block.type, np.asarray(block.data, np.int64)[np.asarray(idx, np.int64)]))
    return out


def _cell_dim(ctype: str) -> int:
    if ctype in BODY_CELLS:
        return BODY_CELLS[ctype][0]
    if ctype in UNSUPPORTED:
        return UNSUPPORTED[ctype]
    if ctype.startswith("line"):
        return 1
    if ctype == "vertex":
        return 0
    return -1


def read_mesh(path: str | Path) -> MeshFile:
    """The checked body mesh of a file (module docstring); `MeshFileError` otherwise."""
    path = str(path)
    m = _read_meshio(path)
    ctype, cells, dim = _body_block(path, m)
    _, cls, nvert = BODY_CELLS[ctype]
    P = _points(path, m, dim)
    if cells.size == 0:
        raise _fail(path, f"no {ctype} elements")
    if cells.min() < 0 or cells.max() >= P.shape[1]:
        raise _fail(path, f"an element refers to point {int(cells.max())} of {P.shape[1]}")
    used = np.unique(cells)
    renumber = np.full(P.shape[1], -1, np.int64)
    renumber[used] = np.arange(used.size)
    t = renumber[cells].T
    if ctype == "hexahedron":
        t = t[list(HEX_FROM_VTK)]
    P = np.ascontiguousarray(P[:, used])
    repeated = np.array([np.unique(col).size < col.size for col in t[:nvert].T])
    if np.any(repeated):
        e = int(np.flatnonzero(repeated)[0])
        raise _fail(path, f"degenerate element {e} ({ctype}): a node repeated in "
                    f"{t[:nvert, e].tolist()}")
    checked = cls(P, np.ascontiguousarray(t), sort_t=False, validate=False)
    _check_elements(path, checked, ctype)
    mesh = cls(P, np.ascontiguousarray(t), validate=False)
    order = 2 if ctype in ("triangle6", "tetra10") else 1
    groups = {}
    facet_kinds = FACET_CELLS[dim]
    # scikit-fem numbers a P2 mesh's vertices 0.. in the order of their point indices
    # (its edge nodes after them): the groups' vertices follow
    vertex = np.full(P.shape[1], -1, np.int64)
    corners = np.unique(t[:nvert])
    vertex[corners] = np.arange(corners.size)
    renumber = np.where(renumber >= 0, vertex[np.maximum(renumber, 0)], -1)
    key = {tuple(sorted(col)): f for f, col in enumerate(mesh.facets.T.tolist())}
    for name, blocks in _group_cells(m, dim).items():
        found: list[int] = []
        for btype, bcells in blocks:
            if btype not in facet_kinds or _cell_dim(btype) == dim:
                continue
            nf = facet_kinds[btype]
            for c in renumber[bcells[:, :nf]].tolist():
                found.append(key.get(tuple(sorted(c)), -1))
        groups[name] = np.array(found, np.int64)
    return MeshFile(path, mesh, order, ctype, groups)


def boundary_group(mesh_file: MeshFile, name: str) -> np.ndarray:
    """The facet indices of the named group; MeshFileError when it is missing, holds no
    facets (a group of body elements, or of points) or is not on the boundary."""
    path = mesh_file.path
    groups = mesh_file.groups
    if name not in groups:
        known = ", ".join(sorted(groups)) or "none"
        raise _fail(path, f"no group named {shown(name)!r} (groups: {known})")
    facets = groups[name]
    if facets.size == 0:
        raise _fail(path, f"group {shown(name)!r} holds no facets of the "
                    f"{mesh_file.dim}D body (a group of its elements or points?); the "
                    "contact zone is a group of boundary "
                    + ("lines" if mesh_file.dim == 2 else "faces"))
    if np.any(facets < 0):
        raise _fail(path, f"group {shown(name)!r} has {int(np.sum(facets < 0))} facet(s) "
                    "that are no element's face")
    inside = np.setdiff1d(facets, mesh_file.mesh.boundary_facets())
    if inside.size:
        raise _fail(path, f"group {shown(name)!r} is not on the boundary: "
                    f"{inside.size} of its {facets.size} facets are inside the body")
    return np.unique(facets)


def write_msh(mesh: fe.Mesh, path: str | Path, groups: dict[str, np.ndarray] | None = None,
              body: str = "body") -> Path:
    """Write a scikit-fem mesh (P1/P2 triangles and tetrahedra, Q1 quadrilaterals and
    hexahedra) to Gmsh's .msh 2.2 (ASCII): the body's elements as physical group `body`,
    each of `groups` (name -> boundary facet indices) as a physical group of lines (2D) or
    faces (3D). Triangles and tetrahedra are written positively oriented (as Gmsh makes
    them: a scikit-fem P1 mesh keeps its element nodes sorted, in either orientation);
    quadrilaterals and hexahedra as they are (one orientation, or ValueError)."""
    import meshio

    types = {v[1]: k for k, v in BODY_CELLS.items()}
    ctype = types.get(type(mesh))
    if ctype is None:
        raise ValueError(f"write_msh: no Gmsh element for {type(mesh).__name__}")
    dim = int(mesh.dim())
    pts = np.asarray(mesh.doflocs, float)
    t = np.asarray(mesh.dofs.element_dofs, np.int64).copy()
    J = _jacobians(mesh)[:, 0]
    flip = J < 0
    if np.any(flip):
        swap = {"triangle": [0, 2, 1], "triangle6": [0, 2, 1, 5, 4, 3],
                "tetra": [0, 2, 1, 3], "tetra10": [0, 2, 1, 3, 6, 5, 4, 7, 9, 8]}.get(ctype)
        if swap is not None:
            t[:, flip] = t[swap][:, flip]
        elif not np.all(flip):  # quadrilaterals, hexahedra: one orientation, as given
            raise ValueError(f"write_msh: {ctype} elements of both orientations")
    if ctype == "hexahedron":
        t = t[list(HEX_TO_VTK)]
    points = np.zeros((pts.shape[1], 3))
    points[:, :dim] = pts.T
    cells = [(ctype, t.T)]
    tags = [np.full(t.shape[1], 1, np.int64)]
    field_data = {body: np.array([1, dim])}
    facet_type = {2: "line", 3: "triangle" if mesh.facets.shape[0] == 3 else "quad"}[dim]
    for k, (name, facets) in enumerate((groups or {}).items(), start=2):
        F = np.asarray(mesh.facets[:, np.asarray(facets, np.int64)], np.int64)
        cells.append((facet_type, F.T))
        tags.append(np.full(F.shape[1], k, np.int64))
        field_data[name] = np.array([k, dim - 1])
    out = meshio.Mesh(points, cells, cell_data={"gmsh:physical": tags,
                                                "gmsh:geometrical": tags},
                      field_data=field_data)
    path = Path(path)
    meshio.write(path, out, file_format="gmsh22", binary=False)
    return path




def cached_mesh(path: str | Path) -> MeshFile:
    """`read_mesh`, read once per file version (its resolved path, size and modification
    time): a run builds its problem several times."""
    p = Path(path)
    try:
        st = p.resolve().stat()
        key = (str(p.resolve()), st.st_size, st.st_mtime_ns)
    except OSError:
        return read_mesh(path)  # raises the one-line error
    return _cached(key, str(path))


@functools.lru_cache(maxsize=8)
def _cached(key: tuple, path: str) -> MeshFile:
    return read_mesh(path)


#: the outward normal's component along the obstacle's normal below which a boundary
#: facet faces the obstacle (`facing_facets`; GetFEM's disc demo takes n_y < -0.01)
FACING = -0.01


def facing_facets(mesh_file: MeshFile, axis: int) -> np.ndarray:
    """The boundary facets whose mean outward unit normal has its `axis` component below
    `FACING` (they face an obstacle below them along that axis): the contact zone of a
    mesh without named groups (a VTU file). MeshFileError when there are none."""
    m = mesh_file.mesh
    facets = m.boundary_facets()
    fb = fe.FacetBasis(m, m.elem(), facets=facets)
    n = np.asarray(fb.normals).mean(axis=2)  # (dim, facets)
    n = n / np.linalg.norm(n, axis=0)
    out = np.sort(facets[n[axis] < FACING])
    if out.size == 0:
        raise _fail(mesh_file.path, f"no boundary facet faces the obstacle (outward normal "
                    f"component {FACING} or less along axis {axis})")
    return out


def refined_facets(coarse: fe.Mesh, facets: np.ndarray, fine: fe.Mesh) -> np.ndarray:
    """The boundary facets of `fine` (a `refined` `coarse`) inside the coarse `facets`:
    those whose vertices all lie among one coarse facet's nodes, edge midpoints and
    centre (where refinement puts new vertices; P2 geometry: its edge nodes). scikit-fem
    keeps named boundaries through `refined` for P1 triangles and Q1 quadrilaterals only.
    """
    scale = float(np.max(np.abs(coarse.doflocs))) or 1.0

    def key(x: np.ndarray) -> tuple:
        return tuple(np.round(np.asarray(x) / scale, 9).tolist())

    owners: dict[tuple, set[int]] = {}
    F = coarse.facets[:, facets]
    pts = coarse.doflocs
    for j in range(F.shape[1]):
        nodes = list(F[:, j])
        cand = [pts[:, v] for v in nodes]
        for a in range(len(nodes)):
            for b in range(a + 1, len(nodes)):
                cand.append(0.5 * (pts[:, nodes[a]] + pts[:, nodes[b]]))
        cand.append(np.mean(pts[:, nodes], axis=1))
        dofs = getattr(coarse.dofs, "facet_dofs", None)
        if dofs is not None and coarse.doflocs.shape[1] > coarse.p.shape[1]:
            cand += [pts[:, d] for d in np.asarray(dofs)[:, facets[j]]]
        for x in cand:
            owners.setdefault(key(x), set()).add(j)
    out = []
    for f in fine.boundary_facets():
        common: set[int] | None = None
        for v in fine.facets[:, f]:
            got = owners.get(key(fine.p[:, v]), set())
            common = got if common is None else common & got
            if not common:
                break
        if common:
            out.append(int(f))
    return np.array(out, np.int64)


__all__ = ["BODY_CELLS", "MeshFile", "MeshFileError", "boundary_group", "cached_mesh",
           "facing_facets", "read_mesh", "refined_facets", "write_msh"]
