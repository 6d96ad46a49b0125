"""Sweeps: grids of scenes x scheme specs x nx x (dt or CFL), one tidy row per run.

A sweep is a list of `Task`s (`plan` builds the product; scheme and case specs may hold
list-valued parameters, expanded with `contact_bench.api.params.expand_spec`). `run_sweep` runs
them and returns one DataFrame:

1. every task whose key (inputs + code hash, `contact_bench.sweeps.cache`) is in the cache is served
   from it (`from_cache` = True);
2. the others run in parallel, in local processes (`jobs`) or on Dask distributed
   (`dask` = an address or "local"); each finished row is written to the cache at
   once, so an interrupted sweep continues where it stopped. On Dask, a run whose
   worker fails (a worker process that died, `KilledWorker`) is an 'error' row saying
   so, not cached (the next sweep runs it again), and the other runs go on;
3. then, with no run going on, a *timing pass*, serial in this process (on Dask: each
   run on a worker of the cluster, one per worker thread at a time): for every
   ok row of a timed task, the scheme's stepper prepared once (`scheme.prepare`, outside
   the timings), a one-step run (JIT compilation) and one warm-up call of `stepper.run`
   (discarded, unless it took `WARM_UP_KEPT_S` or more without compiling: then it is the
   first timed call), then two timings of `repeats` timed calls each (no more than two
   once they took `TIME_BUDGET_S`) with the garbage collector off: `time_s`, the run
   with the row's recording (its stride), and `step_s`, the stepping alone (stride =
   steps: samples at the first and the last step only). Each gives its minimum and,
   through
   `timing_stats`, `<name>_median_s`, `<name>_iqr_s` (interquartile range),
   `<name>_repeats` and `<name>_noisy` (IQR above NOISY_SPREAD x the median: re-time
   it). Timings are cached too, keyed on the run and the CPU model; `retime` measures
   them again (the runs themselves, errors included, still come from the cache).

Time columns (`TIMING_COLUMNS`): `step_s` and `time_s` from the timing pass (without
it, `step_s` is the harness's own, measured in the worker: `contact_bench.harness.runner`);
`setup_s`, `run_s` and `wall_s` the harness's single recorded run (its set-up, the run:
`contact_bench.harness.runner`); `task_s` the whole task
(assembly, run, error norms, bookkeeping). Work-precision uses `step_s`.

Every scene runs (the bar or a 2D/3D body, one problem form:
`contact_bench.harness.runner.problem_for`); a mesh a body scene refuses for a scheme's
mass is an 'error' row, not a stop.

A failing run never stops a sweep: it is a row with status 'error' and the reason.
Rows also carry the scheme's declarations (implicit, energy behaviour, stability limit,
energy drift bound), a stability class and the environment (`contact_bench.harness.environment`).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import gc
import hashlib
import io
import json
import math
import multiprocessing as mp
import signal
import time
import traceback
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numba.core import event as numba_event

from contact_bench.api.params import expand_spec
from contact_bench.api.plugin import Case
from contact_bench.api.registry import make_case, make_scheme, plugin_dirs, use_plugin_dirs
from contact_bench.core.errors import BenchError, shown
from contact_bench.core.sampling import BLOWUP_FACTOR, blown_up_rows
from contact_bench.harness.environment import cpu_model, environment
from contact_bench.harness.io import atomic_write, write_text
from contact_bench.harness.metrics import ERROR_COLUMNS
from contact_bench.harness.runner import (
    BASE_COLUMNS,
    MAX_STEPS,
    check_mesh_grading,
    check_run,
    check_task_inputs,
    declared_limit,
    problem_for,
    run_one,
    table_columns,
)
from contact_bench.harness.runner import TIMING_COLUMNS as RUN_TIMING_COLUMNS
from contact_bench.sweeps.cache import Cache, code_hash, run_key

#: growth max (E - E0)/|E0| tolerated for 'conserved'/'dissipated' schemes with no bound
DEFAULT_GROWTH_TOL = 1e-2
TRACE_POINTS = 200
STABILITY_CLASSES = ("stable", "energy-growing", "blown up")
#: columns that vary from one execution of the same run to the next
TIMING_COLUMNS = ("step_s", "step_median_s", "step_iqr_s", "step_repeats", "step_noisy",
                  "time_s", "time_median_s", "time_iqr_s", "time_repeats", "time_noisy",
                  "setup_s", "run_s", "wall_s", "task_s")
#: a timing whose interquartile range exceeds this fraction of its median is flagged noisy
NOISY_SPREAD = 0.1
#: what varies between executions of the same run: the timings (the sweep's and the
#: harness's, with the references' costs and whether they came from their cache), where a
#: row came from and when
VOLATILE_COLUMNS = tuple(dict.fromkeys((*TIMING_COLUMNS, *RUN_TIMING_COLUMNS, "from_cache",
                                        "run_date")))

COLUMNS = (
    "group", "case", "scheme", "case_name", "scheme_name", "nx", "h", "dt", "cfl", "T",
    "steps", "stride", "grading", *ERROR_COLUMNS,
    "energy_initial", "energy_final", "energy_drift_max", "energy_growth_max",
    "penetration_max", "blowup_time", "status", "stability", "notes", "reference",
    "implicit", "energy_trait", "order_declared", "contact", "massless_contact_node",
    "dt_limit", "cfl_limit", "energy_drift_bound",
    *TIMING_COLUMNS, "from_cache", "key", "code_hash", "run_date",
    *environment().keys(), "energy_trace",
)


@dataclass(frozen=True)
class Task:
    """One run to make. `dt` and `cfl` are exclusive (neither: the case's default dt).

    `max_samples` (optional) sets the sampling stride so that at most about that many
    samples are kept (metrics cost grows with the number of samples).
    """

    case: str
    scheme: str
    nx: int | None = None
    dt: float | None = None
    cfl: float | None = None
    T: float | None = None
    stride: int = 1
    max_samples: int | None = None
    grading: float = 1.0
    group: str = "sweep"
    timed: bool = True

    def inputs(self) -> dict[str, Any]:
        """What defines the run (the cache key): everything but group and timed."""
        out = asdict(self)
        out.pop("group")
        out.pop("timed")
        return out


@dataclass
class SweepResult:
    table: pd.DataFrame
    executed: int  # runs computed by this call (not served from the cache)
    cached: int  # runs served from the cache
    timed: int  # timing measurements made by this call
    elapsed: float
    keys: list[str] = field(default_factory=list)
    #: key -> formatted traceback of each 'error' row (`--traceback`); not a table column
    tracebacks: dict[str, str] = field(default_factory=dict)


def plan(cases: Iterable[str], schemes: Iterable[str], nxs: Sequence[int | None] = (None,),
         dts: Sequence[float | None] | None = None, cfls: Sequence[float] | None = None,
         T: float | None = None, stride: int = 1, max_samples: int | None = None,
         grading: float = 1.0, group: str = "sweep", timed: bool = True) -> list[Task]:
    """The product cases x schemes x nx x (dt or CFL), specs expanded (benchopt style)."""
    if dts and cfls:
        raise BenchError("give time steps either as dt or as CFL, not both")
    steps: list[tuple[float | None, float | None]]
    if cfls:
        steps = [(None, float(c)) for c in cfls]
    else:
        steps = [(None if d is None else float(d), None) for d in (dts or [None])]
    case_specs = [s for c in cases for s in expand_spec(c)]
    scheme_specs = [s for c in schemes for s in expand_spec(c)]
    return [Task(c, s, nx, dt, cfl, T, stride, max_samples, grading, group, timed)
            for c in case_specs for s in scheme_specs for nx in nxs for dt, cfl in steps]


# ------------------------------------------------------------------------ one run


def _one_line(exc: BaseException) -> str:
    return " ".join(f"{type(exc).__name__}: {exc}".split())


def _finite(x: Any) -> bool:
    try:
        return x is not None and math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


def classify(status: str | None, energy_trait: str | None, growth: float | None,
             bound: float | None) -> str | None:
    """Stability class of a row: 'blown up', 'energy-growing' (beyond the declared
    behaviour) or 'stable'; None when the run did not run (error, not applicable).

    Declared behaviour: a `energy_drift_bound` when the scheme gives one; else, for
    'conserved' and 'dissipated' schemes, a growth of at most DEFAULT_GROWTH_TOL;
    a scheme that declares its energy 'may grow' without a bound only blows up.
    """
    if status == "unstable":
        return "blown up"
    if status != "ok":
        return None
    tol = bound if _finite(bound) else (
        DEFAULT_GROWTH_TOL if energy_trait in {"conserved", "dissipated"} else None)
    if tol is not None and _finite(growth) and float(growth) > float(tol):
        return "energy-growing"
    return "stable"


def _trace(t: np.ndarray, E: np.ndarray) -> str:
    """E(t) at <= TRACE_POINTS samples, as JSON (6 significant digits)."""
    idx = np.unique(np.linspace(0, t.size - 1, min(t.size, TRACE_POINTS)).round().astype(int))

    def r(v: float) -> float | None:
        return float(f"{v:.6g}") if math.isfinite(v) else None

    return json.dumps({"t": [r(float(v)) for v in t[idx]], "E": [r(float(v)) for v in E[idx]]})


def _stride_for(task: dict[str, Any], dt: float | None, case: Any, limit: float | None,
                T: float) -> int:
    if not task.get("max_samples"):
        return int(task["stride"])
    dt_est = case.dt if dt is None else dt
    if dt is None and limit is not None and dt_est > limit:
        dt_est = 0.9 * limit
    if not T / dt_est <= MAX_STEPS:  # refused by the run's checks
        return int(task["stride"])
    steps = max(1, math.ceil(T / dt_est - 1e-9))
    return max(int(task["stride"]), min(steps, math.ceil(steps / int(task["max_samples"]))))


def check_task(task: dict[str, Any], made: tuple[Any, Any]) -> None:
    """Every check `execute_task`'s run makes on its inputs, without running: a bad input
    (stride above the steps, samples over memory, ...) is a BenchError before the sweep
    starts, as in `run`. The problem is built once (`problem_for`, kept for the task's
    run and timing when they are made in this process) and handed to the run's checks."""
    case, scheme = made
    if scheme.cannot_run(case) or case.cannot_run(scheme):
        return
    try:
        nx, grading = int(task["nx"]), float(task["grading"])
        T = float(case.T if task["T"] is None else task["T"])
        check_mesh_grading(nx, grading)
        try:
            semi = problem_for(case, scheme, nx, grading)
        except BenchError:
            if case.form == "banded1d":
                raise
            return  # a mesh a sparse scene refuses for this mass: an error row
        limit = declared_limit(case, scheme, semi)
        dt = task["dt"] if task["cfl"] is None else float(task["cfl"]) * semi.hmin / semi.c_max
        stride = _stride_for(task, dt, case, limit, T)
        check_run(case, scheme, nx, dt, T, stride, grading, True, problem=semi)
    except BenchError:
        raise
    except Exception:  # noqa: BLE001, S110 - a broken plugin is an error row when it runs
        return


def execute_task(task: dict[str, Any]) -> dict[str, Any]:
    """Run one task (a `Task.inputs()` dict plus bookkeeping); never raises: errors are rows."""
    start = time.perf_counter()
    row: dict[str, Any] = dict.fromkeys(COLUMNS)
    row.update(case=task["case"], scheme=task["scheme"], nx=task["nx"], dt=task["dt"],
               cfl=task["cfl"], T=task["T"], stride=task["stride"], grading=task["grading"])
    try:
        use_plugin_dirs(task.get("plugins", ()))
        case, scheme = make_case(task["case"]), make_scheme(task["scheme"])
        row.update(case_name=case.name, scheme_name=scheme.name)
        _trait_columns(row, scheme.traits())
        nx, grading = int(task["nx"]), float(task["grading"])
        T = float(case.T if task["T"] is None else task["T"])
        reason = scheme.cannot_run(case) or case.cannot_run(scheme)
        if reason:
            run = run_one(case, scheme, nx, None, T, 1, grading, True)
            row.update(run.row)
        else:
            semi0 = problem_for(case, scheme, nx, grading)
            _trait_columns(row, scheme.traits(semi0))  # what holds on this problem
            h, c = semi0.hmin, semi0.c_max
            limit = declared_limit(case, scheme, semi0)
            row.update(h=h, dt_limit=limit, cfl_limit=None if limit is None else c * limit / h)
            dt = task["dt"] if task["cfl"] is None else float(task["cfl"]) * h / c
            stride = _stride_for(task, dt, case, limit, T)
            # step_s here is a first measurement (one timed call): the timing pass measures
            # it again, serially, for the timed tasks
            run = run_one(case, scheme, nx, dt, T, stride, grading, True, step_repeats=1,
                          problem=semi0)
            row.update(run.row)
            row["cfl"] = c * float(row["dt"]) / h
            traj = run.trajectory
            if traj is not None and run.semi is not None:
                row["energy_drift_bound"] = drift_bound(scheme, run.semi, float(row["dt"]))
                _energy_extras(row, traj.t, np.asarray(traj.energy, float))
        row["stability"] = classify(row["status"], row["energy_trait"],
                                    row["energy_growth_max"], row["energy_drift_bound"])
    except Exception as exc:  # noqa: BLE001 - a failing run never stops the sweep
        row.update(status="error", notes=_one_line(exc), stability=None,
                   traceback="".join(traceback.format_exception(type(exc), exc,
                                                                exc.__traceback__)))
    row["task_s"] = time.perf_counter() - start
    row["run_date"] = f"{_dt.datetime.now(_dt.UTC):%Y-%m-%dT%H:%M:%SZ}"
    row.update(environment())
    return row


def _trait_columns(row: dict[str, Any], traits: Any) -> None:
    """The row's columns of a scheme's declared traits."""
    row.update(implicit=bool(traits.implicit), energy_trait=str(traits.energy),
               order_declared=traits.order, contact=str(traits.contact),
               massless_contact_node=traits.massless_contact_node)


def drift_bound(scheme: Any, problem: Any, dt: float) -> float | None:
    """The scheme's declared energy drift bound on this problem; None when it gives
    none, or gives one only for the 1D bar (a bound that reads the bar's matrices)."""
    try:
        return scheme.energy_drift_bound(problem, dt)
    except (AttributeError, TypeError):
        return None


def _energy_extras(row: dict[str, Any], t: np.ndarray, E: np.ndarray) -> None:
    """Energy growth, the energy trace, and a blow-up the scheme itself did not report."""
    E0 = float(E[0]) if E.size else float("nan")
    scale = abs(E0) if E0 != 0 else 1.0
    with np.errstate(invalid="ignore", over="ignore"):
        finite = np.isfinite(E)
        row["energy_growth_max"] = (float(np.max(E[finite] - E0) / scale)
                                    if finite.any() else float("nan"))
        bad = blown_up_rows(E, E0)
    row["energy_trace"] = _trace(t, E)
    if row["status"] == "ok" and bad.any():
        when = float(t[int(np.argmax(bad))])
        note = f"energy beyond {BLOWUP_FACTOR:g} x E(0) at t = {when:.6g} (seen by the sweep)"
        row.update(status="unstable", blowup_time=when,
                   notes="; ".join(n for n in (row.get("notes"), note) if n))


# ----------------------------------------------------------------- timing pass


#: a slow run stops repeating once its timed calls have taken this long (>= 2 calls)
TIME_BUDGET_S = 3.0
#: a warm-up call at least this long, during which numba compiled nothing, is the first
#: timed call rather than discarded: what a warm-up settles (first-touch page faults,
#: caches) is far below a call of a second, and a discarded call of a run that gets two
#: timed calls a mode would be a fifth of its timing pass for nothing shown
WARM_UP_KEPT_S = 1.0


def timing_stats(samples: Sequence[float], name: str = "time") -> dict[str, Any]:
    """The table's columns for one timing from its repeated measurements: `<name>_s`
    (minimum), `<name>_median_s`, `<name>_iqr_s` (75th - 25th percentile, linear),
    `<name>_repeats` and `<name>_noisy` (IQR > NOISY_SPREAD x median). The same for
    every timing column (e.g. name = 'step' gives step_s, step_median_s, ...)."""
    x = np.asarray([v for v in samples if _finite(v)], float)
    if x.size == 0:
        return {f"{name}_s": None, f"{name}_median_s": None, f"{name}_iqr_s": None,
                f"{name}_repeats": 0, f"{name}_noisy": None}
    med = float(np.median(x))
    iqr = float(np.percentile(x, 75) - np.percentile(x, 25))
    return {f"{name}_s": float(x.min()), f"{name}_median_s": med, f"{name}_iqr_s": iqr,
            f"{name}_repeats": int(x.size), f"{name}_noisy": bool(iqr > NOISY_SPREAD * med)}


def time_integrate(row: dict[str, Any], repeats: int, stepping: bool = False
                   ) -> list[float]:
    """`repeats` timed calls of the prepared stepper after a discarded warm-up: their times,
    with the row's stride, or (`stepping`) with stride = steps (the stepping alone).

    A run whose calls exceed TIME_BUDGET_S in total stops after two calls (one when
    repeats = 1).
    """
    return time_run(row, repeats, (stepping,))[0]


def time_run(row: dict[str, Any], repeats: int, modes: tuple[bool, ...] = (False, True)
             ) -> list[list[float]]:
    """The timed calls for each mode (False: the row's stride, True: the stepping alone)
    on one set-up: the problem read (`problem_for`: the task's own when this process
    ran it and still keeps it), the scheme's stepper prepared and the kernels compiled
    once. The first mode's first call is a warm-up, discarded unless it took at least
    `WARM_UP_KEPT_S` without compiling (then it is that mode's first timed call)."""
    case, scheme = make_case(row["case"]), make_scheme(row["scheme"])
    semi = problem_for(case, scheme, int(row["nx"]), float(row["grading"]))
    dt, steps = float(row["dt"]), int(row["steps"])
    stepper = scheme.prepare(semi, dt)
    stepper.run(1, 1)  # JIT compilation
    out = []
    for i, stepping in enumerate(modes):
        stride = steps if stepping else int(row["stride"])
        times: list[float] = []
        gc.collect()
        enabled = gc.isenabled()
        gc.disable()
        try:
            if i == 0:  # the warm-up call (the next mode runs warm after it)
                with numba_event.install_recorder("numba:compile") as compiled:
                    t0 = time.perf_counter()
                    stepper.run(steps, stride)
                    first = time.perf_counter() - t0
                if first >= WARM_UP_KEPT_S and not compiled.buffer:
                    times.append(first)
            while len(times) < max(1, repeats) and not (len(times) >= 2
                                                        and sum(times) > TIME_BUDGET_S):
                t0 = time.perf_counter()
                stepper.run(steps, stride)
                times.append(time.perf_counter() - t0)
        finally:
            if enabled:
                gc.enable()
        out.append(times)
    return out


# ------------------------------------------------------------------ executors


def _run_serial(todo: list[tuple[str, dict]], done: Callable[[str, dict], None]) -> None:
    for key, task in todo:
        done(key, execute_task(task))


def _ignore_sigint() -> None:
    """Worker start-up: Ctrl-C is the parent's to handle (one message, no worker
    tracebacks); the parent ends the workers."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def shared_work(case: Any, scheme: Any, inputs: dict[str, Any]) -> tuple[tuple, ...]:
    """What a run makes that the runs after it in the same process reuse (a worker
    keeps both, `cache=True` kernels and the reference cache on disk let the other
    workers read them): the scheme's compiled kernels, one set per scheme class, mass
    and problem form; and, for a scene declaring a numerical reference
    (`Case.reference_run`), the reference of the run's mesh and time grid (the same for
    every scheme at the same inputs). None shared when the plugin cannot say (its run
    is then an error row that says why)."""
    try:
        kernels = ("kernels", type(scheme).__module__, type(scheme).__qualname__,
                   str(scheme.mass_kind()), str(case.form))
    except Exception:  # noqa: BLE001 - a broken plugin: its own run reports it
        return ()
    out: tuple[tuple, ...] = (kernels,)
    if type(case).reference_run is not Case.reference_run:
        grid = {k: v for k, v in inputs.items() if k not in ("scheme", "plugins")}
        out += (("reference", json.dumps(grid, sort_keys=True, default=str)),)
    return out


def next_free(keys: Sequence[str], shared: dict[str, tuple[tuple, ...]],
              started: set[tuple], ready: set[tuple]) -> int | None:
    """The index of the first run of `keys` that waits for no piece of shared work: each
    of its pieces (`shared[key]`) either not yet started by any run (it will make it) or
    made (`ready`); None when every run waits for a running one."""
    return next((i for i, key in enumerate(keys)
                 if all(p in ready or p not in started for p in shared.get(key, ()))), None)


def _run_pool(todo: list[tuple[str, dict]], jobs: int, done: Callable[[str, dict], None],
              shared: dict[str, tuple[tuple, ...]] | None = None) -> None:
    """The runs on `jobs` worker processes, at most `jobs` at a time, in todo's order but
    for one rule: while the first run making a piece of `shared` work (`shared_work`:
    kernels to compile, a numerical reference to compute) is running, the other runs
    needing it wait and the free worker takes the next run that does not, so that each
    piece is made once rather than once per worker at the same time."""
    ctx = mp.get_context("spawn")  # no fork of a process holding threads (tqdm, numba)
    shared = shared or {}
    pending = list(todo)
    started: set[tuple] = set()  # pieces whose first run was submitted
    ready: set[tuple] = set()  # ... and finished
    running: dict[Any, tuple[str, list[tuple]]] = {}
    pool = ProcessPoolExecutor(max_workers=jobs, mp_context=ctx, initializer=_ignore_sigint)

    def submit() -> None:
        while len(running) < jobs and pending:
            i = next_free([key for key, _ in pending], shared, started, ready)
            if i is None:  # every pending run waits for a running one
                return
            key, task = pending.pop(i)
            firsts = [p for p in shared.get(key, ()) if p not in started]
            started.update(firsts)
            # a worker is spawned at a submit (the pool's constructor starts none) and
            # inherits the signal mask: it starts with SIGINT blocked, then ignores it
            # (`_ignore_sigint`)
            mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
            try:
                running[pool.submit(execute_task, task)] = (key, firsts)
            finally:
                signal.pthread_sigmask(signal.SIG_SETMASK, mask)

    try:
        submit()
        while running:
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for fut in finished:
                key, firsts = running.pop(fut)
                ready.update(firsts)
                done(key, fut.result())
            submit()
    except BaseException:
        for proc in list(getattr(pool, "_processes", {}).values()):
            proc.terminate()  # interrupted: the running tasks are not waited for
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


#: how long a Dask scheduler has to answer
DASK_TIMEOUT = "5s"


@contextlib.contextmanager
def dask_client(address: str, jobs: int = 2) -> Iterator[Any]:
    """A Dask distributed client on the scheduler at `address`, or on a LocalCluster of
    `jobs` worker processes of one thread each (`address` = "local"), closed on exit."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise BenchError("--dask needs dask distributed: "
                         "pip install 'contact-bench[dask]'") from None
    import logging

    cluster = None
    if address == "local":
        cluster = LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True,
                               dashboard_address=":0", silence_logs=logging.ERROR)
        client = Client(cluster)
    else:
        client = Client(address, timeout=DASK_TIMEOUT)
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def lost_row(task: dict[str, Any], exc: BaseException) -> dict[str, Any]:
    """The 'error' row of a run whose worker failed (a worker process that died, a task
    the cluster could not run): the run's inputs, status 'error' and the reason."""
    row: dict[str, Any] = dict.fromkeys(COLUMNS)
    row.update({k: task.get(k) for k in ("case", "scheme", "nx", "dt", "cfl", "T", "stride",
                                         "grading")})
    for kind, make in (("case", make_case), ("scheme", make_scheme)):
        try:
            row[f"{kind}_name"] = make(row[kind]).name
        except Exception:  # noqa: BLE001, S110 - the row keeps its spec only
            pass
    row.update(status="error", notes=f"worker failed: {_one_line(exc)}",
               run_date=f"{_dt.datetime.now(_dt.UTC):%Y-%m-%dT%H:%M:%SZ}")
    return row


