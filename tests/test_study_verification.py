"""The study's rows on production codes' verification cases: every scheme once at the
case's published grid, and the report's table of their errors against the published
values, with how many are within the published tolerances."""

from __future__ import annotations

import pandas as pd

from contact_bench.api.registry import cases, make_case
from contact_bench.output.report import write_report
from contact_bench.sweeps.analysis import verification_table
from contact_bench.sweeps.study import plan_study
from contact_bench.sweeps.sweep import run_sweep

VERIFICATION = tuple(n for n, c in sorted(cases().plugins.items()) if c.published)


def test_every_declared_verification_case_gets_one_run_per_scheme_at_its_grid() -> None:
    assert {"aster_sdnv100", "ansys_vm265"} <= set(VERIFICATION)
    specs = ["redistributed", "standard"]
    tasks = [t for t in plan_study(scheme_specs=specs, case_specs=["clamped_bar"])
             if t.group == "verification"]
    assert tasks == []  # only the scenes asked for
    tasks = [t for t in plan_study(scheme_specs=specs, case_specs=list(VERIFICATION))]
    assert {t.group for t in tasks} == {"verification"}  # no refinement sweep of theirs
    assert sorted((t.case, t.scheme) for t in tasks) == sorted(
        (make_case(c).spec, s) for c in VERIFICATION for s in specs)
    for t in tasks:
        case = make_case(t.case)
        assert (t.nx, t.dt, t.T) == (case.nx, case.dt, case.T)
    assert not [t for t in plan_study(quick=True, scheme_specs=specs)
                if t.group == "verification"]


def test_verification_table_counts_errors_within_the_published_tolerances(tmp_path) -> None:
    case = make_case("ansys_vm265")
    tasks = [t for t in plan_study(scheme_specs=["redistributed", "standard"],
                                   case_specs=["ansys_vm265"])]
    table = run_sweep(tasks, jobs=1, repeats=1, quiet=True).table
    tol = {q: p.tolerance for q, p in case.published.items()}
    ver = verification_table(table, tol).set_index("scheme")
    # the modified mass meets every published value; the standard mass's contact node
    # chatters, so its contact ends at the first bounce
    assert ver.loc["redistributed", "within"] == f"{len(tol)}/{len(tol)}"
    assert ver.loc["standard", "within"] != f"{len(tol)}/{len(tol)}"
    errs = ver.loc["standard", [f"err_published_{q}" for q in tol]].astype(float)
    assert int(ver.loc["standard", "within"].split("/")[0]) == int(
        sum(errs[f"err_published_{q}"] <= t for q, t in tol.items()))
    assert verification_table(table[table["group"] != "verification"], tol).empty
    write_report(table, tmp_path, argv=["study"])
    md = (tmp_path / "verification_ansys_vm265.md").read_text()
    assert "within" in md and "redistributed" in md
    assert "Against the published values" in (tmp_path / "index.html").read_text()
    assert isinstance(pd.read_csv(tmp_path / "verification_ansys_vm265.csv"), pd.DataFrame)


def test_the_short_manufactured_scene_plans_no_stability_run_longer_than_its_T() -> None:
    """manufactured's T is 1 at a scene dt of 0.02: 16 and 64 x that dt would leave fewer
    than `MIN_STABILITY_STEPS` steps (64 x: dt > T, a bad input that used to stop the
    whole study before its first run); the plan leaves them out and every task passes
    the sweep's input checks."""
    from dataclasses import asdict

    from contact_bench.api.registry import make_scheme
    from contact_bench.sweeps.study import plan_sparse
    from contact_bench.sweeps.sweep import check_task

    tasks = plan_sparse("manufactured", ["redistributed"])
    assert any("stability" in t.group for t in tasks)
    for t in tasks:
        check_task(asdict(t), (make_case(t.case), make_scheme(t.scheme)))
