"""The time integrator's own error (`--time-error K`): a run against the same scheme,
mesh and mass at dt / K, computed once as a cached reference; it decreases at the
scheme's order where the error against the scene's reference is the mesh's."""

from __future__ import annotations

import math

import pytest

from contact_bench.harness import reference_cache
from contact_bench.harness.runner import run_one


@pytest.fixture(autouse=True)
def cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("CONTACT_BENCH_REFERENCE_CACHE", str(tmp_path / "refs"))
    reference_cache.forget()
    yield
    reference_cache.forget()


def test_time_error_converges_where_the_total_error_does_not():
    rows = [run_one("disc_drop[degree=1,lift=0.5]", "redistributed", nx=3, T=5.0, dt=dt,
                    time_error=16).row for dt in (0.02, 0.01)]
    coarse, fine = rows
    # second order in time (the fine run's own error is 1/256 of the run's)
    assert math.log2(coarse["err_time_u"] / fine["err_time_u"]) > 1.5
    assert math.log2(coarse["err_time_stress"] / fine["err_time_stress"]) > 1.0
    # the total error is the mesh's: far above the time error, and flat
    assert fine["err_u_numerical"] > 100 * fine["err_time_u"]
    assert fine["err_u_numerical"] == pytest.approx(coarse["err_u_numerical"], rel=0.01)
    assert fine["time_ref_compute_s"] > 0 and "time error against" in fine["notes"]


def test_time_reference_is_cached_and_works_on_the_bar():
    before = len(reference_cache.computed)
    a = run_one("clamped_bar", "standard", nx=20, T=1.0, dt=0.01, time_error=8).row
    reference_cache.forget()
    b = run_one("clamped_bar", "standard", nx=20, T=1.0, dt=0.01, time_error=8).row
    assert len(reference_cache.computed) == before + 1  # the second read it back
    assert a["err_time_u"] == b["err_time_u"] and 0 < a["err_time_u"] < a["err_u_linf_l2"]
    assert b["notes"] == a["notes"] and b["time_ref_compute_s"] == a["time_ref_compute_s"]
    plain = run_one("clamped_bar", "standard", nx=20, T=1.0, dt=0.01).row
    assert plain.get("err_time_u") is None  # opt-in


@pytest.mark.parametrize("bad", ["0", "-1", "1", "1.5", "abc", ""])
def test_time_error_refuses_what_is_not_an_integer_of_two_or_more(bad, capsys):
    from contact_bench.cli.main import main

    code = main(["run", "--case", "clamped_bar", "--scheme", "standard", "--nx", "4",
                 "--T", "0.1", "--time-error", bad, "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "--time-error must be an integer >= 2" in err
    assert (repr(bad) if bad not in ("0", "-1", "1") else f"got {bad}") in err or not bad