def _run_dask(todo: list[tuple[str, dict]], client: Any,
              done: Callable[[str, dict], None], lost: Callable[[str, dict], None]) -> None:
    """Each run on a worker of the cluster; a run whose worker fails is `lost` (an error
    row, not cached: the next sweep runs it again) and the others go on."""
    from distributed import as_completed

    tasks = dict(todo)
    futures = {client.submit(execute_task, task, key=f"run-{key}", pure=False): key
               for key, task in todo}
    for fut in as_completed(list(futures)):
        key = futures[fut]
        try:
            row = fut.result()
        except Exception as exc:  # noqa: BLE001 - a lost worker is a row, not a stop
            lost(key, lost_row(tasks[key], exc))
            continue
        done(key, row)


def _time_on_worker(row: dict[str, Any], repeats: int) -> list[list[float]]:
    """`time_run` on a Dask worker (module level: the worker imports it by name)."""
    return time_run(row, repeats)


# ----------------------------------------------------------------------- driver


def _progress(total: int, initial: int, desc: str, quiet: bool) -> Any:
    from tqdm.auto import tqdm

    return tqdm(total=total, initial=initial, desc=desc, unit="run", disable=quiet,
                dynamic_ncols=True, leave=True)


def run_sweep(tasks: Sequence[Task], jobs: int = 1, dask: str | None = None,
              cache: Cache | None = None, repeats: int = 5, quiet: bool = False,
              retime: bool = False) -> SweepResult:
    """Run the tasks (see the module docstring); the table has one row per distinct run.
    `retime`: measure the timings again even when cached (runs still come from the cache).
    """
    start = time.perf_counter()
    cache = cache if cache is not None else Cache(None)
    # canonical inputs and keys; bad specs raise BenchError here, before anything runs
    order: list[str] = []
    meta: dict[str, dict[str, Any]] = {}
    made: dict[tuple[str, str], tuple[Any, Any]] = {}
    for task in tasks:
        pair = (task.case, task.scheme)
        if pair not in made:
            made[pair] = (make_case(task.case), make_scheme(task.scheme))
        case, scheme = made[pair]
        check_task_inputs(task.nx, task.dt, task.T, task.cfl, task.stride, task.grading)
        canon = replace(task, case=case.spec, scheme=scheme.spec,
                        nx=int(case.nx if task.nx is None else task.nx))
        if canon.dt is not None and canon.cfl is not None:
            raise BenchError(f"task {task}: give dt or cfl, not both")
        inputs = canon.inputs()
        code = code_hash(type(case), type(scheme))
        if data := case.data_hash():  # the scene's data files (mesh_body's mesh)
            code = hashlib.sha256(f"{code}{data}".encode()).hexdigest()[:16]
        key = run_key(inputs, code)
        if key in meta:  # the same run asked twice (e.g. by two parts of a study)
            groups = meta[key]["group"].split(";")
            if task.group not in groups:
                meta[key]["group"] = ";".join([*groups, task.group])
            meta[key]["timed"] = meta[key]["timed"] or task.timed
            continue
        order.append(key)
        meta[key] = {"inputs": inputs, "code": code, "group": task.group, "timed": task.timed,
                     "case": task.case, "scheme": task.scheme}

    if not order:
        raise BenchError("the sweep has no runs (an empty grid)")
    rows: dict[str, dict[str, Any]] = {}
    for key in order:
        hit = cache.get(key, lambda row, key=key: _check_run_row(row, meta[key]["inputs"]))
        if hit is not None:
            rows[key] = dict(hit, from_cache=True)
    # a worker process (spawned, or a dask worker elsewhere) loads the same plugin folders
    todo = [(key, dict(meta[key]["inputs"], plugins=plugin_dirs()))
            for key in order if key not in rows]
    for key, inputs in todo:  # bad input fails here, before any run (not as error rows)
        check_task(inputs, made[(meta[key]["case"], meta[key]["scheme"])])
    n_cached = len(rows)
    bar = _progress(len(order), n_cached, "runs", quiet)

    def done(key: str, row: dict[str, Any]) -> None:
        row.update(key=key, code_hash=meta[key]["code"])
        cache.put(key, row)
        rows[key] = dict(row, from_cache=False)
        bar.update(1)

    def lost(key: str, row: dict[str, Any]) -> None:  # a failed worker: not cached
        rows[key] = dict(row, key=key, code_hash=meta[key]["code"], from_cache=False)
        bar.update(1)

    with dask_client(dask, max(1, jobs)) if dask else contextlib.nullcontext() as client:
        try:
            if client is not None:
                _run_dask(todo, client, done, lost)
            elif jobs > 1 and len(todo) > 1:
                shared = {key: shared_work(*made[(meta[key]["case"], meta[key]["scheme"])],
                                           meta[key]["inputs"]) for key, _ in todo}
                _run_pool(todo, min(jobs, len(todo)), done, shared)
            else:
                _run_serial(todo, done)
        finally:
            bar.close()
        timed = _timing_pass(order, meta, rows, cache, repeats, quiet, retime, client)
    tracebacks: dict[str, str] = {}
    for key in order:
        rows[key].update(group=meta[key]["group"], key=key, code_hash=meta[key]["code"])
        tb = rows[key].pop("traceback", None)
        if tb:
            tracebacks[key] = tb
    table = add_param_columns(_frame([rows[k] for k in order]))
    return SweepResult(table, len(todo), n_cached, timed, time.perf_counter() - start, order,
                       tracebacks)


