"""Stepping timed apart from recording: `step_s` (the stepping alone) next to `run_s`
(the run with its recording, `wall_s` its former name), and work-precision on `step_s`."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from numba import njit

from contact_bench.harness import runner
from contact_bench.harness.runner import TIMING_COLUMNS, run_one, step_time
from contact_bench.sweeps.analysis import WP_TIME, work_precision


def test_a_run_records_step_s_setup_s_and_run_s():
    row = run_one("clamped_bar", "redistributed", 20, T=1.0).row
    assert row["status"] == "ok"
    assert row["run_s"] == row["wall_s"] > 0
    assert math.isfinite(row["step_s"]) and row["step_s"] > 0
    assert math.isfinite(row["setup_s"]) and row["setup_s"] >= 0
    assert {"step_s", "setup_s", "run_s", "wall_s"} <= set(runner.BASE_COLUMNS)
    assert {"step_s", "setup_s", "run_s", "wall_s"} <= set(TIMING_COLUMNS)


class _Counting:
    """A stand-in stepper that records the (steps, stride) of every run call."""

    def __init__(self) -> None:
        self.calls: list[tuple[int, int]] = []

    def run(self, steps, stride):
        self.calls.append((steps, stride))


def test_step_time_samples_only_the_last_step_after_a_warm_up():
    s = _Counting()
    assert step_time(s.run, 50, repeats=3) >= 0.0
    assert s.calls == [(50, 50)] * 4  # warm-up + 3 timed, stride = steps
    s = _Counting()
    step_time(s.run, 50, repeats=3, budget_s=-1.0)  # a long warm-up is it
    assert s.calls == [(50, 50)]
    assert step_time(_Counting().run, 0) is None


class _Compiling(_Counting):
    """A stand-in whose first call compiles a numba function (a kernel form that the
    scheme's warm-up did not reach)."""

    def __init__(self) -> None:
        super().__init__()
        self.kernel = njit(lambda x: x + 1.0)  # not compiled yet

    def run(self, steps, stride):
        self.kernel(1.0)
        super().run(steps, stride)


def test_a_warm_up_that_compiled_is_not_the_timing():
    s = _Compiling()
    step_time(s.run, 50, repeats=3, budget_s=-1.0)
    assert len(s.calls) == 2  # the compiling call is discarded, one timed call follows


def test_work_precision_front_is_over_step_s_and_keeps_time_s():
    # b is faster than a in recording time (time_s) but slower in stepping (step_s)
    df = pd.DataFrame({
        "case": ["c"] * 2, "scheme": ["a", "b"], "nx": [10, 10], "dt": [0.1, 0.1],
        "cfl": [0.5, 0.5], "status": ["ok", "ok"], "err_u_linf_l2": [0.1, 0.2],
        "step_s": [1.0, 2.0], "time_s": [5.0, 3.0]})
    wp = work_precision(df)
    assert WP_TIME == "step_s" and {"step_s", "time_s"} <= set(wp.columns)
    front = dict(zip(wp["scheme"], wp["pareto"], strict=True))
    assert front == {"a": True, "b": False}  # over time_s, b would be on the front too
    old = work_precision(df.drop(columns=["step_s"]))  # a table from before step_s
    assert old.empty and np.isin(["step_s", "time_s"], old.columns).all()


def test_a_run_prepares_its_stepper_once_and_times_the_set_up_apart():
    """`run_one` calls `Scheme.prepare` once: the warm-up, the timing repeats and the
    recorded run share the stepper; `setup_s` is the preparation, `step_s` the stepping."""
    from contact_bench.api import CallStepper, make_scheme

    inner = make_scheme("redistributed")
    calls = {"prepare": 0, "run": 0}

    class Counting(type(inner)):
        def prepare(self, problem, dt):
            calls["prepare"] += 1
            import time

            time.sleep(0.05)  # a set-up that step_s must not see
            stepper = super().prepare(problem, dt)

            def run(nsteps, stride):
                calls["run"] += 1
                return stepper.run(nsteps, stride)

            return CallStepper(run)

    row = run_one("clamped_bar", Counting(), 20, T=1.0).row
    assert row["status"] == "ok"
    assert calls["prepare"] == 1 and calls["run"] >= 3  # warm-up or timing, and recorded
    assert row["setup_s"] >= 0.05 and row["step_s"] < 0.05
