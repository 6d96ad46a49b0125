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


# ------------------------------------------------ bad input checked before any work
def _main(argv, capsys):
    from contact_bench.cli.main import main

    code = main(list(argv))
    cap = capsys.readouterr()
    assert "Traceback" not in cap.err, cap.err
    return code, cap.out, cap.err


def _one_error(err: str) -> str:
    assert err.count("\n") == 1 and err.startswith("contact-bench: error: "), repr(err)
    return err.strip()


def _table_files(folder: Path) -> dict[str, bytes]:
    header = "# comment\n"
    return {
        "empty.csv": b"",
        "comments.csv": header.encode() * 3,
        "binary.csv": bytes(range(256)) * 4,
        "utf16.csv": "case,scheme,status\nclamped_bar,standard,ok\n".encode("utf-16"),
        "latin1.csv": "case,scheme\ncaf\xe9,standard\n".encode("latin-1"),
        "columns.csv": b"case,scheme,status\nclamped_bar,standard,ok\n",
        "header_only.csv": (b"group,case,scheme,nx,h,dt,cfl,T,steps,status,stability,notes,"
                            b"time_s,energy_trace\n"),
        "ragged.csv": b'case,scheme\n"clamped_bar,standard\n',
    }


@pytest.mark.parametrize("name", list(_table_files(Path("."))))
def test_report_on_a_damaged_table_is_one_line_nothing_written(name, tmp_path, capsys):
    table = tmp_path / name
    table.write_bytes(_table_files(tmp_path)[name])
    out = tmp_path / "report"
    code, _, err = _main(["report", str(table), "--out", str(out)], capsys)
    line = _one_error(err)
    assert code == 2 and name in line, line
    assert not out.exists()


def _small_table(tmp_path: Path) -> Path:
    from contact_bench.sweeps.sweep import save_table

    df = run_sweep([Task("clamped_bar", "standard", nx=8, T=0.5)], cache=Cache(None),
                   repeats=0, quiet=True).table
    df["text_col"] = "abc"
    return save_table(df, tmp_path / "t" / "sweep.csv")[0]


@pytest.mark.parametrize("error,shown", [("bogus", "'bogus'"), ("notes", "'notes'"),
                                         ("", "''")])
def test_report_error_column_checked_first(error, shown, tmp_path, capsys):
    table = _small_table(tmp_path)
    out = tmp_path / "report"
    code, _, err = _main(["report", str(table), "--out", str(out), "--error", error], capsys)
    assert code == 2 and shown in _one_error(err)
    assert not out.exists()


@pytest.mark.parametrize("make_out", [
    lambda p: (p / "file").write_text("x") and p / "file",
    lambda p: (p / "file").write_text("x") and p / "file" / "sub",
    lambda p: p / ("n" * 300),
    lambda p: p / "a" / ("n" * 300) / "b",
])
@pytest.mark.parametrize("command", ["run", "sweep", "report", "study"])
def test_a_bad_out_fails_before_any_work(command, make_out, tmp_path, capsys, monkeypatch):
    from contact_bench.harness import runner
    from contact_bench.sweeps import sweep

    def boom(*a, **k):
        raise AssertionError("a run started before --out was checked")

    monkeypatch.setattr(runner, "_execute", boom)
    monkeypatch.setattr(sweep, "execute_task", boom)
    out = make_out(tmp_path)
    argv = {"run": ["run", "--case", "clamped_bar", "--scheme", "standard", "--T", "0.1"],
            "sweep": ["sweep", "--case", "clamped_bar", "--scheme", "standard", "--no-cache",
                      "--quiet", "-j", "1"],
            "report": ["report", "missing.csv"],
            "study": ["study", "--quick", "--no-cache", "--quiet", "-j", "1"]}[command]
    before = sorted(p.name for p in tmp_path.rglob("*"))
    code, _, err = _main([*argv, "--out", str(out)], capsys)
    assert code == 2, err
    _one_error(err)
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


def test_a_read_only_out_folder_is_refused(tmp_path, capsys, monkeypatch):
    import os

    ro = tmp_path / "ro"
    ro.mkdir()
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, m: False if Path(p) == ro else real(p, m))
    code, _, err = _main(["run", "--case", "clamped_bar", "--scheme", "standard", "--T", "0.1",
                          "--out", str(ro / "sub")], capsys)
    assert code == 2 and "not writable" in _one_error(err)