STATUSES = ("ok", "unstable", "error", "not applicable")
_INT_COLUMNS = ("nx", "steps", "stride", "order_declared")
_FLOAT_COLUMNS = ("h", "dt", "cfl", "T", "grading", *ERROR_COLUMNS, "energy_initial",
                  "energy_final", "energy_drift_max", "energy_growth_max", "penetration_max",
                  "blowup_time", "dt_limit", "cfl_limit", "energy_drift_bound", "wall_s",
                  "run_s", "setup_s")
_TEXT_COLUMNS = ("case", "scheme", "case_name", "scheme_name", "status", "stability", "notes",
                 "reference", "energy_trait", "contact", "energy_trace", "key", "code_hash",
                 "run_date")


def _number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _check_run_row(row: dict[str, Any], inputs: dict[str, Any]) -> str | None:
    """Why a cached run row cannot be served for these inputs (None: it can)."""
    missing = [c for c in COLUMNS if c not in row and c not in VOLATILE_COLUMNS]
    if missing:
        return f"column {missing[0]!r} missing"
    if row["status"] not in STATUSES:
        return f"status {row['status']!r}"
    for col in _INT_COLUMNS:
        if row[col] is not None and (not _number(row[col]) or row[col] != int(row[col])):
            return f"{col} = {row[col]!r} is not an integer"
    for col in _FLOAT_COLUMNS:
        if row.get(col) is not None and not _number(row[col]):
            return f"{col} = {row[col]!r} is not a number"
    for col in _TEXT_COLUMNS:
        if row.get(col) is not None and not isinstance(row[col], str):
            return f"{col} = {row[col]!r} is not text"
    for col in ("case", "scheme", "nx"):
        if row[col] != inputs[col]:
            return f"{col} = {row[col]!r}, this run's is {inputs[col]!r}"
    return None


