"""The study's sparse part: the quick study of every sparse scene picks up
every scheme that integrates sparse problems and every declared parameter sweep from
the registry, and its report draws work-precision on each error column a scene fills."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from contact_bench.api.registry import cases, make_case, make_scheme, schemes
from contact_bench.core.errors import BenchError
from contact_bench.output.report import slug, write_report
from contact_bench.sweeps import analysis
from contact_bench.sweeps.analysis import error_columns
from contact_bench.sweeps.study import plan_sparse, plan_study
from contact_bench.sweeps.sweep import run_sweep

SPARSE = tuple(n for n, c in sorted(cases().plugins.items()) if c.form == "sparse")
SPARSE_SCHEMES = tuple(sorted(schemes().plugins))


@pytest.fixture(scope="module")
def quick() -> pd.DataFrame:
    tasks = plan_study(quick=True, case_specs=list(SPARSE))
    assert {make_case(t.case).form for t in tasks} == {"sparse"}  # no 1D scene added
    # no timing pass (repeats=0): nothing here reads its timings (work-precision plots the
    # runs' own step_s), a failing timing would only be a note, and it repeats each timed
    # run three times; tests/test_distributed_study.py and test_sweep.py test the pass
    return run_sweep(tasks, jobs=1, repeats=0, quiet=True).table


def test_plan_follows_the_declarations() -> None:
    full = [t for n in SPARSE for t in plan_sparse(n, [c().spec for c in
                                                       schemes().plugins.values()])]
    for name in SPARSE:
        grid = cases().plugins[name].study
        mine = [t for t in full if make_case(t.case).name == name]
        assert {t.case for t in mine} == {make_case(s).spec for s in grid.specs}
        assert {t.nx for t in mine if "refine" in t.group} == set(grid.nx)
    # explicit schemes: stability on both sides of the declared limit; every declared
    # parameter sweep at each of its values
    for t in full:
        assert make_scheme(t.scheme).name in SPARSE_SCHEMES
    for name in SPARSE_SCHEMES:
        for pname, param in schemes().plugins[name].params.items():
            for value in param.sweep or ():
                try:
                    spec = make_scheme(f"{name}[{pname}={value:g}]").spec
                except BenchError:  # a value outside the declared range: skipped
                    continue
                assert any(t.scheme == spec and "stability" in t.group for t in full), spec


def test_a_mass_refused_on_coarse_meshes_is_planned_on_the_first_mesh_accepting_it() -> None:
    """The ball refuses the redistributed mass at nx 2 (no positive definite mass keeps
    its moments by the construction): its refine rows keep the scene's CFL (another
    scheme's, on nx 2) and its stability runs move to nx 4, the coarsest mesh it runs."""
    tasks = plan_sparse("sphere_drop", ["redistributed", "nitsche"])
    refine = {(t.scheme, t.nx): t for t in tasks if "refine" in t.group}
    assert {nx for s, nx in refine if s == "redistributed"} == {2, 4, 8}
    assert refine["redistributed", 8].cfl == refine["nitsche", 8].cfl is not None
    stab = {(t.scheme, t.nx) for t in tasks if "stability" in t.group}
    assert {nx for s, nx in stab if s == "redistributed"} == {4}
    assert {nx for s, nx in stab if s == "nitsche"} == {2}


def test_quick_study_covers_every_sparse_scene_and_scheme(quick: pd.DataFrame) -> None:
    df = quick
    assert set(df["case"]) == {make_case(cases().plugins[n].study.small).spec for n in SPARSE}
    assert set(df["scheme_name"].dropna()) == set(SPARSE_SCHEMES)
    groups = {g for gs in df["group"] for g in gs.split(";")}
    assert {"refine", "energy", "stability", "param"} <= groups
    ran = df[df["status"].isin(["ok", "unstable"])]
    assert set(ran["scheme_name"]) == set(SPARSE_SCHEMES)  # each runs somewhere
    bad = df[df["status"] == "error"]
    assert bad["notes"].str.len().gt(0).all()
    # explicit schemes were run just below and just above their declared limit
    expl = ran[ran["cfl_limit"].notna() & ran["group"].str.contains("stability")]
    for (_case, _scheme), g in expl.groupby(["case", "scheme"]):
        if g["group"].str.contains("param").all():  # a parameter value: the scene's dt only
            continue
        ratio = (g["cfl"] / g["cfl_limit"]).to_numpy(float)
        assert np.any(np.isclose(ratio, 0.95, rtol=1e-2)), ratio
        assert np.any(np.isclose(ratio, 1.05, rtol=1e-2)), ratio


def test_report_draws_every_error_column_of_a_scene(quick: pd.DataFrame, tmp_path) -> None:
    # the scenes with more than one reference quantity (the report's figures cost)
    several = [c for c in dict.fromkeys(quick["case"]) if len(make_case(c).quantities) > 1]
    assert several
    table = quick[quick["case"].isin(several)]
    written = {p.name for p in write_report(table, tmp_path)}
    for case in several:
        rows = table[table["case"] == case]
        refined = analysis.select(rows, "refine")
        cols = error_columns(refined if len(refined) else rows)
        declared = make_case(case).quantities
        assert {f"err_{q}" for q in declared} >= set(cols) - {"err_u_linf_l2"}
        for k, col in enumerate(cols):
            stem = f"work_precision_{slug(case)}" + ("" if k == 0 else f"_{col}")
            assert f"{stem}.png" in written, (case, col, sorted(written))
        if make_case(case).quantities:
            assert cols, f"{case}: no error column filled"
        if make_case(case).body(int(rows["nx"].min())) is not None:  # index.html shows
            assert f"snapshots_{slug(case)}.png" in written, case  # the deformed body
    page = (tmp_path / "index.html").read_text()
    assert page.count('<img src="snapshots_') == sum(
        make_case(c).body(int(table[table["case"] == c]["nx"].min())) is not None
        for c in several)


def test_a_scheme_whose_dt_only_samples_gets_no_stability_runs() -> None:
    """ode_adaptive picks its own steps (`Traits.adaptive`): runs at other sampling
    intervals would integrate the same ODE again; hht beside it keeps its runs."""
    tasks = plan_sparse("two_discs", ["ode_adaptive", "hht"])
    extra = {(make_scheme(t.scheme).name, t.group) for t in tasks
             if t.group.startswith("stability")}
    assert {s for s, _ in extra} == {"hht"}
    assert any(make_scheme(t.scheme).name == "ode_adaptive" for t in tasks)


def test_the_quick_study_runs_a_parameter_at_its_quick_value_unless_the_spec_fixes_it() -> None:
    quick = {t.scheme for t in plan_study(quick=True, scheme_specs=["ode_adaptive"],
                                          case_specs=["two_discs"])}
    assert quick == {make_scheme("ode_adaptive[rtol=1e-5]").spec}
    fixed = {t.scheme for t in plan_study(quick=True, scheme_specs=["ode_adaptive[rtol=1e-9]"],
                                          case_specs=["two_discs"])}
    assert fixed == {make_scheme("ode_adaptive[rtol=1e-9]").spec}
    full = {t.scheme for t in plan_study(scheme_specs=["ode_adaptive"], case_specs=["two_discs"])}
    assert full == {make_scheme("ode_adaptive").spec}
