"""mesh_body: a scene from a mesh file equals the built-in scene whose mesh it holds, and
every bad mesh or parameter is one line and exit 2 before anything is assembled."""

from __future__ import annotations

import math
from pathlib import Path

import meshio
import numpy as np
import pytest

from contact_bench.api.mesh_file import boundary_group, read_mesh, write_msh
from contact_bench.api.registry import make_case, make_scheme
from contact_bench.cli.main import main
from contact_bench.harness.runner import TIMING_COLUMNS, run_one

#: columns that differ by construction: the spec, the grid label (the file's mesh is
#: mesh_body's nx 2), timings, and what only the built-in scene has (its numerical and
#: converged references, the mirror symmetry of the disc's ring mesh)
NOT_COMPARED = {"case", "nx", "notes", *TIMING_COLUMNS, "symmetry_defect", "reference"}


def _same_columns(a: dict, b: dict) -> list[str]:
    """The columns compared (both rows have a value), after asserting their equality to
    round-off (the written mesh's elements are oriented, so sums run in another order)."""
    compared = []
    for key in sorted(set(a) & set(b) - NOT_COMPARED):
        va, vb = a[key], b[key]
        if va is None or vb is None or (isinstance(va, float) and math.isnan(va)):
            assert (va is None or math.isnan(va)) and (vb is None or math.isnan(vb)), key
            continue
        if isinstance(va, str):
            assert va == vb, (key, va, vb)
        else:  # relative columns near round-off (err_free_fall, drift) compared absolutely
            assert np.isclose(va, vb, rtol=1e-8, atol=1e-9), (key, va, vb)
        compared.append(key)
    return compared


@pytest.mark.parametrize("degree", [1, 2])
def test_the_disc_written_to_msh_runs_as_the_disc(tmp_path: Path, degree: int) -> None:
    disc = make_case(f"disc_drop[degree={degree}]")
    nx = 3
    body = disc.body(nx)
    facets = body.boundary_facets(lambda x: x[1] < disc.centre_y - 0.01 * disc.R)
    path = write_msh(disc.mesh(nx), tmp_path / "disc.msh", {"contact": facets})
    back = read_mesh(path)
    assert back.cell_type == "triangle6" and back.order == 2
    assert np.array_equal(back.mesh.doflocs, disc.mesh(nx).doflocs)
    assert np.array_equal(boundary_group(back, "contact"), np.sort(facets))
    mine = make_case(f"mesh_body[file={path},degree={degree},h_contact={disc.R / nx!r}]")
    # schemes that do not chatter (a chattering active set amplifies round-off)
    for scheme in ("nitsche", "redistributed"):
        a = run_one(disc, make_scheme(scheme), nx=nx, T=14.0, dt=0.02, stride=1).row
        b = run_one(mine, make_scheme(scheme), nx=2, T=14.0, dt=0.02, stride=1).row
        assert a["status"] == b["status"] == "ok"
        cols = _same_columns(a, b)
        assert {"energy_final", "peak_contact_force", "penetration_max", "impacts",
                "first_contact_start", "err_free_fall", "impulse_residual"} <= set(cols)


def test_the_ball_written_to_msh_runs_as_the_ball(tmp_path: Path) -> None:
    ball = make_case("sphere_drop[lift=0.5]")
    nx = 4
    m = ball.mesh(nx)
    facets = m.facets_satisfying(lambda x: x[2] < ball.centre_z - 0.01 * ball.R,
                                 boundaries_only=True)
    path = write_msh(m, tmp_path / "ball.msh", {"contact": facets})
    mine = make_case(f"mesh_body[file={path},lift=0.5,h_contact={ball.R / nx!r}]")
    for scheme in ("nitsche", "penalty"):
        a = run_one(ball, make_scheme(scheme), nx=nx, T=5.0, dt=0.02, stride=5).row
        b = run_one(mine, make_scheme(scheme), nx=2, T=5.0, dt=0.02, stride=5).row
        assert a["status"] == b["status"] == "ok"
        assert "peak_contact_force" in _same_columns(a, b)


def test_p2_tetrahedra_and_hexahedra_read_back(tmp_path: Path) -> None:
    import skfem as fe

    tet2 = fe.MeshTet2.from_mesh(fe.MeshTet1.init_tensor(*[np.linspace(0, 1, 3)] * 3))
    hexa = fe.MeshHex1.init_tensor(*[np.linspace(0, 1, 3)] * 3)
    for m in (tet2, hexa):
        bottom = m.facets_satisfying(lambda x: x[2] < 1e-9, boundaries_only=True)
        back = read_mesh(write_msh(m, tmp_path / f"{type(m).__name__}.msh",
                                   {"contact": bottom}))
        assert type(back.mesh) is type(m)
        assert np.allclose(np.sort(back.mesh.doflocs, axis=1), np.sort(m.doflocs, axis=1))
        assert boundary_group(back, "contact").size == bottom.size
        case = make_case(f"mesh_body[file={back.path},lift=0.1,g=1]")
        assert case.sparse_problem(2, 1.0, "consistent").contact.size > 0


