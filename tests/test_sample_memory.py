"""What a run keeps grows with the mesh and the number of samples, not with the number
of steps: a stride-s run stores n_samples states; a kept selection stores only its dofs;
the explicit paths run past the dense response matrix's limit (`KEEP_Z_ENTRIES`)
without an n x n_c array, matrix-free, with the same trajectory up to round-off."""

from __future__ import annotations

import numpy as np
import pytest

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core.sampling import n_samples
from contact_bench.kernels import sparse_explicit
from contact_bench.kernels.stepper import run_keeping

CASE = "disc_drop[degree=1]"


def _stepper(scheme: str, nx: int = 3, dt: float = 0.01):
    sch = make_scheme(scheme)
    p = make_case(CASE).sparse_problem(nx, 1.0, sch.mass_kind())
    return p, sch.prepare(p, dt)


def test_stride_run_stores_n_samples_states():
    p, stepper = _stepper("redistributed")
    sizes = []
    for nsteps, stride in ((200, 20), (800, 80)):  # 4x the steps, the same samples
        tr = stepper.run(nsteps, stride)
        assert tr.U.shape == tr.V.shape == (n_samples(nsteps, stride), p.nfree) == (11, p.nfree)
        sizes.append(tr.U.nbytes + tr.V.nbytes)
    assert sizes[0] == sizes[1] == 2 * 11 * p.nfree * 8


def test_kept_selection_stores_only_its_dofs():
    p, stepper = _stepper("redistributed")
    keep = np.array([1, 5, 7], np.int64)
    full = stepper.run(300, 3)
    kept = run_keeping(stepper, 300, 3, keep)
    assert kept.U.shape == (101, 3) and kept.V.shape == (101, 0)
    assert np.array_equal(kept.U, full.U[:, keep])
    assert np.array_equal(kept.extra["U_absmax"], np.max(np.abs(full.U), axis=1))
    assert np.array_equal(kept.extra["V_absmax"], np.max(np.abs(full.V), axis=1))
    assert np.array_equal(kept.energy, full.energy) and np.array_equal(kept.stress, full.stress)


@pytest.mark.parametrize("scheme", ["taylor_flanagan", "penalty[beta=0,mass=getfem]"])
def test_explicit_paths_run_past_the_dense_limit(scheme, monkeypatch):
    p, dense = _stepper(scheme, nx=3)
    nc = np.asarray(p.contact.dofs).size
    ref = dense.run(1400, 10)
    monkeypatch.setattr(sparse_explicit, "KEEP_Z_ENTRIES", 0)  # every Z over the limit
    _, free = _stepper(scheme, nx=3)
    big = [a.shape for a in free.ops
           if isinstance(a, np.ndarray) and a.ndim == 2 and a.size >= p.nfree * nc // 2]
    assert big == []  # no n x n_c (nor n_m x n_c) array kept
    tr = free.run(1400, 10)
    assert tr.steps_done == 1400 and np.max(-tr.stress) > 0  # it hit the plane
    scale = np.max(np.abs(ref.U))
    assert np.max(np.abs(tr.U - ref.U)) <= 1e-9 * scale
    assert np.max(np.abs(tr.stress - ref.stress)) <= 1e-7 * np.max(np.abs(ref.stress))
