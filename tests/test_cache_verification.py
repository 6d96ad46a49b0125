"""The sweep cache verifies its entries: a corrupted, edited or foreign entry is
recomputed (or measured again) with one note, never served; a cache folder that cannot
be written fails before any run."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from contact_bench.core.errors import BenchError
from contact_bench.sweeps.cache import Cache, digest
from contact_bench.sweeps.sweep import VOLATILE_COLUMNS, Task, run_sweep


def _sweep(cache: Cache, repeats: int = 1):
    tasks = [Task("clamped_bar", "standard", nx=8, T=0.5)]
    return run_sweep(tasks, cache=cache, repeats=repeats, quiet=True)


def _metrics(df):
    return df.drop(columns=[*VOLATILE_COLUMNS, "run_date"], errors="ignore")


def _entry_files(root: Path, key: str) -> tuple[Path, Path]:
    run = root / key[:2] / f"{key}.json"
    others = [p for p in root.glob("*/*.json") if p != run]
    assert len(others) == 1  # the timing entry
    return run, others[0]


def _edit_row(path: Path, **changes) -> None:
    entry = json.loads(path.read_text())
    entry["row"].update(changes)
    path.write_text(json.dumps(entry))


def _edit_row_keep_digest(path: Path, **changes) -> None:
    """An edit that also fixes the digest: only the column checks can catch it."""
    entry = json.loads(path.read_text())
    entry["row"].update(changes)
    entry["digest"] = digest(entry["row"])
    path.write_text(json.dumps(entry))


def _all_nan(path: Path) -> None:
    entry = json.loads(path.read_text())
    entry["row"] = {k: float("nan") for k in entry["row"]}
    path.write_text(json.dumps(entry))


CORRUPT_RUN = {
    "err_u_linf_l2 = 999": lambda p: _edit_row(p, err_u_linf_l2=999.0),
    "status bogus": lambda p: _edit_row(p, status="bogus"),
    "status bogus, digest fixed": lambda p: _edit_row_keep_digest(p, status="bogus"),
    "nx text, digest fixed": lambda p: _edit_row_keep_digest(p, nx="8"),
    "column missing, digest fixed": lambda p: _edit_row_keep_digest(p, err_u_linf_l2=None)
    or _drop_column(p, "status"),
    "{}": lambda p: p.write_text("{}"),
    '{"status": "ok"}': lambda p: p.write_text('{"status": "ok"}'),
    "all NaN": _all_nan,
    '"abc"': lambda p: p.write_text('"abc"'),
    "abc (not JSON)": lambda p: p.write_text("abc"),
    "123": lambda p: p.write_text("123"),
    "[]": lambda p: p.write_text("[]"),
    "truncated": lambda p: p.write_text(p.read_text()[:40]),
    "binary": lambda p: p.write_bytes(b"\xff\xfe\x00\x01" * 10),
    "deeply nested": lambda p: p.write_text("[" * 100000 + "]" * 100000),
}


def _drop_column(path: Path, col: str) -> None:
    entry = json.loads(path.read_text())
    entry["row"].pop(col)
    entry["digest"] = digest(entry["row"])
    path.write_text(json.dumps(entry))


@pytest.mark.parametrize("how", list(CORRUPT_RUN))
def test_a_corrupted_run_entry_is_recomputed_with_one_note(how, tmp_path, capsys):
    cache = Cache(tmp_path / "c")
    first = _sweep(cache)
    run_path, _ = _entry_files(cache.root, first.keys[0])
    capsys.readouterr()
    CORRUPT_RUN[how](run_path)
    cache = Cache(tmp_path / "c")
    second = _sweep(cache)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert second.executed == 1 and second.cached == 0, how
    assert err.count("refused") == 1 and err.count("\n") == 1, err
    assert _metrics(second.table).equals(_metrics(first.table))
    # rewritten: the third sweep is served from the cache, silently
    third = _sweep(Cache(tmp_path / "c"))
    assert (third.executed, third.cached) == (0, 1)
    assert capsys.readouterr().err == ""


def test_another_runs_entry_copied_in_is_not_served(tmp_path, capsys):
    cache = Cache(tmp_path / "c")
    a = _sweep(cache)
    b = run_sweep([Task("clamped_bar", "standard", nx=16, T=0.5)], cache=cache, repeats=0,
                  quiet=True)
    path_a = cache.root / a.keys[0][:2] / f"{a.keys[0]}.json"
    path_b = cache.root / b.keys[0][:2] / f"{b.keys[0]}.json"
    path_a.write_text(path_b.read_text())
    capsys.readouterr()
    again = _sweep(Cache(tmp_path / "c"), repeats=0)
    assert again.executed == 1 and int(again.table["nx"][0]) == 8
    assert "stored under another key" in capsys.readouterr().err


CORRUPT_TIMING = {
    "{}": lambda p: p.write_text("{}"),
    "time_s = -5": lambda p: _edit_row_keep_digest(p, time_s=-5),
    "time_s text": lambda p: _edit_row_keep_digest(p, time_s="fast"),
    "time_s NaN": lambda p: _edit_row_keep_digest(p, time_s=None),
    "time_repeats 0": lambda p: _edit_row_keep_digest(p, time_repeats=0),
    "time_s edited": lambda p: _edit_row(p, time_s=1e-9),
    "abc": lambda p: p.write_text('"abc"'),
}


@pytest.mark.parametrize("how", list(CORRUPT_TIMING))
def test_a_corrupted_timing_entry_is_measured_again(how, tmp_path, capsys):
    cache = Cache(tmp_path / "c")
    first = _sweep(cache)
    _, timing_path = _entry_files(cache.root, first.keys[0])
    CORRUPT_TIMING[how](timing_path)
    capsys.readouterr()
    second = _sweep(Cache(tmp_path / "c"))
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("refused") == 1, err
    assert second.cached == 1 and second.timed == 1
    t = float(second.table["time_s"][0])
    assert math.isfinite(t) and t > 0


def test_a_cache_folder_that_cannot_be_written_fails_before_any_run(tmp_path):
    afile = tmp_path / "file"
    afile.write_text("x")
    for root in (afile, afile / "sub"):
        with pytest.raises(BenchError, match="cache folder"):
            Cache(root).check_writable()
    Cache(tmp_path / "new" / "deep").check_writable()  # made
    assert (tmp_path / "new" / "deep").is_dir()
