"""A body run's fields for ParaView and its pictures: the VTU series hold the run's
samples, the von Mises stress of a uniform strain is its closed form, and the snapshot
figure and movie are written with the results."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from contact_bench.api.registry import make_case
from contact_bench.cli.main import main
from contact_bench.harness.runner import run_one
from contact_bench.output.fields import body_fields, read_series
from contact_bench.output.pictures import first_contact

DISC = ["--case", "disc_drop", "--scheme", "nitsche", "--nx", "2", "--T", "14", "--dt",
        "0.02", "--stride", "50"]


@pytest.fixture(scope="module")
def disc_fields(tmp_path_factory) -> tuple[Path, object]:
    folder = tmp_path_factory.mktemp("fields")
    assert main(["run", *DISC, "--fields", str(folder / "f"), "--format", "csv"]) == 0
    run = run_one("disc_drop", "nitsche", nx=2, T=14.0, dt=0.02, stride=50)
    return folder / "f" / "disc_drop__nitsche.pvd", run


def test_the_fields_hold_the_runs_samples(disc_fields) -> None:
    pvd, run = disc_fields
    tr = run.trajectory
    times, meshes = read_series(pvd)
    assert np.array_equal(times, tr.t) and len(meshes) == tr.t.size == 15
    case = make_case("disc_drop")
    fields = body_fields(case.body(2), run.problem)
    nv = case.mesh(2).nvertices  # the P2 mesh's edge nodes are left out
    for k, m in enumerate(meshes):
        pd = m.point_data
        assert m.points.shape == (nv, 3)
        assert pd["displacement"].shape == pd["velocity"].shape == (nv, 3)
        assert pd["von_mises"].shape == pd["contact_pressure"].shape == (nv,)
        # vertex v's dofs are 2 v, 2 v + 1 (scikit-fem numbers the vertices first)
        assert np.array_equal(pd["displacement"][:, :2], tr.U[k].reshape(-1, 2)[:nv])
        assert np.array_equal(pd["velocity"][:, :2], tr.V[k].reshape(-1, 2)[:nv])
        assert np.all(pd["displacement"][:, 2] == 0.0)
        assert np.allclose(pd["von_mises"], fields.von_mises(tr.U[k])[0])
    before = tr.t < make_case("disc_drop").impact_time
    for k in np.flatnonzero(before):  # the free fall is a rigid motion: no stress
        assert np.max(meshes[k].point_data["von_mises"]) < 1e-8
        assert np.max(np.abs(meshes[k].point_data["contact_pressure"])) < 1e-8
    assert np.max(meshes[-1].point_data["contact_pressure"]) > 0  # in contact at the end


def test_the_fields_open_in_pyvista(disc_fields) -> None:
    pv = pytest.importorskip("pyvista")
    pvd, run = disc_fields
    reader = pv.get_reader(str(pvd))
    assert len(reader.time_values) == run.trajectory.t.size
    reader.set_active_time_point(len(reader.time_values) - 1)
    grid = reader.read()[0]
    assert grid.point_data["displacement"].shape[1] == 3


@pytest.mark.parametrize("spec", ["disc_drop[degree=1]", "disc_drop",
                                  "mesh_body[degree=1]"])
def test_von_mises_of_a_uniform_strain_is_2_mu_a(spec: str) -> None:
    """u = (a x, 0) in plane strain: sigma_xx - sigma_yy = sigma_xx - sigma_zz = 2 mu a,
    no shear: von Mises 2 mu a at every vertex of a straight-sided element."""
    case = make_case(spec)
    nx = 2
    body = case.body(nx)
    fields = body_fields(body, case.sparse_problem(nx, 1.0, "consistent"))
    U = np.zeros(body.ndofs)
    U[0::2] = 1e-3 * body.dof_coordinates[0]
    vm = fields.von_mises(U)[0]
    exact = 2 * body.mu * 1e-3
    if spec == "disc_drop[degree=1]":  # P1 on the disc's curved P2 geometry: the
        inner = np.linalg.norm(fields.points - [0, 20], axis=1) < 15  # inner elements
        vm = vm[inner]  # are straight
    assert np.allclose(vm, exact, rtol=1e-10), (vm.min(), vm.max(), exact)


def test_first_contact_finds_start_peak_release() -> None:
    f = np.array([0, 0, 1, 3, 2, 0, 0, 4, 0.0])
    assert first_contact(f) == (2, 3, 5)
    assert first_contact(np.zeros(4)) is None
    assert first_contact(np.array([0, 1, 2.0])) == (1, 2, 2)


def test_snapshots_and_movie_are_written_with_the_results(tmp_path: Path, capsys) -> None:
    pytest.importorskip("imageio")
    out = tmp_path / "out"
    code = main(["run", "--case", "mesh_body[lift=0.5]", "--scheme", "nitsche", "--T", "12",
                 "--out", str(out), "--movie", "gif", "--quiet"])
    assert code == 0, capsys.readouterr().err
    stem = "mesh_body_lift-0.5__nitsche"
    assert (out / f"snapshots_{stem}.png").stat().st_size > 10_000
    import imageio.v2 as imageio

    frames = imageio.mimread(out / f"movie_{stem}.gif")
    assert len(frames) == 120 and frames[0].ndim == 3


def test_movie_needs_out_and_a_writer(tmp_path: Path, capsys) -> None:
    assert main(["run", *DISC, "--movie", "gif"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--movie needs --out" in err[0]
    try:
        import imageio_ffmpeg  # noqa: F401
    except ImportError:
        assert main(["run", *DISC, "--movie", "mp4", "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "imageio-ffmpeg" in err[0]
        assert not (tmp_path / "o").exists()
