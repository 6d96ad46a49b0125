"""A scene's numerical reference is computed once by the harness, kept on disk, read
back by the next runs (not computed again), and its cost is reported apart (`ref_s`,
`ref_compute_s`); it keeps only the dofs its norms read."""

from __future__ import annotations

import numpy as np
import pytest

from contact_bench.api.registry import make_case
from contact_bench.harness import reference_cache
from contact_bench.harness.runner import TIMING_COLUMNS, run_one

CASE = "disc_drop[degree=1,lift=0.5]"  # the impact at t = 3.16
RUN = dict(nx=3, T=5.0)


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("CONTACT_BENCH_REFERENCE_CACHE", str(tmp_path / "refs"))
    reference_cache.forget()
    yield tmp_path / "refs"
    reference_cache.forget()


def _errors(row: dict) -> dict:
    return {k: v for k, v in row.items() if k.startswith("err_") and v is not None}


def test_reference_computed_once_and_read_back(cache_dir):
    before = len(reference_cache.computed)
    first = run_one(CASE, "redistributed", **RUN).row
    assert len(reference_cache.computed) == before + 1  # computed by this run
    assert len(list(cache_dir.glob("*/*.npz"))) == 1  # and stored
    assert first["ref_compute_s"] > 0 and first["ref_s"] >= first["ref_compute_s"] * 0.5
    assert first["ref_from_cache"] is False and "numerical reference: " in first["notes"]
    # another scheme, same mesh and steps: the same reference, from memory
    other = run_one(CASE, "standard", **RUN).row
    assert len(reference_cache.computed) == before + 1
    assert other["ref_compute_s"] == first["ref_compute_s"]
    # a new process (nothing in memory): read back from the disk, not computed again
    reference_cache.forget()
    again = run_one(CASE, "redistributed", **RUN).row
    assert len(reference_cache.computed) == before + 1
    assert again["ref_from_cache"] is True and again["notes"] == first["notes"]
    assert again["ref_compute_s"] == first["ref_compute_s"]  # the stored cost
    assert again["ref_s"] < first["ref_compute_s"]
    assert _errors(again) == _errors(first) and "err_u_numerical" in _errors(first)
    assert {"ref_s", "ref_compute_s", "ref_from_cache"} <= set(TIMING_COLUMNS)


def test_another_request_or_damaged_entry_is_computed(cache_dir):
    before = len(reference_cache.computed)
    run_one(CASE, "redistributed", **RUN)
    run_one(CASE, "redistributed", nx=3, T=4.0)  # other steps: another reference
    assert len(reference_cache.computed) == before + 2
    for path in cache_dir.glob("*/*.npz"):
        path.write_bytes(b"not an npz")
    reference_cache.forget()
    row = run_one(CASE, "redistributed", **RUN).row
    assert len(reference_cache.computed) == before + 3 and "err_u_numerical" in _errors(row)


def test_reference_keeps_only_what_the_norms_read(cache_dir):
    case = make_case(CASE)
    request = case.reference_run(3, 0.01, 5.0, 1)
    ref = reference_cache.reference_samples(case, request)
    nv = case.mesh(3).nvertices
    assert ref.U.shape == (501, 2 * nv)  # the coarse vertices, not the fine mesh's dofs
    assert ref.ndofs > 2 * nv
    # the kept columns and the largest |U| are those of the full fine run, bit for bit
    from contact_bench.api.registry import make_scheme

    scheme = make_scheme(request.scheme)
    p = case.sparse_problem(request.nx, 1.0, scheme.mass_kind())
    full = scheme.integrate(p, request.dt, request.nsteps, request.stride)
    assert np.array_equal(full.U[:, request.keep], ref.U)
    assert np.array_equal(np.max(np.abs(full.U), axis=1), ref.U_absmax)
    assert np.array_equal(full.stress, ref.stress) and np.array_equal(full.t, ref.t)


def test_default_cache_folder_is_outside_the_repository(monkeypatch, tmp_path):
    monkeypatch.delenv("CONTACT_BENCH_REFERENCE_CACHE", raising=False)
    monkeypatch.delenv("CONTACT_BENCH_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert reference_cache.reference_cache_dir() == tmp_path / "contact-bench" / "references"
    monkeypatch.setenv("CONTACT_BENCH_REFERENCE_CACHE", "off")
    assert reference_cache.reference_cache_dir() is None
