"""The generated vector Newmark kernels (bench/kernels/newmark_vec.py) are what their
generator writes today: a change to `contact_bench.kernels.newmark_codegen` must be
followed by `python -m contact_bench.kernels.newmark_codegen` (the kernels' behaviour is
tested through the schemes, in tests/test_reference.py)."""

from __future__ import annotations

import subprocess
import sys

from contact_bench.kernels import newmark_codegen

GENERATOR = "contact_bench.kernels.newmark_codegen"


def test_generated_kernels_are_up_to_date():
    assert newmark_codegen.TARGET.read_text() == newmark_codegen.source(), (
        f"bench/kernels/newmark_vec.py is out of date: run python -m {GENERATOR}")


def test_check_flag_reports_a_stale_file(tmp_path, monkeypatch):
    stale = tmp_path / "newmark_vec.py"
    stale.write_text(newmark_codegen.source() + "# edited by hand\n")
    monkeypatch.setattr(newmark_codegen, "TARGET", stale)
    assert newmark_codegen.main(["--check"]) == 1
    assert newmark_codegen.main([]) == 0  # rewrites it
    assert newmark_codegen.main(["--check"]) == 0


def test_check_command_passes_on_the_repository():
    done = subprocess.run([sys.executable, "-m", GENERATOR, "--check"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "up to date" in done.stdout