def _check_timing_row(row: dict[str, Any]) -> str | None:
    """Why a cached timing cannot be served (None: it can): two non-empty lists of
    finite positive times, `times` (the recorded run) and `step_times` (stepping alone)."""
    if not isinstance(row, dict) or set(row) != {"times", "step_times"}:
        return "not a timing entry"
    for name in ("times", "step_times"):
        values = row[name]
        if not (isinstance(values, list) and values
                and all(_number(v) and math.isfinite(v) and v > 0 for v in values)):
            return f"{name} = {shown(repr(values))}"
    return None


def _timing_pass(order: list[str], meta: dict[str, dict], rows: dict[str, dict],
                 cache: Cache, repeats: int, quiet: bool, retime: bool = False,
                 client: Any = None) -> int:
    """The timings, after all the runs are over (see module doc): serial in this process,
    or (a Dask `client`) each run timed on a worker of the cluster, one run per worker
    thread at a time; the timing cache is then keyed on the workers' CPU models."""
    if repeats <= 0:
        return 0
    wanted = [k for k in order if meta[k]["timed"] and rows[k].get("status") == "ok"]
    machine = (cpu_model() if client is None
               else "; ".join(sorted(set(client.run(cpu_model).values()))))
    todo = []
    for key in wanted:
        tkey = run_key({"run": key, "cpu": machine, "repeats": repeats,
                        "measures": ["time_s", "step_s"]}, meta[key]["code"], kind="timing")
        hit = None if retime else cache.get(tkey, _check_timing_row)
        if hit is not None:
            rows[key].update(timing_stats(hit["times"]))
            rows[key].update(timing_stats(hit["step_times"], "step"))
        else:
            todo.append((key, tkey))
    where = "serial" if client is None else "on the workers"
    bar = _progress(len(todo), 0, f"timing ({where})", quiet or not todo)
    try:
        for (key, tkey), measured in zip(todo, _timings(todo, rows, repeats, client),
                                         strict=False):
            if isinstance(measured, BaseException):  # a failing timing is a note, not a crash
                rows[key]["notes"] = "; ".join(
                    n for n in (rows[key].get("notes"), f"timing failed: {_one_line(measured)}")
                    if n)
                bar.update(1)
                continue
            times, step_times = measured
            rows[key].update(timing_stats(times))
            rows[key].update(timing_stats(step_times, "step"))
            cache.put(tkey, {"times": times, "step_times": step_times})
            bar.update(1)
    finally:
        bar.close()
    return len(todo)


