"""The CLI's user-facing outputs: --version, list (width, filter, JSON), progress on
stderr, --traceback, the untracked default output folder, the dirty flag."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from contact_bench import __version__
from contact_bench.cli.main import DEFAULT_OUT, LIST_WIDTH, main
from contact_bench.harness import environment

ROOT = Path(__file__).resolve().parent.parent


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"contact-bench {__version__}"


def test_list_fits_in_100_columns(capsys):
    assert main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) > 40
    assert max(len(line) for line in lines) <= LIST_WIDTH


def test_list_filters_and_json(capsys):
    assert main(["list", "schemes"]) == 0
    text = capsys.readouterr().out
    assert "Schemes:" in text and "Cases" not in text
    assert main(["list", "ode_verlet"]) == 0
    text = capsys.readouterr().out
    assert "ode_verlet" in text and "hht" not in text
    assert main(["list", "--format", "json", "cases"]) == 0
    records = json.loads(capsys.readouterr().out)
    assert {r["kind"] for r in records} == {"case"}
    assert "clamped_bar" in {r["name"] for r in records}
    assert main(["list", "--format", "json", "ode_verlet"]) == 0
    (rec,) = json.loads(capsys.readouterr().out)
    assert rec["cfl_limit"] == pytest.approx(0.5562, abs=1e-4)  # the seed mass's limit


def test_list_unknown_name_is_one_line(capsys):
    assert main(["list", "nope"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("contact-bench: error:") and "'nope'" in err and "\n" not in err


def test_run_progress_on_stderr_and_traceback(monkeypatch, capsys, tmp_path):
    from contact_bench.schemes.standard import Standard

    def broken(self, problem, dt):  # noqa: ANN001, ANN202
        raise RuntimeError("deliberately broken")

    monkeypatch.setattr(Standard, "prepare", broken)
    argv = ["run", "--case", "clamped_bar", "--scheme", "standard", "--scheme", "penalty",
            "--nx", "10", "--T", "0.5", "--out", str(tmp_path / "o")]
    assert main(argv) == 0  # stderr is not a terminal: no progress lines
    err = capsys.readouterr().err
    assert "run 1/2" not in err and "--traceback" in err
    argv.append("--progress")
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "run 1/2: clamped_bar / standard" in err and "run 2/2" in err
    assert "--traceback" in err and "Traceback" not in err
    assert main([*argv, "--traceback", "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "run 1/2" not in err
    assert "Traceback (most recent call last)" in err and "deliberately broken" in err
    assert "in broken" in err


def test_provenance_has_a_dirty_flag():
    env = environment.environment()
    assert env["env_git_dirty"] in {"yes", "no", "unknown"}
    assert environment.git_dirty() in {"yes", "no", "unknown"}
    prov = environment.provenance(["run"])
    assert ("(dirty)" in prov) == (env["env_git_dirty"] == "yes")


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_main_job_leaves_a_fresh_clone_clean(tmp_path):
    """The README's main job, `contact-bench run`, in a fresh clone of this checkout's
    commit: its files go to the ignored DEFAULT_OUT, so `git status` stays clean."""
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
    out = subprocess.run([sys.executable, "-m", "contact_bench", "run", "--quiet"], cwd=clone,
                         capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr
    assert (clone / DEFAULT_OUT / "runs.csv").exists()
    status = subprocess.run(["git", "status", "--porcelain"], cwd=clone, capture_output=True,
                            text=True, check=True).stdout
    assert status == "", status


def test_sweep_traceback_of_error_rows(monkeypatch, capsys, tmp_path):
    from contact_bench.schemes.standard import Standard

    def broken(self, problem, dt):  # noqa: ANN001, ANN202
        raise RuntimeError("deliberately broken in a sweep")

    monkeypatch.setattr(Standard, "prepare", broken)
    argv = ["sweep", "--case", "clamped_bar", "--scheme", "standard", "--nx", "8", "--T", "0.5",
            "--repeats", "0", "-j", "1", "--no-cache", "--quiet", "--out", str(tmp_path)]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "1 error row(s); --traceback" in err and "Traceback" not in err
    assert main([*argv, "--traceback"]) == 0
    err = capsys.readouterr().err
    assert "--- clamped_bar / standard (nx 8)" in err
    assert "Traceback (most recent call last)" in err and "in broken" in err
    import pandas as pd

    assert "traceback" not in pd.read_csv(tmp_path / "sweep.csv").columns


def test_study_checks_its_report_options_before_the_sweep(tmp_path, capsys):
    for bad in (["--error", "BAD"], ["--fig-format", "tiff"], ["--style", "nosuch"]):
        out = tmp_path / bad[0].strip("-")
        assert main(["study", "--quick", "--out", str(out), "--no-cache", *bad]) == 2
        assert not out.exists()
        assert repr(bad[1]) in capsys.readouterr().err
