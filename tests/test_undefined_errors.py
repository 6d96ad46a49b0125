"""No NaN in an ok row without a word, and no damaged table published."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from contact_bench.cli.main import main
from contact_bench.core.errors import BenchError
from contact_bench.harness import run_one
from contact_bench.output.report import check_table, table_problems, write_report


def test_zero_exact_stress_gives_a_note_with_the_absolute_error() -> None:
    """clamped_bar before the impact at t = 1: the exact stress is 0 over the run, so
    the relative stress error is 0/0; the row says so and gives the absolute error."""
    run = run_one("clamped_bar", "standard", nx=20, T=0.5)
    row = run.row
    assert row["status"] == "ok"
    assert math.isnan(row["err_stress_l2"])
    assert "err_stress_l2 undefined: the exact contact stress is 0 over the run" in row["notes"]
    tr = run.trajectory
    stress = np.asarray(tr.stress, float)
    absolute = float(np.sqrt(np.trapezoid(stress**2, np.asarray(tr.t, float))))
    assert f"(absolute error {absolute:.3g})" in row["notes"]
    assert all(np.isfinite(row[c]) for c in ("err_u_linf_l2", "err_v_l2_l2"))


def test_a_row_with_a_defined_error_has_no_such_note() -> None:
    row = run_one("clamped_bar", "standard", nx=20, T=1.5).row
    assert np.isfinite(row["err_stress_l2"]) and "undefined" not in row["notes"]


def _table() -> pd.DataFrame:
    return pd.DataFrame({
        "case": ["clamped_bar", "clamped_bar"], "scheme": ["standard", "redistributed"],
        "nx": [20, 20], "dt": [0.005, 0.005], "T": [0.5, 0.5], "steps": [100, 100],
        "err_u_linf_l2": [0.01, 0.02], "err_stress_l2": [np.nan, 0.1],
        "energy_initial": [0.125, 0.125], "energy_drift_max": [1e-3, 0.0],
        "status": ["ok", "ok"],
        "notes": ["err_stress_l2 undefined: the exact contact stress is 0 over the run "
                  "(absolute error 0.01)", ""],
        "run_date": ["2026-01-01T00:00:00Z"] * 2,
    })


def test_a_sound_table_has_no_problems() -> None:
    assert table_problems(_table()) == []


@pytest.mark.parametrize(("column", "value", "message"), [
    ("run_date", np.nan, "cut short"),
    ("status", np.nan, "cut short"),
    ("status", "bogus", "status 'bogus' is not one of"),
    ("err_u_linf_l2", -1.0, "err_u_linf_l2 = -1.0"),
    ("err_u_linf_l2", np.inf, "err_u_linf_l2 = inf"),
    ("nx", 0, "nx = 0"),
    ("dt", -0.005, "dt = -0.005"),
    ("energy_initial", np.nan, "without a finite energy_initial"),
    ("notes", "", "err_stress_l2 empty and no note saying why"),
])
def test_damaged_tables_are_refused(tmp_path, column: str, value: object, message: str) -> None:
    df = _table()
    df[column] = df[column].astype(object)
    df.loc[0, column] = value
    problems = table_problems(df)
    assert any(message in p for p in problems), problems
    assert problems[0].startswith("row 1")
    with pytest.raises(BenchError, match="damaged"):
        check_table(df)
    out = tmp_path / "report"
    with pytest.raises(BenchError):
        write_report(df, out)
    assert not out.exists()


def test_report_command_refuses_a_damaged_table(tmp_path, capsys) -> None:
    df = _table()
    df.loc[1, "err_u_linf_l2"] = -3.0
    path = tmp_path / "sweep.csv"
    df.to_csv(path, index=False)
    out = tmp_path / "report"
    assert main(["report", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "damaged" in err and "row 2" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