def _timings(todo: list[tuple[str, str]], rows: dict[str, dict], repeats: int,
             client: Any) -> Iterator[Any]:
    """Each run's (times, step_times), or the exception its timing raised, in todo's order."""
    if client is None:
        for key, _ in todo:
            try:
                yield time_run(rows[key], repeats)
            except Exception as exc:  # noqa: BLE001
                yield exc
        return
    futures = [client.submit(_time_on_worker, rows[key], repeats, key=f"time-{key}",
                             pure=False) for key, _ in todo]
    for fut in futures:
        try:
            yield fut.result()
        except Exception as exc:  # noqa: BLE001 - a lost worker: the run has no timing
            yield exc


def _frame(rows: list[dict[str, Any]]) -> pd.DataFrame:
    """The rows as a table: `COLUMNS`, the harness's other base columns, then every other
    column of the rows sorted by name (`contact_bench.harness.runner.table_columns`: a
    scene's declared `err_<q>` too), with the column types `run_sweep` gives."""
    base = (*COLUMNS, *(c for c in BASE_COLUMNS if c not in COLUMNS))
    df = pd.DataFrame(rows, columns=table_columns(rows, base))
    for col in ("nx", "steps", "stride", "order_declared", "time_repeats", "env_ncpu"):
        if col in df:
            df[col] = pd.to_numeric(df[col], errors="coerce").astype("Int64")
    for col in ("h", "dt", "cfl", "T", "grading", "energy_initial",
                "energy_final", "energy_drift_max", "energy_growth_max", "penetration_max",
                "blowup_time", "dt_limit", "cfl_limit", "energy_drift_bound",
                *(c for c in TIMING_COLUMNS if c.endswith("_s")),
                *(c for c in df.columns if str(c).startswith("err_"))):
        if col in df:
            df[col] = pd.to_numeric(df[col], errors="coerce").astype(float)
    for col in ("implicit", "massless_contact_node", "from_cache",
                *(c for c in df.columns if str(c).endswith("_noisy"))):
        if col in df:
            df[col] = df[col].astype("boolean")
    return df