def test_the_bundled_ellipse_runs_and_refines() -> None:
    case = make_case("mesh_body[lift=0.5]")
    assert case.mesh_file.cell_type == "triangle"
    assert case.mesh(4)[0].t.shape[1] == 4 * case.mesh(2)[0].t.shape[1]
    row = run_one(case, make_scheme("nitsche"), T=5.0).row
    assert row["status"] == "ok" and row["first_contact_start"] > 0
    assert row["err_free_fall"] < 1e-9


# --------------------------------------------------------------------- bad inputs


def _write(path: Path, points, cells, groups: dict[str, tuple[str, list]] | None = None
           ) -> str:
    """A .msh of `cells` [(type, data)] and named facet groups {name: (type, data)}."""
    cells = list(cells)
    tags = [np.ones(len(c[1]), int) for c in cells]
    field = {"body": np.array([1, 2])}
    for k, (name, (ctype, data)) in enumerate((groups or {}).items(), start=2):
        cells.append((ctype, data))
        tags.append(np.full(len(data), k))
        field[name] = np.array([k, 1])
    meshio.write(path, meshio.Mesh(np.asarray(points, float), cells,
                                   cell_data={"gmsh:physical": tags,
                                              "gmsh:geometrical": tags},
                                   field_data=field), file_format="gmsh22", binary=False)
    return str(path)


SQUARE = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
TRIS = [[0, 1, 2], [0, 2, 3]]
BOTTOM = {"contact": ("line", [[0, 1]])}


def _bad_meshes(d: Path) -> dict[str, tuple[str, str]]:
    """name -> (case spec, a word the one-line message must hold)."""
    ok = _write(d / "ok.msh", SQUARE, [("triangle", TRIS)], BOTTOM)
    corrupt = d / "corrupt.msh"
    corrupt.write_text("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0\n")
    unknown = d / "body.xyz"
    unknown.write_text("1 2 3\n")
    pts5 = [*SQUARE, [2, 0, 0]]
    six = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 0, 0], [0.5, 0.5, 0], [0.6, 0.6, 0]]
    interior = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0]]
    fan = [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]
    files = {
        "missing file": (d / "nowhere.msh", "no such file"),
        "unknown format": (unknown, "format"),
        "corrupt file": (corrupt, "not a readable mesh"),
        "mixed elements": (_write(d / "mixed.msh", pts5, [("quad", [[0, 1, 2, 3]]),
                                                         ("triangle", [[1, 4, 2]])], BOTTOM),
                           "mixed elements"),
        "unsupported element": (_write(d / "q9.msh", [*SQUARE, *[[0.5, 0.5, 0]] * 5],
                                       [("quad9", [[0, 1, 2, 3, 4, 5, 6, 7, 8]])]),
                                "unsupported element"),
        "no body elements": (_write(d / "lines.msh", SQUARE, [("line", [[0, 1], [1, 2]])]),
                             "no 2D or 3D elements"),
        "inverted element": (_write(d / "inv.msh", SQUARE, [("triangle", [[0, 1, 2],
                                                                          [0, 3, 2]])],
                                    BOTTOM), "inverted element"),
        "degenerate element": (_write(d / "flat.msh", [[0, 0, 0], [1, 0, 0], [2, 0, 0],
                                                       [0, 1, 0]],
                                      [("triangle", [[0, 1, 3], [0, 1, 2]])], BOTTOM),
                               "degenerate element"),
        "repeated node": (_write(d / "rep.msh", SQUARE, [("triangle", [[0, 1, 2],
                                                                       [0, 2, 2]])],
                                 BOTTOM), "degenerate element"),
        "P2 element folded": (_write(d / "fold.msh", six, [("triangle6", [[0, 1, 2, 3, 4,
                                                                           5]])]),
                              "inverted element"),
        "off the plane z = 0": (_write(d / "z.msh", [[0, 0, 0], [1, 0, 0], [0, 1, 1]],
                                       [("triangle", [[0, 1, 2]])]), "off the plane"),
        "non-finite point": (_write(d / "nan.msh", [[0, 0, 0], [1, 0, 0], [0, np.nan, 0]],
                                    [("triangle", [[0, 1, 2]])]), "non-finite"),
        "missing group": (_write(d / "nogroup.msh", SQUARE, [("triangle", TRIS)]),
                          "no group named"),
        "group of elements": (ok, "holds no facets"),
        "group inside the body": (_write(d / "inside.msh", interior, [("triangle", fan)],
                                         {"contact": ("line", [[0, 4]])}),
                                  "not on the boundary"),
    }
    specs = {name: (f"mesh_body[file={path}]", word) for name, (path, word) in files.items()}
    specs["group of elements"] = (f"mesh_body[file={ok},contact=body]", "holds no facets")
    specs.update({
        "through the obstacle": (f"mesh_body[file={ok},offset=0.5]", "through the obstacle"),
        "slanted normal": (f"mesh_body[file={ok},normal=0;1]", "general gap operator"),
        "negative normal": (f"mesh_body[file={ok},normal=-y]", "general gap operator"),
        "z normal in 2D": (f"mesh_body[file={ok},normal=+z]", "allowed: +x, +y"),
        "degree 2 on quads": (f"mesh_body[file={_write(d / 'quad.msh', SQUARE, [('quad', [[0, 1, 2, 3]])], BOTTOM)},degree=2]",  # noqa: E501
                              "no degree-2 element"),
        "nu of 1/2": (f"mesh_body[file={ok},nu=0.5]", "nu"),
        "negative lift": (f"mesh_body[file={ok},lift=-1]", "lift"),
        "zero modulus": (f"mesh_body[file={ok},young=0]", "young"),
    })
    return specs


