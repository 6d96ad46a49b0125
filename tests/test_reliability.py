"""Reliability: bad inputs, blow-ups, determinism, atomic result files, Ctrl-C."""

from __future__ import annotations

import csv
import io
import os
import shutil
import signal
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

import pandas as pd
import pytest

from contact_bench.api import CallStepper
from contact_bench.api.fem import mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_scheme, schemes
from contact_bench.cli.bad_inputs import BadInput, bad_inputs, demo_plugins
from contact_bench.cli.main import INTERRUPTED, main
from contact_bench.core.errors import BenchError
from contact_bench.harness.io import atomic_write, write_text
from contact_bench.harness.runner import TIMING_COLUMNS, run_one, run_table
from contact_bench.schemes.standard import Standard

ROOT = Path(__file__).resolve().parents[1]
BAD = bad_inputs()


def _cli() -> list[str]:
    """The installed console script, else the same entry point through python -m."""
    exe = shutil.which("contact-bench")
    return [exe] if exe else [sys.executable, "-m", "contact_bench"]


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _with_out(argv: tuple[str, ...], out: Path) -> list[str]:
    argv = list(argv)
    if "--out" in argv:  # the entry's own (bad) --out
        return argv
    if argv and argv[0] == "run":
        return ["run", "--out", str(out), *argv[1:]]
    return [*argv, "--out", str(out)]


def _files(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir()) if folder.exists() else []


def _one_line(err: str) -> str:
    assert "Traceback" not in err, err
    assert err.endswith("\n") and err.count("\n") == 1, repr(err)
    return err.strip()


def _explicit_limit(nx: int = 20) -> float:
    from contact_bench.cases.clamped_bar import ClampedBar

    scheme = make_scheme("redistributed[beta=0]")
    semi = discretise(ClampedBar(), mesh_nodes(1.0, nx), scheme.mass_kind())
    return scheme.stability_limit(semi)


# ------------------------------------------------------------------------ bad inputs
@pytest.mark.parametrize("item", BAD, ids=[f"{i:02d}-{b.what}" for i, b in enumerate(BAD)])
def test_bad_input_is_one_line_exit_2_nothing_written(item: BadInput, tmp_path, capsys):
    out = tmp_path / "out"
    with demo_plugins():
        code = main(_with_out(item.argv, out))
    captured = capsys.readouterr()
    line = _one_line(captured.err)
    assert code == 2, line
    assert line.startswith("contact-bench: error: ")
    assert item.bad in line, (item.bad, line)
    assert captured.out == ""
    assert _files(out) == []


def test_bad_input_list_covers_every_kind_of_bad_input():
    whats = " ".join(b.what for b in BAD)
    for needed in ("nx < 1", "nx not an integer", "dt = 0", "dt NaN", "dt inf", "T = 0",
                   "T NaN", "E <= 0", "rho <= 0", "u0(0) < 0", "not finite", "unknown scene",
                   "unknown scheme", "unknown parameter", "out of range", "cannot run",
                   "stability limit", "stride larger", "unknown option", "bad choice"):
        assert needed in whats, needed
    # every kind of declared range of the registered schemes has its row
    for cls in schemes().plugins.values():
        for key, p in cls.params.items():
            if p.choices is not None or p.low is not None or p.high is not None:
                assert any(f"[{key}=" in " ".join(b.argv) and p.allowed() in b.what
                           for b in BAD), (cls.name, key)


def test_bad_input_in_a_real_process(tmp_path):
    out = tmp_path / "out"
    for argv, bad in ((["run", "--case", "clamped_bar", "--nx", "0"], "got 0"),
                      (["run", "--frobnicate"], "--frobnicate")):
        proc = subprocess.run([*_cli(), *argv, "--out", str(out)], capture_output=True,
                              text=True, env=_env(), cwd=tmp_path, timeout=120)
        line = _one_line(proc.stderr)
        assert proc.returncode == 2 and bad in line, (proc.returncode, line)
        assert proc.stdout == ""
        assert _files(out) == []


def test_help_still_works(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["run", "--help"])
    assert exc.value.code == 0
    assert "--allow-unstable" in capsys.readouterr().out


def test_not_applicable_pair_in_a_product_is_a_row(capsys):
    with demo_plugins():
        code = main(["run", "--case", "clamped_bar", "--scheme", "demo_free_only",
                     "--scheme", "standard", "--nx", "10", "--T", "0.2", "--format", "csv"])
    captured = capsys.readouterr()
    assert code == 0 and captured.err == ""
    df = pd.read_csv(io.StringIO(captured.out))
    assert list(df["status"]) == ["not applicable", "ok"]
    assert "free far end" in df["notes"][0]