def add_param_columns(df: pd.DataFrame) -> pd.DataFrame:
    """One column per scheme parameter (`scheme_<name>`) and scene parameter
    (`case_<name>`), read from the specs (defaults filled in), next to them; a spec that
    does not parse leaves its cells empty. Columns already there are kept."""
    if df.empty:
        return df
    new: dict[str, list[Any]] = {}
    for kind, make in (("case", make_case), ("scheme", make_scheme)):
        values: dict[str, dict[str, Any]] = {}
        for spec in dict.fromkeys(df[kind].dropna()):
            try:
                obj = make(spec)
            except Exception:  # noqa: BLE001 - an error row keeps its spec only
                values[spec] = {}
                continue
            values[spec] = {f"{kind}_{k}": getattr(obj, k, None) for k in type(obj).params}
        cols = list(dict.fromkeys(c for v in values.values() for c in v))
        for col in cols:
            if col in df.columns or col in (f"{kind}_name",):
                continue
            new[col] = [values.get(spec, {}).get(col) for spec in df[kind]]
    if not new:
        return df
    out = df.copy()
    at = list(out.columns).index("scheme_name") + 1 if "scheme_name" in out else len(out.columns)
    for i, (col, vals) in enumerate(new.items()):
        out.insert(at + i, col, pd.Series(vals, index=out.index, dtype=object))
    return out


