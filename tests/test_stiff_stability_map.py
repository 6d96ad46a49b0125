"""The stiff scenes' stability part maps CFL against the penalty parameter: every value
of a swept parameter (penalty, nitsche, armero_petocz: 1 ... 1e8) runs the scheme's whole
CFL grid, so the report draws a (parameter x CFL) map, not one CFL per value."""

from __future__ import annotations

import pytest

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core.errors import BenchError
from contact_bench.sweeps.analysis import parameter_maps
from contact_bench.sweeps.study import FULL, plan_study
from contact_bench.sweeps.sweep import run_sweep

PENALISED = ("penalty", "nitsche", "armero_petocz")
PARAM = {"penalty": "gamma_p", "nitsche": "gamma0", "armero_petocz": "gamma_p"}


def _stability_cfls(tasks, spec):
    return sorted(t.cfl for t in tasks if t.scheme == spec and "stability" in t.group)


@pytest.mark.parametrize("name", PENALISED)
def test_the_full_plan_runs_every_parameter_value_on_the_whole_cfl_grid(name):
    case = make_case("steel_bar")
    assert case.stiff
    tasks = [t for t in plan_study(scheme_specs=[name], case_specs=["steel_bar"])
             if t.case == "steel_bar"]
    base = _stability_cfls(tasks, name)
    assert len(base) >= FULL["cfl_points"]
    param = type(make_scheme(name)).params[PARAM[name]]
    assert param.sweep[0] == 1.0 and param.sweep[-1] == 1e8
    mapped = 0
    for value in param.sweep:
        try:
            spec = make_scheme(f"{name}[{PARAM[name]}={value:g}]").spec
        except BenchError:  # outside the declared range (nitsche's gamma0 = 1): not run
            continue
        mapped += 1
        mine = _stability_cfls(tasks, spec)
        assert set(base) <= set(mine), (spec, base, mine)
    assert mapped >= 4


def test_a_tiny_grid_gives_the_map():
    """The quick plan (nx 10, the sweep's two ends) for penalty on steel_bar, run: the
    report's map has both values of gamma_p as rows and the whole CFL grid as columns,
    every cell classified."""
    tasks = [t for t in plan_study(quick=True, scheme_specs=["penalty"],
                                   case_specs=["steel_bar"])
             if "stability" in t.group]
    res = run_sweep(tasks, repeats=1, quiet=True)
    maps = parameter_maps(res.table, "steel_bar")
    table = maps[("penalty", "gamma_p")]
    assert list(table.index) == [1.0, 1e8]
    assert table.shape[1] >= 3 and table.notna().all().all()
    assert set(table.to_numpy().ravel()) <= {"stable", "energy-growing", "blown up"}