def test_api_strictness_of_a_single_pair():
    from contact_bench.cli.bad_inputs import DemoFreeOnly

    with demo_plugins():
        run = run_one("clamped_bar", DemoFreeOnly(), nx=10, T=0.2)
        assert run.row["status"] == "not applicable"
        with pytest.raises(BenchError, match="cannot run case clamped_bar"):
            run_one("clamped_bar", DemoFreeOnly(), nx=10, T=0.2, strict=True)
        with pytest.raises(BenchError, match="cannot run"):
            run_table(["clamped_bar"], ["demo_free_only"], [10], T=0.2, explicit_pair=True)


# ------------------------------------------------------------------------- blow-ups
def test_blow_up_stops_early_with_status_unstable():
    limit = _explicit_limit(20)
    run = run_one("clamped_bar", "redistributed[beta=0]", nx=20, dt=2 * limit, T=6.0,
                  allow_unstable=True)
    row, tr = run.row, run.trajectory
    assert row["status"] == "unstable"
    assert 0 < row["blowup_time"] < row["T"]
    assert tr.steps_done < row["steps"]  # stopped early
    assert row["blowup_time"] == pytest.approx(tr.steps_done * row["dt"])
    assert "above the stability limit" in row["notes"] and "blew up" in row["notes"]
    assert row["err_u_linf_l2"] is None  # no errors against a blown-up run


def test_allow_unstable_below_blow_up_marks_the_row():
    limit = _explicit_limit(20)
    run = run_one("clamped_bar", "redistributed[beta=0]", nx=20, dt=1.01 * limit, T=0.05,
                  allow_unstable=True)
    assert run.row["status"] == "ok"
    assert "above the stability limit" in run.row["notes"]


class _Boom(Standard):
    name = "boom"
    summary = "test: raises while it steps"

    def prepare(self, problem, dt):
        def run(nsteps, stride):
            raise RuntimeError("kaboom\nsecond line")

        return CallStepper(run)