@pytest.mark.parametrize("how", ["option", "env"])
def test_a_bad_cache_fails_before_any_run(how, tmp_path, capsys, monkeypatch):
    afile = tmp_path / "afile"
    afile.write_text("x")
    argv = ["sweep", "--case", "clamped_bar", "--scheme", "standard", "--quiet", "-j", "1",
            "--out", str(tmp_path / "out")]
    if how == "option":
        argv += ["--cache", str(afile)]
    else:
        monkeypatch.setenv("CONTACT_BENCH_CACHE", str(afile / "sub"))
    code, _, err = _main(argv, capsys)
    assert code == 2 and "afile" in _one_error(err)
    assert not (tmp_path / "out").exists()


def test_a_dask_address_nobody_answers_is_one_line_within_seconds(tmp_path, capsys):
    pytest.importorskip("distributed")
    import socket
    import time

    with socket.socket() as s:  # a free port: nobody listens there
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    for address in (f"tcp://127.0.0.1:{port}", "bogus://x:y:z", "::::"):
        start = time.perf_counter()
        code, _, err = _main(["sweep", "--case", "clamped_bar", "--scheme", "standard",
                              "--no-cache", "--quiet", "--dask", address,
                              "--out", str(tmp_path / "out")], capsys)
        assert code == 2 and "--dask" in _one_error(err), err
        assert time.perf_counter() - start < 20
    assert not (tmp_path / "out").exists()


def test_sweep_and_run_read_numbers_alike(tmp_path, capsys):
    from contact_bench.cli.checks import numbers

    assert numbers(["1e3"], int, "nx") == [1000] == numbers(["1e3"], int, "nx", commas=True)
    assert numbers(["10, 20", "3e1"], int, "nx", commas=True) == [10, 20, 30]
    for bad in (["1,,2"], [""], [","], ["1e400"], ["nan"], ["2.5"]):
        with pytest.raises(BenchError):
            numbers(bad, int, "nx", commas=True)
    code, _, err = _main(["sweep", "--case", "clamped_bar", "--scheme", "standard", "--nx",
                          "1e1", "--T", "0.1", "--no-cache", "--quiet", "-j", "1",
                          "--repeats", "0", "--out", str(tmp_path / "s")], capsys)
    assert code == 0, err
    import pandas as pd

    assert list(pd.read_csv(tmp_path / "s" / "sweep.csv")["nx"]) == [10]


def test_run_one_raises_bench_error_for_bad_input_only():
    from contact_bench.harness.runner import run_one

    for kw in (dict(nx=1), dict(dt=10.0, T=0.1), dict(dt=1e-320, T=0.1), dict(T=1e308),
               dict(grading=50.0), dict(grading=1e5), dict(nx=10**9), dict(stride=10**300),
               dict(nx="x" * 1000), dict(dt=float("nan")), dict(T=-0.0), dict(T=5e-324),
               dict(T=1e-300, dt=1e-300)):
        with pytest.raises(BenchError) as exc:
            run_one("clamped_bar", "nitsche", **{"T": 0.1, **kw})
        assert "\n" not in str(exc.value) and len(str(exc.value)) < 400, kw
    # every scheme at the smallest mesh runs (or is not applicable)
    for name in schemes().names():
        row = run_one("clamped_bar", name, nx=2, T=0.05).row
        assert row["status"] in {"ok", "not applicable"}, (name, row["notes"])


def test_default_dt_above_a_short_T_is_lowered_with_a_note():
    from contact_bench.harness.runner import run_one

    row = run_one("clamped_bar", "standard", nx=8, T=0.001).row  # default dt 0.005
    assert row["T"] == 0.001 and row["steps"] == 1 and "lowered to T" in row["notes"]


# ------------------------------------------------------------- interrupted writes
RUN = ["run", "--scheme", "standard", "--T", "0.1", "--nx", "8", "--format", "csv"]


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())} if folder.exists() else {}


def _hidden(parent: Path) -> list[str]:
    return sorted(p.name for p in parent.rglob(".*"))


def test_run_out_is_replaced_as_a_set(tmp_path, capsys):
    out = tmp_path / "res"
    code, _, _ = _main([*RUN, "--case", "clamped_bar", "--case", "pulse", "--out", str(out)],
                       capsys)
    assert code == 0 and {"clamped_bar.png", "pulse.png", "README.md"} <= set(_snapshot(out))
    code, _, _ = _main([*RUN, "--case", "clamped_bar", "--out", str(out)], capsys)
    assert code == 0
    assert sorted(_snapshot(out)) == ["README.md", "clamped_bar.fig.json", "clamped_bar.png",
                                      "runs.csv", "runs.csv.json", "runs.md"]
    assert _hidden(tmp_path) == []
    # a folder with the user's own files: they stay, the previous set's stale files go
    (out / "mine.txt").write_text("keep me")
    code, _, _ = _main([*RUN, "--case", "pulse", "--out", str(out)], capsys)
    assert code == 0
    assert sorted(_snapshot(out)) == ["README.md", "mine.txt", "pulse.fig.json", "pulse.png",
                                      "runs.csv", "runs.csv.json", "runs.md"]
    assert _hidden(tmp_path) == []


