"""Issue 28: parameters kept to the last digit, a cache that verifies its entries."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from contact_bench.api.params import Param, expand_spec, format_value, parse_spec
from contact_bench.api.registry import cases, make_case, make_scheme, schemes
from contact_bench.core.errors import BenchError
from contact_bench.sweeps.cache import Cache, digest
from contact_bench.sweeps.sweep import VOLATILE_COLUMNS, Task, plan, run_sweep


# ------------------------------------------------------- parameters to the last digit
def _values(p: Param) -> list:
    """Allowed values of p, with floats that `:g` would round (many digits, neighbours)."""
    if p.choices is not None:
        return list(p.choices)
    if p.kind is bool:
        return [True, False]
    if p.kind is int:
        return [p.default, p.default + 1, 10**30 + 7]
    if p.kind is not float:
        return [p.default, "x"]
    lo = -1e6 if p.low is None else p.low
    hi = 1e6 if p.high is None else p.high
    out = [p.default]
    for frac in (0.123456789012345, 0.5, 0.999999999):
        out.append(lo + (hi - lo) * frac)
    for edge, toward in ((lo, hi), (hi, lo)):
        out += [edge, math.nextafter(edge, toward), math.nextafter(math.nextafter(edge, toward),
                                                                   toward)]
    out += [math.nextafter(p.default, hi), math.nextafter(p.default, lo)]
    return out


def _plugin_params() -> list[tuple[str, type, str, Param]]:
    return [(kind, cls, key, p) for kind, reg in (("scheme", schemes()), ("case", cases()))
            for cls in reg.plugins.values() for key, p in cls.params.items()]


@pytest.mark.parametrize("kind,cls,key,p", _plugin_params(),
                         ids=[f"{c.name}.{k}" for _, c, k, _p in _plugin_params()])
def test_parse_format_parse_is_the_identity_for_every_parameter(kind, cls, key, p):
    make = make_scheme if kind == "scheme" else make_case
    tried = 0
    for value in _values(p):
        try:
            plugin = make(f"{cls.name}[{key}={format_value(value)}]")
        except BenchError:  # out of range (an open bound) or refused by validate()
            continue
        tried += 1
        assert plugin.values[key] == value and type(plugin.values[key]) is type(value)
        again = make(plugin.spec)  # format -> parse
        assert again.values == plugin.values, (plugin.spec, again.spec)
        assert again.spec == plugin.spec
        if isinstance(value, float):  # every bit, not only ==
            assert math.copysign(1, again.values[key]) == math.copysign(1, value) or value == 0
            assert again.values[key].hex() == (value + 0.0).hex()
    assert tried >= 1


def test_specs_keep_every_digit():
    assert make_scheme("penalty[gamma_p=1.0000001]").spec == "penalty[gamma_p=1.0000001]"
    assert make_scheme("nitsche[gamma0=1.0000001]").values["gamma0"] == 1.0000001
    assert make_scheme("restitution[e=0.9999999]").spec == "restitution[e=0.9999999]"
    assert make_case("fast_impact[mach=0.0123456789]").mach == 0.0123456789
    # -0.0 is 0.0 (one value, one spec); huge and infinite integers are a one-line error
    assert make_scheme("restitution[e=-0.0]").spec == "restitution"
    for bad in ("inf", "-inf", "1e999", "9" * 400, "nan"):
        with pytest.raises(BenchError, match="theta="):
            make_scheme(f"nitsche[theta={bad}]")


def test_grids_keep_distinct_values_and_refuse_empty_items():
    specs = expand_spec("penalty[gamma_p=[1.0000001,1.0000002,1.00000049]]")
    assert [make_scheme(s).values["gamma_p"] for s in specs] == [1.0000001, 1.0000002,
                                                                 1.00000049]
    for bad in ("penalty[gamma_p=[1,,2]]", "penalty[gamma_p=[1,2,]]", "penalty[gamma_p=[]]",
                "penalty[gamma_p=1,,beta=0.3]"):
        with pytest.raises(BenchError):
            expand_spec(bad)
    assert parse_spec("penalty[gamma_p=[1, 2]]") == ("penalty", {"gamma_p": ["1", "2"]})


def test_sweep_over_two_values_equal_to_6_digits_gives_two_rows():
    tasks = plan(["clamped_bar"], ["penalty[gamma_p=[1.0000001,1.0000002]]"], [8], T=0.5)
    res = run_sweep(tasks, cache=Cache(None), repeats=0, quiet=True)
    df = res.table
    assert len(df) == 2, df[["scheme", "status"]]
    assert list(df["scheme"]) == ["penalty[gamma_p=1.0000001]", "penalty[gamma_p=1.0000002]"]
    assert list(df["status"]) == ["ok", "ok"], list(df["notes"])
    # each row was run with its own value: rebuild from the row's label
    assert [make_scheme(s).values["gamma_p"] for s in df["scheme"]] == [1.0000001, 1.0000002]


def test_sweep_runs_the_parsed_value_not_a_rounded_one():
    mach = 0.0123456789
    tasks = [Task("fast_impact[mach=0.0123456789]", "standard", nx=8, T=0.05),
             Task("fast_impact[mach=0.0123457]", "standard", nx=8, T=0.05)]
    df = run_sweep(tasks, cache=Cache(None), repeats=0, quiet=True).table
    assert len(df) == 2 and make_case(df["case"][0]).mach == mach
    a, b = df.iloc[0], df.iloc[1]
    assert a["energy_initial"] != b["energy_initial"] or a["energy_final"] != b["energy_final"]


# --------------------------------------------------------------- the cache verifies
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