# ------------------------------------------------------------------ table files


def save_table(df: pd.DataFrame, path: str | Path, prov: str | None = None) -> list[Path]:
    """Write df as plain CSV (and Parquet next to it when pyarrow is installed),
    atomically; `prov` (the provenance line) goes to `<name>.csv.json` and into the
    Parquet file's metadata (key b"contact_bench_provenance")."""
    path = Path(path)
    written = [write_text(path, df.to_csv(index=False))]
    if prov is not None:
        side = {"provenance": prov, "file": path.name}
        written.append(write_text(path.with_name(path.name + ".json"),
                                  json.dumps(side, indent=1) + "\n"))
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return written

    def write_parquet(tmp: str) -> None:
        table = pa.Table.from_pandas(_parquet_safe(df), preserve_index=False)
        if prov is not None:
            meta = dict(table.schema.metadata or {})
            meta[b"contact_bench_provenance"] = prov.encode()
            table = table.replace_schema_metadata(meta)
        pq.write_table(table, tmp)

    written.append(atomic_write(path.with_suffix(".parquet"), write_parquet))
    return written


def _parquet_safe(df: pd.DataFrame) -> pd.DataFrame:
    """Object columns holding mixed types (parameter columns: a float for one scheme, a
    string for another) as strings, so that Arrow takes them; None stays missing."""
    out = df
    for col in df.columns:
        if df[col].dtype == object:
            kinds = {type(v) for v in df[col] if v is not None and not
                     (isinstance(v, float) and math.isnan(v))}
            if len(kinds) > 1:
                if out is df:
                    out = df.copy()
                out[col] = [None if v is None or (isinstance(v, float) and math.isnan(v))
                            else str(v) for v in df[col]]
    return out