def test_every_bad_mesh_or_parameter_is_one_line_and_exit_2(tmp_path: Path, capsys) -> None:
    bad = _bad_meshes(tmp_path)
    assert len(bad) >= 15
    for name, (spec, word) in bad.items():
        code = main(["run", "--case", spec, "--scheme", "nitsche", "--T", "1"])
        out = capsys.readouterr()
        assert code == 2, (name, out.out[-300:], out.err)
        lines = out.err.strip().splitlines()
        assert len(lines) == 1 and word in lines[0], (name, out.err)
    # the nx of a file's mesh: 2, 4, 8 ...
    code = main(["run", "--case", f"mesh_body[file={tmp_path / 'ok.msh'}]", "--scheme",
                 "nitsche", "--T", "1", "--nx", "3"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "allowed: 2, 4, 8" in err[0], err


# ------------------------------------------------------------------ the docs' examples

EXAMPLES = Path(__file__).resolve().parents[1] / "docs" / "examples"


def _example(name: str):
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_docs_disc_example_writes_and_reads_the_disc(tmp_path: Path) -> None:
    spec = _example("disc_to_msh").disc_to_msh(str(tmp_path / "disc.msh"), nx=2)
    a = run_one("disc_drop", "nitsche", nx=2, T=12.0, dt=0.02).row
    b = run_one(spec, "nitsche", T=12.0, dt=0.02, stride=1).row
    assert "peak_contact_force" in _same_columns(a, b)


def test_the_docs_gmsh_example_meshes_an_ellipse_that_runs(tmp_path: Path) -> None:
    pytest.importorskip("gmsh")
    out = _example("gmsh_ellipse").ellipse(str(tmp_path / "e.msh"), h=6.0, order=2)
    mf = read_mesh(out)
    assert mf.cell_type == "triangle6" and mf.order == 2
    bottom = boundary_group(mf, "contact")
    X = mf.mesh.doflocs
    nodes = np.unique(mf.mesh.facets[:, bottom])
    assert np.all(mf.mesh.p[1, nodes] <= 12.0 + 1e-9)  # the lower half of the boundary
    r = ((X[0] / 20.0) ** 2 + ((X[1] - 12.0) / 12.0) ** 2)  # every node in the ellipse,
    assert np.all(r <= 1 + 1e-9) and np.isclose(r.max(), 1.0)  # edge nodes on the curve
    for scheme in ("nitsche", "redistributed"):
        row = run_one(f"mesh_body[file={out},lift=0.5]", scheme, T=5.0).row
        assert row["status"] == "ok" and row["first_contact_start"] > 0


@pytest.mark.parametrize("kind", ["tetra10", "hexahedron", "quad", "triangle6"])
def test_gmsh_meshes_read_with_their_node_order(tmp_path: Path, kind: str) -> None:
    """Gmsh's own P2 tetrahedra, hexahedra, quadrilaterals and P2 triangles of a box (a
    rectangle): the body's measure is the box's, every P2 edge node is its edge's
    midpoint (a wrong node order would misplace them), the bottom group is the face
    z = 0 (y = 0), and the body runs."""
    gmsh = pytest.importorskip("gmsh")
    dim = 3 if kind in ("tetra10", "hexahedron") else 2
    out = str(tmp_path / f"{kind}.msh")
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        if dim == 3:
            occ.addBox(0, 0, 0, 2, 1, 1)
        else:
            occ.addRectangle(0, 0, 0, 2, 1)
        occ.synchronize()
        bottom = [t for d, t in gmsh.model.getEntities(dim - 1)
                  if abs(gmsh.model.occ.getCenterOfMass(d, t)[dim - 1]) < 1e-9]
        gmsh.model.addPhysicalGroup(dim - 1, bottom, name="contact")
        gmsh.model.addPhysicalGroup(dim, [1], name="body")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.4)
        if kind in ("hexahedron", "quad"):
            gmsh.model.mesh.setTransfiniteAutomatic()
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.model.mesh.generate(dim)
        if kind in ("tetra10", "triangle6"):
            gmsh.model.mesh.setOrder(2)
        gmsh.write(out)
    finally:
        gmsh.finalize()
    mf = read_mesh(out)
    assert mf.cell_type == kind
    import skfem as fe

    m = mf.mesh
    elem = {"tetra10": fe.ElementTetP2, "hexahedron": fe.ElementHex1,
            "quad": fe.ElementQuad1, "triangle6": fe.ElementTriP2}[kind]()
    volume = fe.Functional(lambda w: 1.0 + 0.0 * w.x[0]).assemble(fe.Basis(m, elem))
    assert np.isclose(volume, 2.0)
    if mf.order == 2:
        edges = m.edges if dim == 3 else m.facets
        mid = 0.5 * (m.p[:, edges[0]] + m.p[:, edges[1]])
        assert np.allclose(m.doflocs[:, m.nvertices:m.nvertices + edges.shape[1]], mid)
    group = boundary_group(mf, "contact")
    assert np.allclose(m.p[dim - 1, np.unique(m.facets[:, group])], 0.0)
    one = fe.Functional(lambda w: 1.0 + 0.0 * w.x[0])
    assert np.isclose(one.assemble(fe.FacetBasis(m, elem, facets=group)), 2.0)
    row = run_one(f"mesh_body[file={out},lift=0.01,speed=0.5,young=100]", "nitsche", T=0.3,
                  dt=1e-3).row
    assert row["status"] == "ok" and row["first_contact_start"] > 0


def test_a_changed_mesh_file_runs_again_in_a_cached_sweep(tmp_path: Path) -> None:
    from contact_bench.sweeps.cache import Cache
    from contact_bench.sweeps.sweep import Task, run_sweep

    path = tmp_path / "body.msh"
    _write(path, SQUARE, [("triangle", TRIS)], BOTTOM)
    tasks = [Task(f"mesh_body[file={path},lift=0.01,speed=0.5]", "nitsche", T=0.1,
                  dt=1e-3)]
    cache = Cache(tmp_path / "cache")
    first = run_sweep(tasks, cache=cache, repeats=0, quiet=True).table
    again = run_sweep(tasks, cache=cache, repeats=0, quiet=True).table
    _write(path, SQUARE, [("triangle", [[0, 1, 3], [1, 2, 3]])], BOTTOM)  # other diagonal
    changed = run_sweep(tasks, cache=cache, repeats=0, quiet=True).table
    assert not first["from_cache"].iloc[0] and again["from_cache"].iloc[0]
    assert not changed["from_cache"].iloc[0]


def test_a_vtu_without_groups_takes_the_facets_facing_the_obstacle(tmp_path: Path) -> None:
    """The disc as a VTU file (no named groups): contact=@facing picks the boundary
    facets whose outward normal points down, the disc's own zone (its lower half)."""
    disc = make_case("disc_drop[degree=1]")
    nx = 3
    m = disc.mesh(nx)
    path = tmp_path / "disc.vtu"
    write_msh(m, tmp_path / "disc.msh")
    meshio.write(path, meshio.read(tmp_path / "disc.msh"))
    mine = make_case(f"mesh_body[file={path},contact=@facing,degree=1,"
                     f"h_contact={disc.R / nx!r}]")
    zone = disc.body(nx).boundary_facets(lambda x: x[1] < disc.centre_y - 0.01 * disc.R)
    assert np.array_equal(mine.facets, np.sort(zone))
    a = run_one(disc, make_scheme("nitsche"), nx=nx, T=12.0, dt=0.02, stride=1).row
    b = run_one(mine, make_scheme("nitsche"), T=12.0, dt=0.02, stride=1).row
    assert "peak_contact_force" in _same_columns(a, b)
    with pytest.raises(Exception, match="no group named 'contact'"):
        make_case(f"mesh_body[file={path}]")
