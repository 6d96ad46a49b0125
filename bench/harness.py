"""Run (case, scheme, nx, dt, T, stride) and tabulate one metrics row per run.

The harness reads only what plugins declare: the case's reference and the quantities
it provides, the scheme's traits, stability limit and `cannot_run`. What a scene does
not provide is left empty (NaN) and the row's `notes` say why.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from bench.errors import BenchError
from bench.fem import mesh_nodes
from bench.metrics import ERROR_COLUMNS, NEEDS, energy_metrics, error_metrics, penetration
from bench.plugin import Case, Scheme, Trajectory
from bench.problem import discretise
from bench.registry import make_case, make_scheme

COLUMNS = (
    "case", "scheme", "nx", "dt", "T", "steps", *ERROR_COLUMNS,
    "energy_initial", "energy_final", "energy_drift_max", "penetration_max", "wall_s",
    "status", "notes", "stride", "grading", "blowup_time", "reference",
)

_warmed: set[tuple[type, str]] = set()


@dataclass
class Run:
    """One finished run: its metrics row and, unless it did not start, its trajectory."""

    row: dict[str, Any]
    trajectory: Trajectory | None = None
    semi: Any = None


def _check_positive(name: str, value: float) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise BenchError(f"{name} must be a number > 0, got {value!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise BenchError(f"{name} must be finite and > 0, got {value!r}")
    return value


def _check_nx(nx: Any) -> int:
    if isinstance(nx, bool) or not isinstance(nx, int | np.integer | str | float):
        raise BenchError(f"nx must be an integer >= 1, got {nx!r}")
    try:
        value = int(nx) if not isinstance(nx, str) else int(nx.strip())
    except ValueError:
        raise BenchError(f"nx must be an integer >= 1, got {nx!r}") from None
    if value < 1 or (isinstance(nx, float) and value != nx):
        raise BenchError(f"nx must be an integer >= 1, got {nx!r}")
    return value


def run_one(case: Case | str, scheme: Scheme | str, nx: int | None = None,
            dt: float | None = None, T: float | None = None, stride: int = 1,
            grading: float = 1.0, allow_unstable: bool = False) -> Run:
    """Run one configuration. Bad input raises BenchError; a blow-up is a row."""
    case = make_case(case) if isinstance(case, str) else case
    scheme = make_scheme(scheme) if isinstance(scheme, str) else scheme
    nx = _check_nx(case.nx if nx is None else nx)
    T = _check_positive("T", case.T if T is None else T)
    dt_given = dt is not None
    dt = _check_positive("dt", case.dt if dt is None else dt)
    if isinstance(stride, bool) or int(stride) != stride or stride < 1:
        raise BenchError(f"stride must be an integer >= 1, got {stride!r}")
    stride = int(stride)
    row: dict[str, Any] = dict.fromkeys(COLUMNS)
    row.update(case=case.spec, scheme=scheme.spec, nx=nx, T=T, stride=stride,
               grading=grading, reference=case.reference or "none")
    notes: list[str] = []
    reason = scheme.cannot_run(case) or case.cannot_run(scheme)
    if reason:
        row.update(dt=dt, status="not applicable", notes=reason)
        return Run(row)

    x = mesh_nodes(case.L, nx, grading)
    semi = discretise(case, x, scheme.mass_kind())
    limit = scheme.stability_limit(semi.hmin, semi.c_max)
    if limit is not None and dt > limit * (1 + 1e-12):
        if dt_given and not allow_unstable:
            raise BenchError(
                f"dt = {dt:g} is above the stability limit {limit:.6g} of {scheme.spec} "
                f"at nx = {nx} (pass --allow-unstable to run it anyway)")
        if dt_given:
            notes.append(f"dt above the stability limit {limit:.4g}")
        else:  # the case's default dt is too large for this explicit scheme
            dt = 0.9 * limit
            notes.append(f"dt lowered to 0.9 x the stability limit {limit:.4g}")
    steps = max(1, math.ceil(T / dt - 1e-9))
    if stride > steps:
        raise BenchError(f"stride = {stride} is larger than the number of steps ({steps})")
    T_run = steps * dt
    row.update(dt=dt, T=T_run, steps=steps)

    key = (type(scheme), scheme.mass_kind())
    if key not in _warmed:
        scheme.warm_up(semi)  # JIT compilation stays out of wall_s
        _warmed.add(key)
    start = time.perf_counter()
    traj = scheme.integrate(semi, dt, steps, stride)
    row["wall_s"] = time.perf_counter() - start

    row.update(energy_metrics(traj))
    row["penetration_max"] = penetration(traj)
    if traj.blowup_time is not None:
        row.update(status="unstable", blowup_time=traj.blowup_time)
        notes.append(f"blew up at t = {traj.blowup_time:.6g}")
    else:
        row["status"] = "ok"
        exact = case.exact(T_run) if case.reference else None
        if exact is None:
            notes.append("errors: no reference solution")
        else:
            row.update(error_metrics(semi, traj, exact, case.provides))
            missing = sorted({NEEDS[c] for c in ERROR_COLUMNS} - set(case.provides))
            if missing:
                notes.append(f"reference has no {', '.join(missing)}")
            if case.reference == "numerical":
                notes.append("errors against a numerical reference")
    row["notes"] = "; ".join(notes)
    return Run(row, traj, semi)


def run_table(cases: Iterable[str], schemes: Iterable[str], nxs: Iterable[int | None] = (None,),
              dts: Iterable[float | None] = (None,), T: float | None = None, stride: int = 1,
              grading: float = 1.0, allow_unstable: bool = False,
              keep: list[Run] | None = None) -> pd.DataFrame:
    """The product cases x schemes x nx x dt as one DataFrame (one row per run)."""
    case_objs = [make_case(c) for c in cases]
    scheme_objs = [make_scheme(s) for s in schemes]
    rows = []
    for case in case_objs:
        for scheme in scheme_objs:
            for nx in nxs:
                for dt in dts:
                    run = run_one(case, scheme, nx, dt, T, stride, grading, allow_unstable)
                    rows.append(run.row)
                    if keep is not None:
                        keep.append(run)
    return pd.DataFrame(rows, columns=list(COLUMNS))