def read_provenance(path: str | Path) -> str | None:
    """The provenance saved with a table (`save_table`), from Parquet metadata or the
    CSV's sidecar; None when there is none."""
    path = Path(path)
    if path.suffix == ".parquet":
        import pyarrow.parquet as pq

        meta = pq.read_schema(path).metadata or {}
        raw = meta.get(b"contact_bench_provenance")
        return None if raw is None else raw.decode()
    side = path.with_name(path.name + ".json")
    if side.exists():
        return json.loads(side.read_text(encoding="utf-8")).get("provenance")
    return None


#: columns a saved table must have for `report` (what the analysis reads); the sweep's
#: other columns, which a `run` table lacks (group, cfl, timings, traces), read as empty
TABLE_COLUMNS = ("case", "scheme", "nx", "dt", "T", "steps", "status")


def load_table(path: str | Path) -> pd.DataFrame:
    """A saved sweep table (CSV or Parquet), with the column types `run_sweep` gives.

    A file that is not such a table (empty, only comments, binary, not UTF-8, cut so
    that it does not parse, columns missing) is a one-line BenchError naming it.
    """
    path = Path(path)
    if not path.exists():
        raise BenchError(f"no such table: {shown(str(path))}")
    if not path.is_file():
        raise BenchError(f"{shown(str(path))} is not a file")
    try:
        if path.suffix == ".parquet":
            df = pd.read_parquet(path)
        else:
            raw = path.read_bytes()
            if b"\0" in raw:
                raise ValueError("binary content (or not UTF-8 text)")
            lines = raw.decode("utf-8").splitlines(keepends=True)
            skip = next((i for i, line in enumerate(lines) if not line.startswith("#")),
                        len(lines))
            text = "".join(lines[skip:])
            _check_fields(text)
            df = pd.read_csv(io.StringIO(text), keep_default_na=True)
    except (OSError, ValueError, UnicodeError, ImportError) as exc:
        why = " ".join(f"{type(exc).__name__}: {exc}".split())
        raise BenchError(f"{shown(str(path))} is not a readable sweep table ({shown(why)})"
                         ) from None
    missing = [c for c in TABLE_COLUMNS if c not in df]
    if missing:
        raise BenchError(f"{shown(str(path))} is not a sweep table: column(s) "
                         f"{', '.join(missing[:5])} missing")
    if df.empty:
        raise BenchError(f"{shown(str(path))} is a sweep table with no rows")
    for number, trace in enumerate(df.get("energy_trace", ()), start=1):
        if isinstance(trace, str):
            try:
                json.loads(trace)
            except ValueError:
                raise BenchError(f"{shown(str(path))}: row {number}'s energy_trace is not "
                                 "valid JSON (cut short?)") from None
    return add_param_columns(_frame(df.to_dict("records")))


def _check_fields(text: str) -> None:
    """Every CSV record has the header's number of fields (a row cut short is refused,
    not read with blanks); raises ValueError naming the first that does not."""
    import csv

    if text and not text.endswith("\n"):
        raise ValueError("the last row is cut short (no final newline)")
    records = csv.reader(io.StringIO(text, newline=""))
    header = next(records, None)
    for number, record in enumerate(records, start=1):
        if header is not None and len(record) != len(header):
            raise ValueError(f"row {number} has {len(record)} of {len(header)} fields "
                             "(cut short?)")


#: error columns `report` and `study` can analyse (`--error`)
ANALYSABLE = (*ERROR_COLUMNS, "energy_drift_max", "energy_growth_max", "penetration_max")


def check_error_column(df: pd.DataFrame | None, error: str) -> None:
    """--error names a numeric column: one of ANALYSABLE, and a numeric one of df."""
    if error not in ANALYSABLE:
        from contact_bench.core.errors import unknown

        raise unknown("--error column", error, ANALYSABLE)
    if df is not None:
        if error not in df:
            raise BenchError(f"--error {error!r}: the table has no such column")
        if not pd.api.types.is_numeric_dtype(df[error]):
            raise BenchError(f"--error {error!r}: the column is not numeric")