def test_table_goes_on_after_unstable_and_error_rows(monkeypatch, capsys, tmp_path):
    monkeypatch.setitem(schemes().plugins, "boom", _Boom)
    dt = 2 * _explicit_limit(20)
    out = tmp_path / "out"
    code = main(["run", "--case", "clamped_bar", "--scheme", "redistributed[beta=0]",
                 "--scheme", "boom", "--scheme", "standard", "--nx", "20", "--dt", repr(dt),
                 "--T", "3", "--allow-unstable", "--format", "csv", "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 0 and captured.err == ""
    df = pd.read_csv(io.StringIO(captured.out))
    assert list(df["status"]) == ["unstable", "error", "ok"]
    assert df["notes"][1].startswith("RuntimeError: kaboom second line")
    assert df["blowup_time"][0] > 0
    assert {"runs.csv", "runs.md", "README.md"} <= set(_files(out))


# ---------------------------------------------------------------------- determinism
DET_ARGS = ["run", "--case", "clamped_bar", "--case", "dropped_bar", "--scheme", "standard",
            "--scheme", "redistributed", "--scheme", "redistributed[beta=0]", "--nx", "16",
            "--T", "1.0", "--format", "csv"]


def _metrics_csv(text: str) -> list[list[str]]:
    """The CSV text cell by cell without the timing columns (no float parsing: exact)."""
    rows = list(csv.reader(io.StringIO(text)))
    keep = [i for i, c in enumerate(rows[0]) if c not in TIMING_COLUMNS]
    return [[r[i] for i in keep] for r in rows]


def test_same_command_bit_identical_in_separate_processes(tmp_path):
    outs = []
    for _ in range(2):
        proc = subprocess.run([*_cli(), *DET_ARGS], capture_output=True, text=True,
                              env=_env(), cwd=tmp_path, timeout=300)
        assert proc.returncode == 0, proc.stderr
        outs.append(proc.stdout)
    a, b = (pd.read_csv(io.StringIO(o)) for o in outs)
    assert (a["status"] == "ok").all()
    # pandas writes floats with repr precision: equal text is equal bits
    assert _metrics_csv(outs[0]) == _metrics_csv(outs[1])
    assert len(_metrics_csv(outs[0])) == 1 + 2 * 3


def _table(case: str, scheme: str) -> pd.DataFrame:
    return run_table([case], [scheme], [16], T=1.0).drop(columns=list(TIMING_COLUMNS),
                                                         errors="ignore")


def test_run_table_identical_serial_and_in_two_worker_processes():
    pairs = [(c, s) for c in ("clamped_bar", "dropped_bar")
             for s in ("standard", "redistributed[beta=0]")]
    serial = run_table([c for c, _ in pairs[::2]], ["standard", "redistributed[beta=0]"],
                       [16], T=1.0).drop(columns=list(TIMING_COLUMNS), errors="ignore")
    with ProcessPoolExecutor(2, mp_context=get_context("spawn")) as pool:
        parts = list(pool.map(_table, *zip(*pairs, strict=True)))  # pickled: exact floats
    pooled = pd.concat(parts, ignore_index=True)
    assert (serial["status"] == "ok").all()
    assert serial.to_csv(index=False) == pooled.to_csv(index=False)


def test_sweep_identical_with_1_and_2_workers():
    sweep = pytest.importorskip("contact_bench.sweeps.sweep")
    from contact_bench.sweeps.cache import Cache

    tasks = sweep.plan(["clamped_bar", "dropped_bar"], ["standard", "redistributed[beta=0]"],
                       [16], T=1.0, timed=False)
    tables = [sweep.run_sweep(tasks, jobs=j, cache=Cache(None), quiet=True).table
              for j in (1, 2)]
    volatile = [c for c in sweep.VOLATILE_COLUMNS if c in tables[0]]
    a, b = (t.drop(columns=volatile).to_csv(index=False) for t in tables)
    assert (tables[0]["status"] == "ok").all()
    assert a == b


# ------------------------------------------------------------- atomic files, Ctrl-C
def test_atomic_write_interrupted_leaves_old_file_and_no_temporary(tmp_path):
    target = tmp_path / "runs.csv"
    write_text(target, "old\n")

    def half(tmp: str) -> None:
        with open(tmp, "w") as fh:
            fh.write("half a fi")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        atomic_write(target, half)
    assert target.read_text() == "old\n"
    assert _files(tmp_path) == ["runs.csv"]
    from contact_bench.harness.io import _UMASK

    assert target.stat().st_mode & 0o777 == 0o666 & ~_UMASK  # not mkstemp's 0600


def test_every_file_the_cli_writes_is_renamed_into_place(tmp_path, monkeypatch, capsys):
    renamed: list[str] = []
    real = os.replace

    def spy(src, dst, *a, **k):
        renamed.append(Path(dst).name)
        return real(src, dst, *a, **k)

    monkeypatch.setattr(os, "replace", spy)
    out = tmp_path / "out"
    code = main(["run", "--case", "clamped_bar", "--scheme", "standard", "--nx", "10",
                 "--T", "0.2", "--out", str(out)])
    capsys.readouterr()
    assert code == 0
    written = _files(out)
    assert written and set(written) <= set(renamed), (written, renamed)
    assert not [f for f in written if f.startswith(".")]


def test_ctrl_c_while_writing_results_leaves_no_partial_file(tmp_path, monkeypatch, capsys):
    import matplotlib.figure

    def interrupted_savefig(self, fname, *a, **k):
        with open(fname, "wb") as fh:
            fh.write(b"\x89PNG half")
        raise KeyboardInterrupt

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", interrupted_savefig)
    out = tmp_path / "out"
    code = main(["run", "--case", "clamped_bar", "--scheme", "standard", "--nx", "10",
                 "--T", "0.2", "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 130
    assert _one_line(captured.err) == INTERRUPTED
    files = _files(out)
    assert not [f for f in files if f.startswith(".") or f.endswith(".png")], files
    for f in files:  # whatever was finished before Ctrl-C is whole
        text = (out / f).read_text()
        assert text.endswith("\n") and "clamped_bar" in text


def test_ctrl_c_during_a_run_exits_130_one_line_no_file(tmp_path, from_a_terminal):
    out = tmp_path / "out"
    # the console script is `from contact_bench.cli.main import main; sys.exit(main())`; "ready"
    # marks
    # the end of the imports so that SIGINT lands in main (a long job: 8 runs of ~1.5 s)
    argv = ["run", "--case", "clamped_bar", "--scheme", "standard", "--nx", "4000",
            "--T", "48", "--stride", "2000", "--out", str(out)]
    for dt in ("1e-4", "1.01e-4", "1.02e-4", "1.03e-4", "1.04e-4", "1.05e-4", "1.06e-4"):
        argv += ["--dt", dt]
    code = ("import sys; from contact_bench.cli.main import main; print('ready', flush=True); "
            f"sys.exit(main({argv!r}))")
    proc = subprocess.Popen(from_a_terminal([sys.executable, "-c", code]), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=_env(), cwd=tmp_path)
    try:
        assert proc.stdout.readline().strip() == "ready"
        time.sleep(1.5)
        assert proc.poll() is None, "the job finished before Ctrl-C"
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert _one_line(err) == INTERRUPTED
    assert _files(out) == []


@pytest.mark.parametrize("bad, shown", [("--nx=0", "0"), ("--dt=-1", "-1"), ("--cfl=nan", "nan"),
                                        ("--T=0", "0")])
def test_sweep_rejects_bad_numbers_before_running(tmp_path, capsys, bad, shown):
    from contact_bench.cli.main import main

    out = tmp_path / "sweep"
    code = main(["sweep", "--case", "clamped_bar", "--scheme", "standard", bad,
                 "--out", str(out), "--quiet", "--no-cache"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and shown in err[0] and "Traceback" not in err[0]
    assert not out.exists()
