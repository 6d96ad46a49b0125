"""Bad input refused before any work, with one line and nothing written; result files
that an interruption (Ctrl-C, SIGKILL) leaves whole: the old set or the new one."""

from __future__ import annotations

from pathlib import Path

import pytest

from contact_bench.api.registry import schemes
from contact_bench.core.errors import BenchError
from contact_bench.sweeps.cache import Cache
from contact_bench.sweeps.sweep import Task, run_sweep


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


def test_ctrl_c_to_two_workers_is_one_line(tmp_path, from_a_terminal):
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
    proc = subprocess.Popen(from_a_terminal(argv), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=_cli_env(), cwd=tmp_path,
                            start_new_session=True)
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
def test_ctrl_c_during_start_up_imports_is_one_line(delay, tmp_path, from_a_terminal):
    import signal
    import subprocess
    import sys
    import time

    proc = subprocess.Popen(from_a_terminal([sys.executable, "-m", "contact_bench", "list"]),
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
