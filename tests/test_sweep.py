"""Sweeps, the run cache, order fitting and the report (tiny grids, a few seconds each)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.cli.main import main
from contact_bench.output.report import write_tables
from contact_bench.sweeps import sweep
from contact_bench.sweeps.analysis import convergence_table, fit_order, pareto_mask
from contact_bench.sweeps.cache import Cache
from contact_bench.sweeps.study import plan_study
from contact_bench.sweeps.sweep import (
    VOLATILE_COLUMNS,
    classify,
    load_table,
    next_free,
    plan,
    run_sweep,
    save_table,
    shared_work,
    time_run,
)
from contact_bench.sweeps.time_order import time_order_table

# 12 runs of a fraction of a second: two schemes (one explicit, blowing up at CFL 1)
GRID = dict(cases=["clamped_bar"], schemes=["standard", "redistributed[beta=[0.25,0]]"],
            nxs=[8, 16], cfls=[0.5, 1.0], T=3.0)


def _metrics(df: pd.DataFrame) -> pd.DataFrame:
    return df.drop(columns=list(VOLATILE_COLUMNS), errors="ignore").reset_index(drop=True)


def test_parallel_and_dask_give_the_serial_table():
    pytest.importorskip("distributed")
    tasks = plan(**GRID)
    serial = run_sweep(tasks, jobs=1, repeats=0, quiet=True)
    assert len(serial.table) == 12 and serial.executed == 12
    assert set(serial.table["status"]) == {"ok", "unstable"}
    blown = serial.table[serial.table["status"] == "unstable"]
    assert (blown["scheme"] == "redistributed[beta=0]").all()
    assert blown["blowup_time"].notna().all() and (blown["stability"] == "blown up").all()
    pool = run_sweep(tasks, jobs=2, repeats=0, quiet=True)
    dask = run_sweep(tasks, jobs=2, dask="local", repeats=0, quiet=True)
    pd.testing.assert_frame_equal(_metrics(serial.table), _metrics(pool.table))
    pd.testing.assert_frame_equal(_metrics(serial.table), _metrics(dask.table))
    env = serial.table.filter(like="env_").iloc[0]
    assert env["env_numpy"] and env["env_cpu"] and env["env_git"]


def test_a_run_waits_while_another_makes_the_work_it_shares():
    shared = {"a1": (("k", "A"),), "a2": (("k", "A"),), "b1": (("k", "B"), ("r", 1)),
              "b2": (("k", "B"), ("r", 1)), "c": ()}
    started, ready = {("k", "A")}, set()  # a1 runs, compiling A
    assert next_free(["a2", "b1", "b2"], shared, started, ready) == 1  # b1 makes B and r
    started |= {("k", "B"), ("r", 1)}
    assert next_free(["a2", "b2"], shared, started, ready) is None  # both wait
    assert next_free(["a2", "b2", "c"], shared, started, ready) == 2
    ready.add(("k", "A"))  # a1 done
    assert next_free(["a2", "b2"], shared, started, ready) == 0
    ready.add(("k", "B"))  # b2 still waits for the reference
    assert next_free(["b2"], shared, started, ready) is None
    ready.add(("r", 1))
    assert next_free(["b2"], shared, started, ready) == 0


def test_shared_work_is_the_kernels_and_the_scenes_numerical_reference():
    disc = make_case("disc_drop[degree=1]")
    a, b = make_scheme("standard"), make_scheme("nitsche")
    inputs = {"case": disc.spec, "nx": 5, "cfl": 0.1, "dt": None, "T": 30.0, "stride": 1,
              "max_samples": 500, "grading": 1.0}
    sa = shared_work(disc, a, dict(inputs, scheme=a.spec))
    sb = shared_work(disc, b, dict(inputs, scheme=b.spec))
    assert sa[0] != sb[0] and sa[1] == sb[1] and sa[1][0] == "reference"  # one reference
    assert shared_work(disc, a, dict(inputs, scheme=a.spec, nx=10))[1] != sa[1]
    bar = make_case("clamped_bar")  # an exact solution: kernels only
    assert shared_work(bar, a, dict(inputs, case=bar.spec)) == (sa[0][:-1] + ("banded1d",),)


class _Stepper:
    """A stepper whose calls take `call_s` on a clock of its own (`perf_counter`)."""

    def __init__(self, call_s: float) -> None:
        self.calls: list[tuple[int, int]] = []
        self.call_s, self.now = call_s, 0.0

    def run(self, steps: int, stride: int) -> None:
        self.calls.append((steps, stride))
        self.now += self.call_s

    def perf_counter(self) -> float:
        return self.now


def test_timing_pass_keeps_a_long_warm_up_call_and_discards_a_short_one(monkeypatch):
    row = {"case": "clamped_bar", "scheme": "standard", "nx": 8, "grading": 1.0,
           "dt": 0.1, "steps": 50, "stride": 5}
    scheme = make_scheme("standard")
    for call_s, kept in ((0.5 * sweep.WARM_UP_KEPT_S, False), (sweep.WARM_UP_KEPT_S, True)):
        stepper = _Stepper(call_s)
        monkeypatch.setattr(type(scheme), "prepare", lambda self, p, dt, s=stepper: s)
        monkeypatch.setattr(sweep, "TIME_BUDGET_S", 100.0)  # 3 calls a mode
        monkeypatch.setattr(sweep, "time", stepper)  # the sweep's clock
        times, steps = time_run(row, repeats=3)
        assert times == pytest.approx([call_s] * 3) and steps == pytest.approx([call_s] * 3)
        # one-step compilation, the warm-up, 3 + 3 timed calls (the warm-up one of them
        # when kept)
        assert len(stepper.calls) == 1 + (6 if kept else 7)
        assert stepper.calls[1:4] == [(50, 5)] * 3 and stepper.calls[-1] == (50, 50)


def test_second_identical_sweep_is_served_from_the_cache(tmp_path):
    tasks = plan(**GRID)
    cache = Cache(tmp_path / "cache")
    first = run_sweep(tasks, cache=cache, repeats=1, quiet=True)
    n_ok = int((first.table["status"] == "ok").sum())
    assert (first.executed, first.cached) == (12, 0) and first.timed == n_ok  # ok rows timed
    assert first.table["time_s"].notna().sum() == n_ok and 0 < n_ok < 12
    second = run_sweep(tasks, cache=cache, repeats=1, quiet=True)
    assert (second.executed, second.cached, second.timed) == (0, 12, 0)
    assert second.table["from_cache"].all() and not first.table["from_cache"].any()
    pd.testing.assert_frame_equal(_metrics(first.table), _metrics(second.table))
    # a changed input is a new run; the others still come from the cache
    third = run_sweep(plan(**{**GRID, "nxs": [8, 16, 24]}), cache=cache, repeats=0, quiet=True)
    assert (third.executed, third.cached) == (6, 12)


def test_killed_sweep_resumes(tmp_path):
    cache_dir, out = tmp_path / "cache", tmp_path / "out"
    args = ["sweep", "--case", "clamped_bar", "--scheme", "standard",
            "--scheme", "redistributed", "--nx", "20,40,60,80,100,120,140,160", "--cfl", "0.5",
            "--T", "6", "--repeats", "0", "-j", "1", "--quiet",
            "--cache", str(cache_dir), "--out", str(out)]
    proc = subprocess.Popen([sys.executable, "-m", "contact_bench", *args], start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while len(Cache(cache_dir)) < 2 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.02)
        os.killpg(proc.pid, signal.SIGKILL)
    finally:
        proc.wait(timeout=30)
    done_before = len(Cache(cache_dir))
    assert proc.returncode == -signal.SIGKILL, "the sweep finished before it could be killed"
    assert 2 <= done_before < 16
    assert not (out / "sweep.csv").exists()  # nothing half-written
    assert main(args) == 0
    df = load_table(out / "sweep.csv")
    assert len(df) == 16 and (df["status"] == "ok").all()
    assert int(df["from_cache"].sum()) == done_before  # cached rows reused, the rest computed
    assert len(Cache(cache_dir)) == 16


def test_fit_order_recovers_a_known_slope_and_skips_the_roundoff_floor():
    h = 2.0 ** -np.arange(2, 10)
    rng = np.random.default_rng(0)
    err = 3.0 * h**2 * (1 + 0.01 * rng.standard_normal(h.size))
    err[-2:] = [3e-15, 1e-15]  # at the round-off floor
    fit = fit_order(h, err)
    assert fit.order == pytest.approx(2.0, abs=0.02)
    assert (fit.n_used, fit.n_dropped) == (6, 2)
    np.testing.assert_allclose(fit.local, 2.0, atol=0.06)
    # the same data as sweep rows at a fixed CFL give the same order in the table
    df = pd.DataFrame({"case": "c", "scheme": "s", "status": "ok", "T": 1.0, "cfl": 0.5,
                       "nx": (1 / h).astype(int), "h": h, "dt": 0.5 * h, "err_u_linf_l2": err,
                       "order_declared": 2})
    row = convergence_table(df).iloc[0]
    assert row["against"] == "h" and row["order"] == pytest.approx(fit.order)
    assert row["points"] == 6 and row["floor points"] == 2


def test_pareto_front_and_classes():
    t = np.array([1.0, 2.0, 3.0, 4.0])
    e = np.array([1e-1, 2e-1, 1e-2, 1e-2])
    assert pareto_mask(t, e).tolist() == [True, False, True, False]
    assert classify("unstable", "conserved", None, None) == "blown up"
    assert classify("ok", "conserved", 0.5, None) == "energy-growing"
    assert classify("ok", "conserved", 0.5, 1.0) == "stable"
    assert classify("ok", "may grow", 50.0, None) == "stable"
    assert classify("error", "conserved", None, None) is None


def test_report_renders_from_a_saved_table(tmp_path):
    tasks = plan_study(quick=True, scheme_specs=["standard", "redistributed[beta=0]"],
                       case_specs=["clamped_bar"])
    res = run_sweep(tasks, repeats=1, quiet=True)
    assert {"refine", "dt", "stability"} <= {g for gs in res.table["group"] for g in gs.split(";")}
    table = save_table(res.table, tmp_path / "sweep.csv")[0]
    # the study's declared-against-measured time orders, saved beside the table
    orders = time_order_table(list(res.table["scheme"]))
    write_tables(orders, tmp_path, "time_order", "made by the test")
    out = tmp_path / "report"
    assert main(["report", str(table), "--out", str(out)]) == 0
    html = (out / "index.html").read_text()
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert {"work_precision_clamped_bar.png", "stability_clamped_bar.png",
            "energy_clamped_bar.png"} <= set(pngs)
    for name in pngs:
        assert f'src="{name}"' in html
    tex = (out / "convergence_clamped_bar.tex").read_text()
    assert tex.startswith("% made by `contact-bench report") and "\\begin{tabular}" in tex
    assert "\\end{tabular}" in tex and "\\toprule" in tex and "\\bottomrule" in tex
    assert "fitted order" in tex and "err\\_u" not in tex  # readable headers
    assert (out / "work_precision_clamped_bar.md").read_text().startswith("<!-- made by")
    # plain CSV: a bare read_csv gets the columns; provenance in the sidecar
    energy = pd.read_csv(out / "energy_clamped_bar.csv")
    assert "energy_drift_max" in energy.columns
    side = json.loads((out / "energy_clamped_bar.csv.json").read_text())
    assert side["provenance"].startswith("made by `contact-bench report")
    conv = pd.read_csv(out / "convergence_clamped_bar.csv")
    assert set(conv["against"]) == {"h", "dt"}
    assert (out / "convergence_clamped_bar.png").exists()
    assert "<title>contact-bench report" in html and 'href="#clamped_bar-stability"' in html
    assert 'class="scroll"' in html
    assert Path(out / "stability_map_clamped_bar.tex").exists()
    assert "Time order away from impacts" in html and (out / "time_order.md").exists()
    assert conv.columns.get_loc("smooth order") == conv.columns.get_loc("declared order") + 1
    shown = pd.read_csv(out / "time_order.csv", comment="#")
    assert set(shown["scheme"]) == {"standard", "redistributed[beta=0]"}
