"""The ball at any nx (`sphere_drop[ball=lattice]`): a conforming tetrahedral ball whose
counts, boundary and volume are checked against independent facts (the sphere, the
refined octahedron of scikit-fem at nx 2, the ball's volume)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import skfem as fe

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.cases.sphere_drop import lattice_ball
from contact_bench.harness import runner


def _volumes(m: fe.MeshTet) -> np.ndarray:
    a, b, c, d = (m.p[:, m.t[i]] for i in range(4))
    return np.einsum("ij,ij->j", b - a, np.cross(c - a, d - a, axis=0)) / 6.0


@pytest.mark.parametrize("n", [1, 2, 3, 5, 6])
def test_counts_boundary_and_orientation(n: int) -> None:
    m = lattice_ball(n)
    assert m.nelements == 8 * n**3
    assert m.nvertices == (2 * n + 1) * (2 * n * n + 2 * n + 3) // 3
    assert m.boundary_facets().size == 8 * n * n  # no unmatched face between octants
    on = m.boundary_nodes()
    np.testing.assert_allclose(np.linalg.norm(m.p[:, on], axis=0), 1.0, rtol=1e-14)
    inner = np.setdiff1d(np.arange(m.nvertices), on)
    assert np.all(np.linalg.norm(m.p[:, inner], axis=0) < 1.0 - 1e-3)
    assert np.all(_volumes(m) > 0.0)


def test_nx_2_has_the_refined_octahedrons_points() -> None:
    mine, skfem = lattice_ball(2), fe.MeshTet.init_ball(1)
    key = lambda p: sorted(map(tuple, np.round(p.T, 12)))  # noqa: E731
    assert key(mine.p) == key(skfem.p)


def test_volume_converges_to_the_balls() -> None:
    err = [abs(_volumes(lattice_ball(n)).sum() - 4.0 / 3.0 * math.pi) for n in (3, 6, 12)]
    assert err[0] > err[1] > err[2]
    assert err[1] / err[2] > 3.0  # second order: flat faces on a sphere


def test_the_scene_takes_any_nx_and_runs() -> None:
    case = make_case("sphere_drop[ball=lattice,lift=0.1]")
    problem = case.sparse_problem(6, 1.0, "redistributed")
    assert problem.U0.size == case.footprint(6).unknowns
    run = runner.run_one(case, make_scheme("redistributed"), 6, 0.05, 2.0, 10)
    assert run.row["status"] == "ok", run.row["notes"]
    with pytest.raises(ValueError, match="ball=lattice"):
        make_case("sphere_drop").mesh(6)
