"""benchmarks/getfem_side_by_side.py without GetFEM: the one-line skip, the mesh export in
GetFEM's GT_PK(2,2) order, the reading of GetFEM's mesh export, and the contact intervals
of a force history."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from contact_bench.api.registry import make_case

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "getfem_side_by_side.py"


def _module():
    spec = importlib.util.spec_from_file_location("getfem_side_by_side", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_skipped_in_one_line_without_getfem():
    env = dict(os.environ, GETFEM_PYTHON=sys.executable)  # the venv has no getfem
    out = subprocess.run([sys.executable, str(SCRIPT), "--T", "0.1"], capture_output=True,
                         text=True, env=env, timeout=300)
    assert out.returncode == 0
    lines = out.stdout.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("skipped: GetFEM is absent")


def test_mesh_export_order(tmp_path):
    mod = _module()
    case = make_case("disc_drop")
    path = tmp_path / "mesh.npz"
    mod.export_mesh(case, 3, str(path))
    nodes = np.load(path)["nodes"]  # (2, 6, elements): v0, m01, v1, m02, m12, v2
    assert nodes.shape == (2, 6, 54)
    v0, m01, v1, m02, m12, v2 = (nodes[:, k] for k in range(6))
    for a, m, b in ((v0, m01, v1), (v0, m02, v2), (v1, m12, v2)):
        chord = (a + b) / 2
        r = np.linalg.norm(m - np.array([[0.0], [20.0]]), axis=0)
        # a midpoint is the chord's, or (on the boundary) on the circle near it
        straight = np.linalg.norm(m - chord, axis=0) < 1e-12
        assert np.all(straight | (np.abs(r - 20.0) < 1e-12))
        assert np.all(np.linalg.norm(m - chord, axis=0) < 0.1 * np.linalg.norm(b - a, axis=0))


def test_contact_intervals():
    mod = _module()
    R = np.array([0, 0, 1, 2, 0, 0, 3, 0])
    assert mod.intervals(R, 0.5, 0.1) == [(1.0, 1.5), (3.0, 3.0)]
    assert mod.intervals(np.zeros(4), 0.5, 0.1) == []


def test_read_getfem_mesh_rebuilds_the_quadratic_mesh(tmp_path):
    """The ring mesh written as GetFEM exports a mesh file (points, GT_PK(2,2) cells) and
    read back: the same P2 geometry, so the same mass and stiffness energy."""
    mod = _module()
    case = make_case("disc_drop")
    path = tmp_path / "mesh.npz"
    mod.export_mesh(case, 2, str(path))
    nodes = np.load(path)["nodes"]  # (2, 6, elements)
    flat = nodes.transpose(2, 1, 0).reshape(-1, 2)
    points, cells = np.unique(np.round(flat, 12), axis=0, return_inverse=True)
    np.savez(tmp_path / "gf.npz", points=points.T, cells=cells.reshape(-1, 6),
             geotrans="GT_PK(2,2)", contact_faces=0)
    mesh = mod.read_getfem_mesh(str(tmp_path / "gf.npz"))
    ours = case.mesh(2)
    assert mesh.t.shape == ours.t.shape and mesh.doflocs.shape == ours.doflocs.shape
    a = mod.on_mesh(case, mesh).sparse_problem(2, 1.0, "consistent")
    b = case.sparse_problem(2, 1.0, "consistent")
    assert abs(a.body_mass - b.body_mass) < 1e-9 * b.body_mass
    Pa = mesh.doflocs.T  # the same energy of a field of the coordinates
    fa = np.ravel(np.stack([Pa[:, 1] ** 2, Pa[:, 0] * Pa[:, 1]], axis=1))
    Pb = ours.doflocs.T
    fb = np.ravel(np.stack([Pb[:, 1] ** 2, Pb[:, 0] * Pb[:, 1]], axis=1))
    assert abs(fa @ a.K @ fa - fb @ b.K @ fb) < 1e-9 * (fb @ b.K @ fb)
    assert len(a.contact.dofs) == len(b.contact.dofs)
