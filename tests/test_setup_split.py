"""`setup_s` split (issue 48, item 3): the factorisations and the contact operators timed
where they happen (`contact_bench.core.timers`), the problem's building as `assembly_s`."""

from __future__ import annotations

import itertools

import pytest

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core import timers
from contact_bench.harness.runner import problem_for, run_one


def test_phases_are_exclusive_and_only_while_recording(monkeypatch) -> None:
    clock = itertools.count()  # one tick per reading of the clock
    monkeypatch.setattr(timers.time, "perf_counter", lambda: float(next(clock)))

    @timers.phase("factor")
    def factor() -> None:
        next(clock)  # 1 tick inside, 2 between its two readings

    @timers.phase("contact")
    def contact() -> None:
        factor()  # its 2 ticks count as factor's, not contact's
        next(clock)

    factor()  # no recording: nothing counted, no clock read
    with timers.recording() as spent:
        contact()
        factor()
    assert spent == {"factor": 4.0, "contact": 3.0}  # contact: 5 ticks, 2 of factor's


@pytest.mark.parametrize("scheme,factored", [("redistributed", True),
                                             ("taylor_flanagan[mass=lumped]", False)])
def test_a_run_splits_its_setup(scheme: str, factored: bool) -> None:
    case = "disc_drop[degree=1,lift=0.5]"
    for _ in range(2):  # the second preparation: no JIT compilation in setup_s
        row = run_one(case, scheme, nx=3, T=0.5).row
    assert row["status"] == "ok", row["notes"]
    assert row["assembly_s"] > 0.0
    assert (row["setup_factor_s"] > 0.0) == factored
    assert (row["setup_contact_s"] > 0.0) == factored  # the lumped one: a diagonal W
    assert row["setup_factor_s"] + row["setup_contact_s"] <= row["setup_s"] * 1.05 + 1e-3


def test_the_assembly_time_is_a_field_of_the_problem_built() -> None:
    """The harness's problems carry their building time in their own field (a body's: a
    copy; the scene's own problem, which it may keep, is left as the scene built it)."""
    case, scheme = make_case("disc_drop[degree=1,lift=0.5]"), make_scheme("redistributed")
    assert problem_for(case, scheme, 3, keep=False).assembly_s > 0.0
    assert case.sparse_problem(3, 1.0, scheme.mass_kind()).assembly_s is None
    assert problem_for(make_case("dropped_bar"), scheme, 10, keep=False).assembly_s > 0.0
