"""Error norms over a trajectory's samples read them block by block
(`contact_bench.api.sparse.sample_blocks`), so that their temporaries stay a block's size:
the blocks cover every sample once, and the disc's and the ball's errors are the same
numbers whatever the block size."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from contact_bench.api import sparse
from contact_bench.api.registry import make_case, make_scheme
from contact_bench.api.sparse import sample_blocks


@pytest.mark.parametrize("samples,width", [(0, 5), (1, 5), (7, 3), (1000, 4_000_001)])
def test_blocks_cover_every_sample_once(samples, width):
    blocks = sample_blocks(samples, width)
    covered = [i for b in blocks for i in range(samples)[b]]
    assert covered == list(range(samples))
    assert all((b.stop - b.start) * width <= max(sparse.SAMPLE_BLOCK_VALUES, width)
               for b in blocks)


@pytest.mark.parametrize("spec,nx,T", [("disc_drop[degree=1,lift=0.5]", 3, 5.0),
                                        ("sphere_drop[lift=0.1]", 8, 2.0)])
def test_errors_do_not_depend_on_the_block_size(monkeypatch, spec, nx, T):
    case = make_case(spec)
    scheme = make_scheme("penalty")
    problem = case.sparse_problem(nx, 1.0, scheme.mass_kind())
    dt = case.dt
    traj = scheme.integrate(problem, dt, int(round(T / dt)), 1)
    row = {"dt": dt, "nx": nx, "stride": 1}
    kw = {}
    if case.name == "disc_drop":  # a stand-in for its numerical reference: the run, perturbed
        nv = case.mesh(nx).nvertices
        cols = np.ravel(np.stack([2 * np.arange(nv), 2 * np.arange(nv) + 1], axis=1))
        U = traj.U[:, cols] * (1.0 + 1e-3 * np.sin(np.arange(cols.size)))
        kw["reference"] = SimpleNamespace(t=traj.t, U=U, U_absmax=np.abs(traj.U).max(axis=1),
                                          stress=traj.stress, contact_measure=1.0)
    whole = case.quantity_errors(problem, traj, row, **kw)
    monkeypatch.setattr(sparse, "SAMPLE_BLOCK_VALUES", 7)  # a few samples a block
    assert len(sample_blocks(traj.t.size, problem.U0.size)) > 10
    assert case.quantity_errors(problem, traj, row, **kw) == whole
    assert "err_free_fall" in whole
    assert ("err_u_numerical" in whole) == (case.name == "disc_drop")