def test_ctrl_c_while_writing_run_out_leaves_the_old_set(tmp_path, capsys, monkeypatch):
    from contact_bench.cli.main import INTERRUPTED
    from contact_bench.output import figures

    out = tmp_path / "res"
    assert _main([*RUN, "--case", "clamped_bar", "--out", str(out)], capsys)[0] == 0
    before = _snapshot(out)

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(figures, "contact_figure", interrupted)
    code, _, err = _main([*RUN, "--case", "clamped_bar", "--dt", "0.001", "--out", str(out)],
                         capsys)
    assert code == 130 and err.strip() == INTERRUPTED
    assert _snapshot(out) == before  # not new tables beside an old README and figures
    assert _hidden(tmp_path) == []


def _cli_env() -> dict[str, str]:
    import os

    env = dict(os.environ)
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[1]) + os.pathsep + env.get(
        "PYTHONPATH", "")
    return env


def test_sigkill_while_writing_leaves_nothing_in_the_target(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "res"
    argv = [sys.executable, "-m", "contact_bench", *RUN, "--case", "clamped_bar", "--case",
            "pulse", "--case", "grazing", "--out", str(out)]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            env=_cli_env(), cwd=tmp_path)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            if any(p.name.startswith(".res.partial-") and any(p.iterdir())
                   for p in tmp_path.iterdir()):
                break
            time.sleep(0.005)
        assert proc.poll() is None, "finished before the kill"
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert not out.exists()  # nothing half-written in the target
    left = [p.name for p in tmp_path.iterdir() if p.name.startswith(".res.partial-")]
    assert left  # the hidden folder beside it, removed by the next write:
    from contact_bench.harness.io import folder_set

    with folder_set(out) as tmp:
        (tmp / "README.md").write_text("# Results\n")
    assert [p.name for p in tmp_path.iterdir()] == ["res"]


def test_ctrl_c_to_two_workers_is_one_line(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    cache = tmp_path / "cache"
    argv = [sys.executable, "-m", "contact_bench", "sweep", "--case", "clamped_bar",
            "--scheme", "standard", "--scheme", "penalty", "--nx", "2000,2001,2002,2003",
            "--T", "6", "--dt", "1e-3", "--stride", "100", "-j", "2", "--quiet",
            "--repeats", "0", "--cache", str(cache), "--out", str(tmp_path / "out")]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=_cli_env(), cwd=tmp_path, start_new_session=True)
    try:
        deadline = time.monotonic() + 180
        while len(Cache(cache)) < 1 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        assert proc.poll() is None, proc.communicate()
        os.killpg(proc.pid, signal.SIGINT)  # as a terminal does: the whole group
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert err.count("\n") == 1 and "interrupted" in err, err


@pytest.mark.parametrize("delay", [0.15, 0.4])
def test_ctrl_c_during_start_up_imports_is_one_line(delay, tmp_path):
    import signal
    import subprocess
    import sys
    import time

    proc = subprocess.Popen([sys.executable, "-m", "contact_bench", "list"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env=_cli_env(), cwd=tmp_path)
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    if proc.returncode == 0:
        pytest.skip("the command finished before the signal")
    # 130, or killed by SIGINT itself (-2) when the signal lands before Python's handler
    assert proc.returncode in {130, -signal.SIGINT}, err
    assert "Traceback" not in err and err.count("\n") <= 1, err


def test_report_on_a_table_cut_anywhere_is_one_line_nothing_written(tmp_path, capsys):
    src = _small_table(tmp_path).read_bytes()
    cuts = sorted({*range(1, len(src), max(1, len(src) // 60)), len(src) - 1})
    for cut in cuts:
        table = tmp_path / "cut.csv"
        table.write_bytes(src[:cut])
        out = tmp_path / f"report{cut}"
        code, _, err = _main(["report", str(table), "--out", str(out)], capsys)
        assert code == 2, (cut, err)
        _one_error(err)
        assert not out.exists(), cut
