"""The study's 2D/3D part on a Dask cluster (`contact-bench study --dask ADDRESS`): a
LocalCluster of two worker processes gives the serial run's table (times aside), times
each timed run on a worker (not in the client), and a worker that dies is an error row
of its run while the others go on. Skipped without dask distributed (`.[dask]`)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from contact_bench.api.registry import PLUGINS_ENV
from contact_bench.sweeps import sweep
from contact_bench.sweeps.cache import Cache
from contact_bench.sweeps.study import plan_study
from contact_bench.sweeps.sweep import VOLATILE_COLUMNS, run_sweep

pytest.importorskip("distributed")

# the quick study's 2D disc and 3D sphere, one implicit and one explicit scheme: 8 runs
# (an error row among them: the redistributed mass refused on the coarsest P1 disc)
SCHEMES, SCENES = ["redistributed", "taylor_flanagan"], ["disc_drop", "sphere_drop"]

KILLER = '''"""A scheme that kills the Dask worker process running it (elsewhere it is
taylor_flanagan): a test of a lost worker."""
import os

from contact_bench.schemes.taylor_flanagan import TaylorFlanagan


class WorkerKiller(TaylorFlanagan):
    name = "worker_killer"

    def prepare(self, problem, dt):
        try:
            from distributed import get_worker

            get_worker()
        except (ImportError, ValueError):
            return super().prepare(problem, dt)
        os._exit(3)
'''


def _metrics(df: pd.DataFrame) -> pd.DataFrame:
    return df.drop(columns=list(VOLATILE_COLUMNS), errors="ignore").reset_index(drop=True)


def test_the_distributed_study_gives_the_serial_table_timed_on_the_workers(monkeypatch):
    tasks = plan_study(quick=True, scheme_specs=SCHEMES, case_specs=SCENES)
    serial = run_sweep(tasks, jobs=1, repeats=1, quiet=True)
    # every scheme runs on the first small mesh that accepts its mass: no error row
    assert set(serial.table["status"]) == {"ok"}
    assert serial.table["case"].str.startswith("sphere_drop").any()

    def not_here(*_args: object, **_kw: object) -> None:
        raise AssertionError("timed in the client, not on a worker")

    # the client cannot time anything: the timings come from the worker processes
    monkeypatch.setattr(sweep, "time_run", not_here)
    dask = run_sweep(tasks, jobs=2, dask="local", repeats=1, quiet=True)
    pd.testing.assert_frame_equal(_metrics(serial.table), _metrics(dask.table))
    timed = dask.table["group"].str.contains("refine") & (dask.table["status"] == "ok")
    assert timed.sum() >= 2 and dask.timed == timed.sum()
    assert (dask.table.loc[timed, ["step_s", "time_s"]] > 0).all().all()
    assert not dask.table["notes"].fillna("").str.contains("timing failed").any()


def test_a_worker_that_dies_is_an_error_row_and_the_study_goes_on(tmp_path: Path, monkeypatch):
    import dask

    folder = tmp_path / "plugins"
    folder.mkdir()
    (folder / "worker_killer.py").write_text(KILLER)
    monkeypatch.setenv(PLUGINS_ENV, str(folder))
    tasks = plan_study(quick=True, scheme_specs=["worker_killer", "taylor_flanagan"],
                       case_specs=["disc_drop"])
    cache = Cache(tmp_path / "cache")
    # a task whose worker dies is not retried on another worker (the default retries it
    # 3 x), and each worker holds one task at a time (a task queued on the dying worker
    # would be lost with it)
    with dask.config.set({"distributed.scheduler.allowed-failures": 0,
                          "distributed.scheduler.worker-saturation": 1.0}):
        res = run_sweep(tasks, jobs=2, dask="local", cache=cache, repeats=0, quiet=True)
    df = res.table
    lost = df[df["scheme"] == "worker_killer"]
    others = df[df["scheme"] == "taylor_flanagan"]
    assert len(lost) == len(others) >= 2
    assert (lost["status"] == "error").all() and (others["status"] == "ok").all()
    assert lost["notes"].str.startswith("worker failed: KilledWorker").all(), lost["notes"]
    assert (lost["scheme_name"] == "worker_killer").all()
    # the lost runs are not cached (a next sweep runs them again); the others are
    again = run_sweep(tasks, jobs=1, cache=cache, repeats=0, quiet=True)
    assert again.cached == len(others) and again.executed == len(lost)
