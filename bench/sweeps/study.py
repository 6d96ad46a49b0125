"""The published default study: its grids, built from what plugins declare.

For each scene of the main job (cases with `in_default_run`) and every registered scheme (default
parameters, plus any spec given with --scheme):

- refine (work-precision, order in h, energy): nx in nx_refine at a fixed CFL, the
  smaller of 0.5 and 0.9 x the scheme's declared CFL limit (dt proportional to h);
  these runs, and only these, are timed (serial timing pass, `contact_bench.sweeps.sweep`);
- dt (order in dt): nx = nx_fine, CFL halved dt_points times from 8 (no declared
  limit) or from 0.9 x the limit; only for schemes declaring a time order (for the
  others, e.g. an adaptive integrator, dt is not their step);
- stability: nx = nx_stab, T = long_t x the scene's T; CFL from 0.1 to 100 (no
  declared limit) or to twice the declared limit (with 0.95 and 1.05 x the limit);
  each scheme parameter declaring a `sweep` (`Param.sweep`, e.g. a penalty parameter
  in 1 ... 1e8) at each of its values (the quick study: the first and the last), at
  three CFL; every scene declaring `stiff` (steel_bar);
- energy: the refine runs at nx = nx_energy (traces of E(t) kept in the table);
- time order away from impacts: every scheme spec of the table, measured on a smooth
  motion without contact (`contact_bench.sweeps.time_order`, outside the sweep and its
  cache) and shown next to its declared order (`Traits.order`).

At most `max_samples` samples are kept per run (the stride grows with the number of
steps): the metrics' cost grows with the samples, and the sampling interval stays
about T / max_samples across refinements. `FULL` is sized for the 15-minute budget
on 2 cores (error runs dominate; see the report's timing note); `quick=True` is the
same study on tiny grids (a smoke test, about a minute).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.params import expand_spec
from contact_bench.api.plugin import Case, Scheme
from contact_bench.api.problem import discretise
from contact_bench.api.registry import cases, make_case, make_scheme, schemes
from contact_bench.sweeps.sweep import Task

FULL = {"nx_refine": [20, 40, 80, 160, 320, 640], "nx_fine": 640, "dt_points": 5,
        "nx_stab": 40, "cfl_points": 8, "nx_energy": 160, "max_samples": 1000,
        "long_t": 3.0, "param_sweep": "all"}
QUICK = {"nx_refine": [10, 20, 40], "nx_fine": 40, "dt_points": 3,
         "nx_stab": 10, "cfl_points": 3, "nx_energy": 20, "max_samples": 300,
         "long_t": 2.0, "param_sweep": "ends"}


def cfl_limit(case: Case, scheme: Scheme, nx: int) -> float | None:
    """The scheme's declared stability limit as a CFL number on this scene's mesh."""
    semi = discretise(case, mesh_nodes(float(case.L), nx), scheme.mass_kind())
    limit = scheme.stability_limit(semi.hmin, semi.c_max)
    return None if limit is None else limit * semi.c_max / semi.hmin


def stability_cfls(limit: float | None, points: int) -> list[float]:
    """0.1 to 100 (no limit) or to twice the limit (with points just below/above it)."""
    top = 100.0 if limit is None else 2.0 * limit
    grid = list(np.geomspace(0.1, top, points)) if top > 0.1 else [top]
    if limit is not None:
        grid += [0.95 * limit, 1.05 * limit]
    return sorted({float(f"{c:.3g}") for c in grid})


def default_schemes() -> list[str]:
    return [cls().spec for cls in schemes().plugins.values()]


def plan_study(quick: bool = False, scheme_specs: Sequence[str] | None = None,
               case_specs: Sequence[str] | None = None) -> list[Task]:
    """The tasks of the study (see the module docstring)."""
    g = QUICK if quick else FULL
    specs = [s for spec in (scheme_specs or default_schemes()) for s in expand_spec(spec)]
    scenes = list(case_specs or [n for n, c in cases().plugins.items() if c.in_default_run])
    stiff = [n for n, c in cases().plugins.items() if c.stiff and n not in scenes]
    tasks: list[Task] = []
    ms = g["max_samples"]
    for case_spec in scenes:
        case = make_case(case_spec)
        for spec in specs:
            scheme = make_scheme(spec)
            try:
                lim = cfl_limit(case, scheme, g["nx_stab"])
            except Exception:  # noqa: BLE001 - the sweep will report the error as a row
                lim = None
            cfl_r = min(0.5, 0.9 * lim) if lim is not None else 0.5
            for nx in g["nx_refine"]:
                group = "refine;energy" if nx == g["nx_energy"] else "refine"
                tasks.append(Task(case_spec, spec, nx, cfl=cfl_r, max_samples=ms, group=group))
            if scheme.traits().order is None:  # dt is not its step (e.g. adaptive)
                continue
            top = 8.0 if lim is None else 0.9 * lim
            for k in range(g["dt_points"]):
                tasks.append(Task(case_spec, spec, g["nx_fine"], cfl=float(f"{top / 2**k:.4g}"),
                                  max_samples=ms, group="dt", timed=False))
        for spec in specs:
            tasks += _stability(case_spec, spec, g)
    for case_spec in stiff:
        for spec in specs:
            tasks += _stability(case_spec, spec, g)
    return tasks


def _stability(case_spec: str, spec: str, g: dict) -> list[Task]:
    case, scheme = make_case(case_spec), make_scheme(spec)
    T = g["long_t"] * float(case.T)
    ms, nx = g["max_samples"], g["nx_stab"]

    def limit_of(s: Scheme) -> float | None:
        try:
            return cfl_limit(case, s, nx)
        except Exception:  # noqa: BLE001
            return None

    out = [Task(case_spec, spec, nx, cfl=c, T=T, max_samples=ms, group="stability", timed=False)
           for c in stability_cfls(limit_of(scheme), g["cfl_points"])]
    for pname, param in type(scheme).params.items():
        if not param.sweep or f"{pname}=" in spec:
            continue
        values = param.sweep if g["param_sweep"] == "all" else dict.fromkeys(
            (param.sweep[0], param.sweep[-1]))
        for value in values:
            variant = _with_param(spec, pname, value)
            try:
                vs = make_scheme(variant)
            except Exception:  # noqa: BLE001 - a value outside the declared range: skip it
                continue
            cfls = stability_cfls(limit_of(vs), 3)
            out += [Task(case_spec, vs.spec, nx, cfl=c, T=T, max_samples=ms,
                         group="stability", timed=False) for c in cfls]
    return out


def _with_param(spec: str, name: str, value: float) -> str:
    text = f"{value:g}"
    if spec.endswith("]"):
        return f"{spec[:-1]},{name}={text}]"
    return f"{spec}[{name}={text}]"
