"""The study's friction part (`contact_bench.sweeps.study.plan_friction`, `contact-bench
study --part friction`) in its quick mode on the sliding block: every scheme declaring
friction has rows, a scheme without a friction law is refused (one 'not applicable' row
per variant, run nowhere), the stability table has one row per (scheme, mu), a run that
fails is an error row and the part goes on, and its report writes the friction_* files."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from contact_bench.api.registry import PLUGINS_ENV, make_case, make_scheme
from contact_bench.cli.main import main
from contact_bench.output.friction_report import write_friction_report
from contact_bench.sweeps import analysis
from contact_bench.sweeps.cache import Cache
from contact_bench.sweeps.study import (
    FRICTION_QUICK,
    MIN_STABILITY_STEPS,
    default_schemes,
    plan_friction,
)
from contact_bench.sweeps.sweep import run_sweep

#: penalty, except that it fails (raises in `prepare`) on a scene with mu >= 0.8
FAILER = '''"""A frictional scheme failing on purpose at mu >= 0.8 (a test of a failing run)."""
from contact_bench.schemes.penalty import Penalty


class FrictionFailer(Penalty):
    name = "friction_failer"

    def prepare(self, problem, dt):
        mu = problem.contact.friction
        if mu is not None and len(mu) and float(max(mu)) >= 0.8:
            raise RuntimeError("friction_failer fails at mu >= 0.8 on purpose")
        return super().prepare(problem, dt)
'''
VARIANTS = ("sliding_block[mu=0.3]", "sliding_block[mu=0.3,dim=3]")


@pytest.fixture(scope="module")
def part(tmp_path_factory: pytest.TempPathFactory) -> tuple[pd.DataFrame, Path]:
    tmp = tmp_path_factory.mktemp("friction")
    (tmp / "plugins").mkdir()
    (tmp / "plugins" / "friction_failer.py").write_text(FAILER)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(PLUGINS_ENV, str(tmp / "plugins"))
        specs = default_schemes()
        assert "friction_failer" in specs
        tasks = plan_friction(quick=True, scheme_specs=specs, case_specs=["sliding_block"])
        res = run_sweep(tasks, jobs=1, cache=Cache(tmp / "cache"), repeats=0, quiet=True)
    return res.table, tmp


def _declares_friction(spec: str) -> bool:
    return bool(make_scheme(spec).traits().friction)


def test_every_frictional_scheme_has_rows(part) -> None:
    df, _ = part
    frictional = [s for s in default_schemes() if _declares_friction(s)]
    assert len(frictional) >= 6  # today's: moreau_jean, penalty, nitsche, standard, ...
    refine = df[analysis.tagged(df, "friction-refine")]
    stab = df[analysis.tagged(df, "friction-stability")]
    for variant in VARIANTS:
        case = make_case(variant)
        for spec in frictional:
            mine = refine[(refine["case"] == case.spec) & (refine["scheme"] == spec)]
            if make_scheme(spec).cannot_run(case):  # nitsche in 3D: refused, says why
                assert list(mine["status"]) == ["not applicable"], (variant, spec)
                continue
            assert len(mine) == 2, (variant, spec)  # both small meshes
            if spec != "friction_failer":
                assert (mine["status"] == "ok").all(), mine[["nx", "status", "notes"]]
                # the sliding identity holds to round-off in every run
                assert (mine["err_sliding_momentum"].astype(float) < 1e-9).all()
                assert (mine["friction_work"].astype(float) < 0).all()
            assert (stab["scheme"] == spec).any(), spec


def test_no_frictionless_scheme_runs_a_frictional_scene(part) -> None:
    df, _ = part
    frictionless = [make_scheme(s).name for s in default_schemes()
                    if not _declares_friction(s)]
    assert "hht" in frictionless and "kane" in frictionless
    mine = df[df["scheme_name"].isin(frictionless)]  # the quick study's spec of each
    # one refused row per (variant, scheme), saying why; no stability run at any mu
    assert len(mine) == len(frictionless) * len(VARIANTS)
    assert (mine["status"] == "not applicable").all()
    assert mine["notes"].str.contains("declares no friction law").all()
    assert not analysis.tagged(mine, "friction-stability").any()


def test_the_stability_table_has_one_row_per_scheme_and_mu(part) -> None:
    df, _ = part
    stab = df[analysis.tagged(df, "friction-stability")]
    # every stability run keeps at least MIN_STABILITY_STEPS steps
    ran = stab[stab["status"] != "error"]
    assert len(ran) > 0 and (ran["steps"].astype(int) >= MIN_STABILITY_STEPS).all()
    table = analysis.friction_stability_table(df)
    mus = sorted(FRICTION_QUICK["mus"])
    for variant in VARIANTS:
        family = analysis.without_param(make_case(variant).spec, "mu")
        mine = table[table["case"] == family]
        runners = sorted([s for s in default_schemes() if _declares_friction(s)
                          and not make_scheme(s).cannot_run(make_case(variant))]
                         + ["friction_failer"])  # the fixture's plugin
        assert sorted(mine["scheme"].unique()) == runners
        assert len(mine) == len(runners) * len(mus)
        for _, g in mine.groupby("scheme"):
            assert sorted(g["mu"]) == mus
        # each row read again from its runs: the largest CFL with every run up to it stable
        for r in mine.itertuples():
            runs = stab[(stab["scheme"] == r.scheme) & (stab["case"].map(
                lambda s: analysis.without_param(s, "mu")) == family)
                & np.isclose(stab["case_mu"].astype(float), r.mu)]
            assert r.runs == len(runs) >= 1
            ok = runs[runs["stability"] == "stable"]["cfl"].astype(float)
            if r.all_stable:
                assert math.isclose(r.largest_stable_cfl, runs["cfl"].astype(float).max())
            elif not ok.empty and ok.min() < r.first_unstable_cfl:
                assert r.largest_stable_cfl < r.first_unstable_cfl


def test_a_failing_run_is_recorded_and_the_part_goes_on(part) -> None:
    df, _ = part
    fail = df[(df["scheme"] == "friction_failer") & (df["case_mu"].astype(float) >= 0.8)]
    assert len(fail) >= 2 and (fail["status"] == "error").all()
    assert fail["notes"].str.contains("fails at mu >= 0.8 on purpose").all()
    table = analysis.friction_stability_table(df)
    row = table[(table["scheme"] == "friction_failer") & (table["mu"] == 0.8)]
    assert len(row) == len(VARIANTS)
    assert (row["first_unstable_class"] == "error").all()
    assert row["largest_stable_cfl"].isna().all()
    # the same scheme below 0.8, and the other schemes at 0.8, ran
    assert (df[(df["scheme"] == "friction_failer") & (df["case_mu"].astype(float) < 0.8)]
            ["status"] == "ok").all()
    others = table[(table["scheme"] != "friction_failer") & (table["mu"] == 0.8)]
    assert others["largest_stable_cfl"].notna().all()


def test_the_stability_table_reads_the_classes() -> None:
    """A table made by hand: stable, stable, blown up, stable -> 2nd CFL; an error first
    -> none; all stable -> the last, flagged."""
    def rows(spec: str, scheme: str, classes: list[str | None], status: list[str]) -> list:
        return [{"case": spec, "scheme": scheme, "nx": 2, "T": 1.0, "cfl": c,
                 "stability": k, "status": s, "cfl_limit": None,
                 "group": "friction-stability"}
                for c, k, s in zip((0.1, 1.0, 10.0, 100.0), classes, status, strict=True)]
    df = pd.DataFrame(
        rows("sliding_block[mu=0.3]", "a", ["stable", "stable", "blown up", "stable"],
             ["ok", "ok", "unstable", "ok"])
        + rows("sliding_block[mu=0.8]", "a", [None, "stable", "stable", "stable"],
               ["error", "ok", "ok", "ok"])
        + rows("sliding_block", "a", ["stable"] * 4, ["ok"] * 4))
    t = analysis.friction_stability_table(df).set_index("mu")
    assert t.loc[0.3, "largest_stable_cfl"] == 1.0 and t.loc[0.3, "first_unstable_cfl"] == 10.0
    assert t.loc[0.3, "first_unstable_class"] == "blown up"
    assert math.isnan(t.loc[0.8, "largest_stable_cfl"])
    assert t.loc[0.8, "first_unstable_class"] == "error"
    assert t.loc[0.0, "largest_stable_cfl"] == 100.0 and bool(t.loc[0.0, "all_stable"])
    assert set(t["case"]) == {"sliding_block"}


def test_the_friction_work_against_the_finest_run() -> None:
    df = pd.DataFrame({"case": ["s"] * 3, "scheme": ["a"] * 3, "cfl": [0.5] * 3,
                       "nx": [2, 4, 8], "status": ["ok"] * 3,
                       "friction_work": [-1.2, -1.05, -1.0]})
    out = analysis.finest_run_error(df)[analysis.FRICTION_WORK_ERROR].to_numpy()
    np.testing.assert_allclose(out[:2], [0.2, 0.05], rtol=1e-12)
    assert math.isnan(out[2])


def test_the_report_and_the_command(part) -> None:
    df, tmp = part
    out = tmp / "report"
    files = {p.name for p in write_friction_report(df, out)}
    assert "friction.html" in files and "friction_refused.md" in files
    assert "friction_work_precision_sliding_block_mu_0.3.png" in files
    assert "friction_stability_sliding_block_dim_3.md" in files
    md = (out / "friction_stability_sliding_block.md").read_text()
    assert "moreau_jean" in md and "hht" not in md
    # the command, its runs from the fixture's cache: friction files only, the rest of
    # the study's files untouched (none written)
    cli_out = tmp / "cli"
    assert main(["study", "--part", "friction", "--quick", "--case", "sliding_block",
                 "--scheme", "moreau_jean", "--scheme", "hht", "--cache", str(tmp / "cache"),
                 "--out", str(cli_out), "--quiet", "-j", "1", "--repeats", "0"]) == 0
    names = {p.name for p in cli_out.iterdir()}
    assert "friction_sweep.csv" in names and "friction.html" in names
    assert "sweep.csv" not in names and "index.html" not in names
    table = pd.read_csv(cli_out / "friction_sweep.csv", comment="#")
    assert set(table[table["status"] == "ok"]["scheme"]) == {"moreau_jean"}


def test_the_oblique_impact_declares_a_short_stability_time() -> None:
    """oblique_impact's T (about 71: the flight, the impact and the rebound) times the
    part's 10 would make its stability runs 710 long: it declares 75 (one impact and
    the flight after it); the sliding block keeps the part's 10 T."""
    tasks = plan_friction(scheme_specs=["penalty"], case_specs=["oblique_impact",
                                                                 "sliding_block"])
    stab = [t for t in tasks if t.group == "friction-stability"]
    oblique = [t for t in stab if t.case.startswith("oblique_impact")]
    block = [t for t in stab if t.case.startswith("sliding_block")]
    assert oblique and block
    assert make_case("oblique_impact[mu=0.3]").T > 70.0
    assert {t.T for t in oblique} == {75.0}
    assert {t.T for t in block} == {10.0 * make_case("sliding_block[mu=0.3]").T}
