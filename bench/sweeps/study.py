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
  three CFL; every scene declaring `stiff` (steel_bar), where each parameter value runs
  the scheme's whole CFL grid (and 0.95, 1.05 x its own limit): a map of CFL against the
  parameter (`contact_bench.sweeps.analysis.parameter_maps`); none for a scheme whose
  dt only samples (`Traits.adaptive`);
- energy: the refine runs at nx = nx_energy (traces of E(t) kept in the table);
- time order away from impacts: every scheme spec of the table, measured on a smooth
  motion without contact (`contact_bench.sweeps.time_order`, outside the sweep and its
  cache) and shown next to its declared order (`Traits.order`).

The sparse part (2D/3D scenes: every body scene, whose `form` is "sparse", on the grids
it declares in `Case.study`; every scheme, or, when a spec cannot run the scene and the
scheme takes a lumped `mass`, its lumped variant):

- refine: each declared variant (`StudyGrid.specs`) at each declared nx, at the CFL of
  the scene's dt on the coarsest mesh (0.9 x the declared limit when that is smaller),
  timed: work-precision on each error column the scene fills (`Case.quantities`, or
  the 1D norms of an embedded bar), energy drift at the finest nx;
- stability over dt, on the coarsest mesh the scene accepts with the scheme's mass (a
  scene may refuse a mass that is not positive definite on its coarse meshes: those
  refine rows are errors that say why): the refine run, and multiples of the
  declared limit for explicit schemes (SPARSE["limit_factors"]), of the scene's dt
  otherwise (SPARSE["dt_factors"], each leaving at least `MIN_STABILITY_STEPS` steps
  in the run's T);
- stability over each parameter declaring a `Param.sweep` (penalty gamma_p, Nitsche
  gamma0, ...), at the refine CFL on that mesh.

Verification cases of production codes (scenes declaring `Case.published`: code_aster's
SDNV100, Ansys's VM265): every scheme once at the scene's own grid, nx and dt (the
published case's), group "verification"; the report tabulates their err_published_<q>
against the published tolerances (`contact_bench.sweeps.analysis.verification_table`).
The quick study leaves them out.

The friction part (`plan_friction`; `contact-bench study --part friction`): every scene
declaring frictional variants (`StudyGrid.friction`: a Coulomb coefficient `mu` > 0),
with every scheme that runs them (one that cannot, e.g. one declaring no friction law,
`Traits.friction`, is a 'not applicable' row saying why, run nowhere):

- work-precision: each variant at each declared nx, at the CFL of the scene's dt on the
  coarsest mesh (as the sparse part), timed, group "friction-refine";
- stability in CFL against mu: on the coarsest mesh, each variant with its `mu` set to
  each of FRICTION["mus"], over the CFL grid of the 1D part's stability search
  (`stability_cfls`) keeping at least `MIN_STABILITY_STEPS` steps in T = long_t x the
  study's T, group "friction-stability"
  (`contact_bench.sweeps.analysis.friction_stability_table`: the largest stable CFL).

The quick study runs the scenes' small variants instead (`StudyGrid.small`, `small_T`),
each scheme on the first of `small_nx` that accepts its mass, with fewer factors and the
ends of each parameter sweep.

At most `max_samples` samples are kept per run (the stride grows with the number of
steps): the metrics' cost grows with the samples, and the sampling interval stays
about T / max_samples across refinements. `FULL` is the published grid, not sized for a
time budget: on a quiet 2-core machine its main part takes over an hour, two thirds of
it the serial timing pass of the refine runs (docs/study.md, "Where the time goes");
`quick=True` is the same study on tiny grids (a smoke test, about a minute).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from contact_bench.api.params import expand_spec, format_value, parse_spec
from contact_bench.api.plugin import Case, Scheme
from contact_bench.api.registry import cases, make_case, make_scheme, schemes
from contact_bench.core.errors import BenchError
from contact_bench.harness.runner import declared_limit, problem_for
from contact_bench.sweeps.sweep import Task

FULL = {"nx_refine": [20, 40, 80, 160, 320, 640], "nx_fine": 640, "dt_points": 5,
        "nx_stab": 40, "cfl_points": 8, "nx_energy": 160, "max_samples": 1000,
        "long_t": 3.0, "param_sweep": "all"}
QUICK = {"nx_refine": [10, 20, 40], "nx_fine": 40, "dt_points": 3,
         "nx_stab": 10, "cfl_points": 3, "nx_energy": 20, "max_samples": 300,
         "long_t": 2.0, "param_sweep": "ends"}


SPARSE = {"dt_factors": (4.0, 16.0, 64.0), "limit_factors": (0.5, 0.95, 1.05, 2.0),
          "max_samples": 500, "param_sweep": "all"}
#: the fewest steps a stability run of the sparse part makes (larger dt are left out)
MIN_STABILITY_STEPS = 10
SPARSE_QUICK = {"dt_factors": (16.0,), "limit_factors": (0.95, 1.05), "max_samples": 200,
                "param_sweep": "ends"}

#: the friction part (module docstring): the Coulomb coefficients of its stability runs,
#: the points of their CFL grid, their T as a multiple of the scene's study T
FRICTION = {"mus": (0.0, 0.1, 0.3, 0.8), "cfl_points": 8, "long_t": 10.0, "max_samples": 1000}
FRICTION_QUICK = {"mus": (0.0, 0.3, 0.8), "cfl_points": 4, "long_t": 2.0,
                  "max_samples": 200}
#: the group tags of the friction part's rows (none shared with the other parts)
FRICTION_GROUPS = ("friction-refine", "friction-stability")
#: the scene parameter the friction part varies (every frictional variant has it)
FRICTION_PARAM = "mu"


def cfl_limit(case: Case, scheme: Scheme, nx: int) -> float | None:
    """The scheme's declared stability limit as a CFL number on this scene's mesh."""
    return _limit_as_cfl(case, scheme, problem_for(case, scheme, nx))


def scene_cfl(case: Case, scheme: Scheme, nx: int) -> tuple[float, float | None]:
    """The scene's own dt as a CFL number on this mesh, and the declared limit as one."""
    semi = problem_for(case, scheme, nx)
    return float(case.dt) * semi.c_max / semi.hmin, _limit_as_cfl(case, scheme, semi)


def _limit_as_cfl(case: Case, scheme: Scheme, semi: Any) -> float | None:
    limit = declared_limit(case, scheme, semi)
    return None if limit is None else limit * semi.c_max / semi.hmin


def stability_cfls(limit: float | None, points: int) -> list[float]:
    """0.1 to 100 (no limit) or to twice the limit (with points just below/above it);
    points = 0: only those two (none without a limit)."""
    top = 100.0 if limit is None else 2.0 * limit
    grid = ([] if points < 1 else list(np.geomspace(0.1, top, points)) if top > 0.1
            else [top])
    if limit is not None:
        grid += [0.95 * limit, 1.05 * limit]
    return sorted({float(f"{c:.3g}") for c in grid})


def default_schemes() -> list[str]:
    return [cls().spec for cls in schemes().plugins.values()]


def plan_study(quick: bool = False, scheme_specs: Sequence[str] | None = None,
               case_specs: Sequence[str] | None = None) -> list[Task]:
    """The tasks of the study (see the module docstring)."""
    g = QUICK if quick else FULL
    specs = _study_specs(scheme_specs, quick)
    given = [s for spec in case_specs or () for s in expand_spec(spec)]
    sparse = [s for s in given if make_case(s).form != "banded1d"]
    scenes = [s for s in given if s not in sparse and not make_case(s).published]
    if not case_specs:
        scenes = [n for n, c in cases().plugins.items() if c.in_default_run]
        sparse = [n for n, c in cases().plugins.items() if c.form != "banded1d"
                  and (c.study is None or c.study.in_default_study)]
    stiff = ([n for n, c in cases().plugins.items() if c.stiff and n not in scenes]
             if scenes else [])
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
    for case_spec in sparse:
        tasks += plan_sparse(case_spec, specs, quick)
    verification = ([n for n, c in cases().plugins.items() if c.published]
                    if not case_specs else [s for s in given if make_case(s).published])
    if not quick:
        for case_spec in verification:
            tasks += plan_verification(case_spec, specs)
    return tasks


def plan_verification(case_spec: str, specs: Sequence[str]) -> list[Task]:
    """Every spec once on a verification case (`Case.published`) at its own nx, dt and
    T (module docstring)."""
    case = make_case(case_spec)
    return [Task(case.spec, spec, int(case.nx), dt=float(case.dt), T=float(case.T),
                 stride=int(case.stride), group="verification", timed=False)
            for spec in specs]


def _variants(case: Case, spec: str) -> str | None:
    """The spec that runs the scene: itself, or its lumped-mass variant when it cannot
    and the scheme takes a lumped `mass` (None: neither runs it)."""
    scheme = make_scheme(spec)
    if not (scheme.cannot_run(case) or case.cannot_run(scheme)):
        return spec
    mass = type(scheme).params.get("mass")
    if mass is None or not mass.choices or "lumped" not in mass.choices or "mass=" in spec:
        return spec  # a 'not applicable' row with its reason
    lumped = make_scheme(_with_param(spec, "mass", "lumped"))
    return lumped.spec if not (lumped.cannot_run(case) or case.cannot_run(lumped)) else spec


def _coarsest_accepted(case: Case, scheme: Scheme, nxs: Sequence[int]
                       ) -> tuple[int, float, float | None] | None:
    """The coarsest of nxs whose mesh the scene accepts with the scheme's mass (a scene
    may refuse a mass that is not positive definite on coarse meshes), with the scene's
    dt and the declared limit as CFL numbers on it (`scene_cfl`); None when it refuses
    every one."""
    for nx in nxs:
        try:
            return (int(nx), *scene_cfl(case, scheme, nx))
        except Exception:  # noqa: BLE001 - a refused mesh: its error row says why
            continue
    return None


def plan_sparse(case_spec: str, specs: Sequence[str], quick: bool = False) -> list[Task]:
    """The sparse part of the study for one scene (see the module docstring): its
    declared variants (`Case.study`) x every spec (a 'not applicable' row where it cannot
    run the scene)."""
    base = make_case(case_spec)
    grid = base.study
    if grid is None:
        return []
    g = SPARSE_QUICK if quick else SPARSE
    ms = g["max_samples"]
    if quick:  # one mesh a scheme: the first of small_nx that accepts its mass
        variants, nxs, T = [grid.small], list(grid.small_nx[:1]), grid.small_T
    else:
        variants = list(grid.specs) if case_spec == type(base).name else [case_spec]
        nxs, T = list(grid.nx), grid.T
    tasks: list[Task] = []
    for variant in variants:
        case = make_case(variant)
        runnable: dict[str, tuple[Scheme, tuple[int, float, float | None] | None]] = {}
        for spec in dict.fromkeys(v for s in specs if (v := _variants(case, s)) is not None):
            scheme = make_scheme(spec)
            if scheme.cannot_run(case) or case.cannot_run(scheme):
                tasks.append(Task(case.spec, spec, nxs[0], T=T, group="refine", timed=False))
            else:
                runnable[spec] = scheme, _coarsest_accepted(
                    case, scheme, grid.small_nx if quick else nxs)
        # the scene's dt as a CFL on its coarsest mesh (c_max / hmin: the mesh's, the same
        # for every scheme that mesh accepts)
        scene_cfl0 = next((m[1] for _, m in runnable.values() if m and m[0] == nxs[0]), None)
        for spec, (scheme, measured) in runnable.items():
            nx_stab, cfl0, lim = measured or (nxs[0], None, None)
            if measured is not None and scene_cfl0 is not None:
                cfl0 = scene_cfl0
            cfl_r = None if cfl0 is None else float(f"{cfl0:.4g}")
            if cfl_r is not None and lim is not None:
                cfl_r = min(cfl_r, float(f"{0.9 * lim:.4g}"))
            mine = [nx_stab] if quick else nxs
            for nx in mine:
                group = "refine" + (";stability" if nx == nx_stab else "") + (
                    ";energy" if nx == mine[-1] else "")
                tasks.append(Task(case.spec, spec, nx, cfl=cfl_r, T=T, max_samples=ms,
                                  group=group))
            if cfl_r is None or scheme.traits().adaptive:  # every mesh refused (its
                continue  # error rows say why), or dt only samples: nothing to destabilise
            cfls = ([f * lim for f in g["limit_factors"]] if lim is not None
                    else [f * cfl0 for f in g["dt_factors"]])
            if lim is None:  # multiples of the scene's dt (cfl0 on this mesh): one that
                # leaves fewer than MIN_STABILITY_STEPS steps in T tests nothing (a short
                # scene: manufactured, T = 1)
                t_run = float(case.T if T is None else T)
                cfls = [c for c in cfls
                        if float(case.dt) * c / cfl0 * MIN_STABILITY_STEPS <= t_run]
            tasks += [Task(case.spec, spec, nx_stab, cfl=float(f"{c:.4g}"), T=T,
                           max_samples=ms, group="stability", timed=False) for c in cfls]
            tasks += [Task(case.spec, vs.spec, nx_stab, cfl=cfl_r, T=T, max_samples=ms,
                           group="stability;param", timed=False)
                      for vs in _param_variants(spec, scheme, g["param_sweep"])]
    # runs of one mesh and dt one after the other: a scene's numerical reference (kept by
    # the worker for its next runs) is computed about once per worker, not once per scheme
    return sorted(tasks, key=lambda t: (t.case, t.nx or 0, t.cfl or 0.0))


def _stability(case_spec: str, spec: str, g: dict) -> list[Task]:
    case, scheme = make_case(case_spec), make_scheme(spec)
    if scheme.traits().adaptive:  # dt only samples: nothing to destabilise
        return []
    T = g["long_t"] * float(case.T)
    ms, nx = g["max_samples"], g["nx_stab"]

    def limit_of(s: Scheme) -> float | None:
        try:
            return cfl_limit(case, s, nx)
        except Exception:  # noqa: BLE001
            return None

    base = stability_cfls(limit_of(scheme), g["cfl_points"])
    out = [Task(case_spec, spec, nx, cfl=c, T=T, max_samples=ms, group="stability", timed=False)
           for c in base]
    for vs in _param_variants(spec, scheme, g["param_sweep"]):
        if case.stiff:  # a map: every parameter value on the scheme's whole CFL grid,
            # and just below and above the value's own limit
            cfls = sorted(set(base) | set(stability_cfls(limit_of(vs), 0)))
        else:
            cfls = stability_cfls(limit_of(vs), 3)
        out += [Task(case_spec, vs.spec, nx, cfl=c, T=T, max_samples=ms,
                     group="stability", timed=False) for c in cfls]
    return out


def _param_variants(spec: str, scheme: Scheme, which: str) -> list[Scheme]:
    """The scheme at each value of its declared parameter sweeps (`Param.sweep`; `which`
    "all" values or only the two ends), for the parameters the spec does not fix; values
    outside the declared range are skipped."""
    out = []
    for pname, param in type(scheme).params.items():
        if not param.sweep or f"{pname}=" in spec:
            continue
        values = param.sweep if which == "all" else dict.fromkeys(
            (param.sweep[0], param.sweep[-1]))
        for value in values:
            try:
                out.append(make_scheme(_with_param(spec, pname, value)))
            except Exception:  # noqa: BLE001 - a value outside the declared range: skip it
                continue
    return out


def _study_specs(scheme_specs: Sequence[str] | None, quick: bool) -> list[str]:
    """The scheme specs a part of the study runs: the given ones (every registered scheme
    when none is given), each expanded, with the quick study's parameter values when quick."""
    specs = [s for spec in (scheme_specs or default_schemes()) for s in expand_spec(spec)]
    return [_quick_spec(s) for s in specs] if quick else specs


def _quick_spec(spec: str) -> str:
    """The spec with the quick study's value of each parameter it does not fix
    (`Param.quick`)."""
    scheme = make_scheme(spec)
    for name, param in type(scheme).params.items():
        if param.quick is not None and f"{name}=" not in spec:
            spec = _with_param(spec, name, param.quick)
    return make_scheme(spec).spec


def _with_param(spec: str, name: str, value: float | str) -> str:
    text = value if isinstance(value, str) else f"{value:g}"
    if spec.endswith("]"):
        return f"{spec[:-1]},{name}={text}]"
    return f"{spec}[{name}={text}]"


def at_param(spec: str, name: str, value: float) -> str:
    """The canonical spec of the scene `spec` with its parameter `name` set to `value`
    (replacing a value the spec gives)."""
    base, params = parse_spec(spec)
    params = dict(params, **{name: format_value(float(value))})
    return make_case(f"{base}[{','.join(f'{k}={v}' for k, v in params.items())}]").spec


def friction_variants(case_specs: Sequence[str] | None = None) -> list[tuple[str, Any]]:
    """(variant spec, its scene's StudyGrid) of the friction part: every registered scene's
    `StudyGrid.friction` variants; with named scenes, a bare name's declared variants and
    any other spec with friction (`Case.friction` > 0) as itself."""
    out: list[tuple[str, Any]] = []
    if not case_specs:
        for c in cases().plugins.values():
            if c.study is not None:
                out += [(make_case(v).spec, c.study) for v in c.study.friction]
        return out
    for spec in (s for given in case_specs for s in expand_spec(given)):
        case = make_case(spec)
        grid = case.study
        if grid is None:
            continue
        if spec == type(case).name:
            out += [(make_case(v).spec, grid) for v in grid.friction]
        elif case.friction() > 0:
            out.append((case.spec, grid))
    return out


def plan_friction(quick: bool = False, scheme_specs: Sequence[str] | None = None,
                  case_specs: Sequence[str] | None = None) -> list[Task]:
    """The tasks of the friction part (module docstring)."""
    g = FRICTION_QUICK if quick else FRICTION
    specs = _study_specs(scheme_specs, quick)
    ms = g["max_samples"]
    tasks: list[Task] = []
    for variant, grid in friction_variants(case_specs):
        case = make_case(variant)
        if FRICTION_PARAM not in type(case).params:
            raise BenchError(f"{variant}: the friction part varies the scene's parameter "
                             f"{FRICTION_PARAM!r}, which it does not have")
        nxs = list(grid.small_nx[:2]) if quick else list(grid.nx)
        T = grid.small_T if quick else grid.T
        runnable: dict[str, tuple[Scheme, tuple[int, float, float | None] | None]] = {}
        for spec in dict.fromkeys(v for s in specs if (v := _variants(case, s)) is not None):
            scheme = make_scheme(spec)
            if scheme.cannot_run(case) or case.cannot_run(scheme):  # refused: one row
                tasks.append(Task(case.spec, spec, nxs[0], T=T, group=FRICTION_GROUPS[0],
                                  timed=False))
            else:
                runnable[spec] = scheme, _coarsest_accepted(case, scheme, nxs)
        scene_cfl0 = next((m[1] for _, m in runnable.values() if m and m[0] == nxs[0]), None)
        t_stab = g["long_t"] * float(case.T if T is None else T)
        if grid.friction_stability_T is not None:  # the scene's declared cap
            t_stab = min(t_stab, float(grid.friction_stability_T))
        for spec, (scheme, measured) in runnable.items():
            nx_stab, cfl0, lim = measured or (nxs[0], None, None)
            if measured is not None and scene_cfl0 is not None:
                cfl0 = scene_cfl0
            cfl_r = None if cfl0 is None else float(f"{cfl0:.4g}")
            if cfl_r is not None and lim is not None:
                cfl_r = min(cfl_r, float(f"{0.9 * lim:.4g}"))
            tasks += [Task(case.spec, spec, nx, cfl=cfl_r, T=T, max_samples=ms,
                           group=FRICTION_GROUPS[0]) for nx in nxs]
            if cfl0 is None or scheme.traits().adaptive:  # every mesh refused (its error
                continue  # rows say why), or dt only samples: nothing to destabilise
            # the CFL grid, less the CFL leaving fewer than MIN_STABILITY_STEPS steps
            cfls = [c for c in stability_cfls(lim, g["cfl_points"])
                    if float(case.dt) * c / cfl0 * MIN_STABILITY_STEPS <= t_stab]
            tasks += [Task(at_param(case.spec, FRICTION_PARAM, mu), spec, nx_stab,
                           cfl=c, T=t_stab, max_samples=ms, group=FRICTION_GROUPS[1],
                           timed=False) for mu in g["mus"] for c in cfls]
    return sorted(tasks, key=lambda t: (t.case, t.nx or 0, t.cfl or 0.0))
