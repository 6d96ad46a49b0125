"""A table keeps every column its scenes declare (contact_bench.harness.runner.table_columns).

A plugin scene (a copy of clamped_bar) declares a quantity no built-in has, `my_quantity`,
and returns its relative error from `quantity_errors`. The column `err_my_quantity` and
its value reach `run_table`, `contact-bench run` (printed table, CSV, Markdown), a sweep's
`sweep.csv` and the tables `report` makes from it. The printed table shows the error
columns its scenes declare; the default run's is the one docs/default-run.md shows.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import pandas as pd
import pytest

from contact_bench.api.registry import PLUGINS_ENV, make_case
from contact_bench.cli.main import main, shown_columns
from contact_bench.harness.runner import (
    BASE_COLUMNS,
    TIMING_COLUMNS,
    quantity_columns,
    run_table,
)

ROOT = Path(__file__).resolve().parents[1]
SCENE = "my_quantity_bar"
COLUMN = "err_my_quantity"
VALUE = 0.125
#: tiny runs: a few hundred steps of the clamped bar before its first impact ends
RUN = ["--scheme", "redistributed", "--nx", "8", "--T", "1.5"]


@pytest.fixture
def plugins(tmp_path: Path) -> Path:
    """A plugin folder with clamped_bar copied as `my_quantity_bar`, which declares the
    quantity my_quantity and gives it the relative error VALUE."""
    text = (ROOT / "cases" / "clamped_bar.py").read_text(encoding="utf-8")
    for old, new in (('name = "clamped_bar"', f'name = "{SCENE}"'),
                     ("in_default_run = True", "in_default_run = False")):
        assert old in text
        text = text.replace(old, new)
    text += f'''
    quantities = frozenset({{"my_quantity"}})

    def quantity_errors(self, problem, traj, row):
        return {{"{COLUMN}": {VALUE!r}}}
'''
    folder = tmp_path / "plugins"
    folder.mkdir()
    (folder / f"{SCENE}.py").write_text(text, encoding="utf-8")
    return folder


def test_run_table_keeps_a_declared_column_after_the_base_ones(plugins: Path,
                                                                monkeypatch) -> None:
    monkeypatch.setenv(PLUGINS_ENV, str(plugins))
    assert COLUMN in quantity_columns(make_case(SCENE))
    df = run_table([SCENE, "clamped_bar"], ["redistributed"], [8], T=1.5)
    assert list(df["status"]) == ["ok", "ok"], df["notes"].tolist()
    assert df[COLUMN].iloc[0] == VALUE and math.isnan(df[COLUMN].iloc[1])
    cols = list(df.columns)
    assert cols[:len(BASE_COLUMNS)] == list(BASE_COLUMNS)
    declared = cols[len(BASE_COLUMNS):]  # the scenes' err_<q>, sorted by name
    assert declared == sorted(declared) and COLUMN in declared
    assert "err_contact_start" in declared  # the first contact's, from the exact stress
    assert cols.index("setup_s") == cols.index("step_s") + 1 and "setup_s" in TIMING_COLUMNS
    again = run_table(["clamped_bar", SCENE], ["redistributed"], [8], T=1.5)
    assert list(again.columns) == cols  # the order does not follow the rows'


def test_the_cli_run_prints_and_writes_the_declared_column(plugins: Path, tmp_path: Path,
                                                           capsys) -> None:
    out = tmp_path / "run"
    argv = ["--plugins", str(plugins), "run", "--case", SCENE, "--case", "clamped_bar", *RUN]
    assert main([*argv, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    header = printed.splitlines()[0].split()
    assert COLUMN in header and "err_u_linf_l2" in header
    assert printed.splitlines()[1].split()[header.index(COLUMN)] == f"{VALUE:.3g}"
    assert "err_contact_start" not in header  # the harness's own quantities: in the CSV
    df = pd.read_csv(out / "runs.csv")
    assert df[COLUMN].iloc[0] == VALUE and "setup_s" in df
    assert COLUMN in (out / "runs.md").read_text(encoding="utf-8")
    assert main([*argv, "--format", "csv"]) == 0
    df = pd.read_csv(io.StringIO(capsys.readouterr().out))
    assert df[COLUMN].iloc[0] == VALUE and "err_contact_start" in df


def test_a_sweep_and_its_report_keep_the_declared_column(plugins: Path,
                                                        tmp_path: Path) -> None:
    sweep, report = tmp_path / "sweep", tmp_path / "report"
    assert main(["--plugins", str(plugins), "sweep", "--case", SCENE, "--scheme",
                 "redistributed", "--nx", "8,16", "--cfl", "0.5", "--T", "1.5", "--repeats",
                 "0", "-j", "1", "--quiet", "--no-cache", "--out", str(sweep)]) == 0
    df = pd.read_csv(sweep / "sweep.csv")
    assert (df["status"] == "ok").all(), df["notes"].tolist()
    assert list(df[COLUMN]) == [VALUE, VALUE] and "setup_s" in df
    assert main(["--plugins", str(plugins), "report", str(sweep / "sweep.csv"), "--out",
                 str(report), "--fig-format", "svg"]) == 0
    runs = pd.read_csv(report / "runs.csv")
    assert list(runs[COLUMN]) == [VALUE, VALUE]
    wp = pd.read_csv(report / f"work_precision_{SCENE}_{COLUMN}.csv")  # its own curve
    assert list(wp[COLUMN]) == [VALUE, VALUE]
    assert "error my quantity (rel.)" in (report / f"work_precision_{SCENE}_{COLUMN}.md"
                                          ).read_text(encoding="utf-8")
    assert f"work_precision_{SCENE}_{COLUMN}" in (report / "index.html").read_text(
        encoding="utf-8")


def _table(*specs: str) -> pd.DataFrame:
    """Empty rows of these scenes with the columns a table of them has."""
    return pd.DataFrame([dict(dict.fromkeys((*BASE_COLUMNS, *quantity_columns(make_case(s)))),
                              case=s) for s in specs])


def test_the_printed_table_shows_the_error_columns_its_scenes_declare() -> None:
    default = shown_columns(_table("clamped_bar", "dropped_bar"))  # docs/default-run.md
    assert default == ["case", "scheme", "nx", "dt", "steps", "err_u_linf_l2",
                       "err_v_linf_l2", "err_stress_l2", "energy_drift_max",
                       "penetration_max", "step_s", "run_s", "status"]
    disc = [c for c in shown_columns(_table("disc_drop")) if c.startswith("err_")]
    assert disc == ["err_contact_duration", "err_contact_end", "err_contact_force_numerical",
                    "err_contact_impulse", "err_contact_start", "err_force_history",
                    "err_free_fall", "err_peak_force", "err_rebound_velocity",
                    "err_u_numerical", "err_vibration_energy"]  # with its converged reference
    grazing = [c for c in shown_columns(_table("grazing")) if c.startswith("err_")]
    assert grazing == ["err_u_linf_l2", "err_v_linf_l2"]  # its reference has no stress
