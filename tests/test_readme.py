"""The README's "Add your own scheme" template runs as it is.

The first ```python block under that heading is written into a temporary plugins folder,
imported from there, and run on the paper's two scenes on small grids. It steps the
explicit central difference with a massless contact node, which the built-in
`redistributed[beta=0]` steps in compiled code: the two must agree to round-off, and
the template's errors must shrink under refinement.
"""

from __future__ import annotations

import csv
import importlib.util
import io
import re
import subprocess
import sys
from pathlib import Path

import pytest

from contact_bench.api import make_scheme
from contact_bench.api.plugin import Scheme
from contact_bench.harness import run_one

README = Path(__file__).resolve().parents[1] / "README.md"
HEADING = "## Add your own scheme"


def template_code() -> str:
    text = README.read_text(encoding="utf-8")
    assert HEADING in text, f"README.md has no {HEADING!r} section"
    section = text.split(HEADING, 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert blocks, "the section holds no ```python block"
    return blocks[0]


def load_template(folder: Path) -> tuple[type[Scheme], Path]:
    """Write the template into `folder` (as a user would save it) and import it."""
    name = re.search(r'^    name = "(\w+)"', template_code(), flags=re.M)
    assert name, "the template declares no name"
    path = folder / f"{name.group(1)}.py"
    path.write_text(template_code(), encoding="utf-8")
    spec = importlib.util.spec_from_file_location(f"readme_template_{name.group(1)}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    found = [obj for obj in vars(module).values()
             if isinstance(obj, type) and issubclass(obj, Scheme) and obj is not Scheme
             and obj.__module__ == module.__name__]
    assert len(found) == 1, f"expected one Scheme subclass in the template, got {found}"
    return found[0], path


def test_readme_is_a_short_user_guide():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 250, f"README.md has {len(lines)} lines (at most 250)"
    text = "\n".join(lines)
    assert "Dabaghi" in text and "ESAIM" in text
    for command in ('pip install -e . && contact-bench run',
                    'pip install -e ".[test]" && python -m pytest'):
        assert command in text
    for link in re.findall(r"\]\((docs/[^)#]+)\)", text):
        assert (README.parent / link).is_file(), f"README links to missing {link}"


@pytest.mark.parametrize("case", ["clamped_bar", "dropped_bar"])
def test_readme_template_runs_and_matches_the_compiled_scheme(case: str, tmp_path: Path):
    cls, _ = load_template(tmp_path)
    errors = []
    for nx in (20, 40):
        run = run_one(case, cls(), nx=nx)
        row = run.row
        assert row["status"] == "ok", row["notes"]
        assert row["penetration_max"] <= 1e-12
        ref = run_one(case, "redistributed[beta=0]", nx=nx).row
        assert row["steps"] == ref["steps"] and row["dt"] == ref["dt"]
        for key in ("err_u_linf_l2", "err_v_linf_l2", "err_stress_l2", "energy_drift_max"):
            assert row[key] == pytest.approx(ref[key], rel=1e-8, abs=1e-12), key
        errors.append(row["err_u_linf_l2"])
    assert errors[1] < 0.75 * errors[0]  # refinement helps


def test_readme_template_variant_parameter(tmp_path: Path):
    """The template's parameter is parsed like a built-in one (spec, choices)."""
    cls, _ = load_template(tmp_path)
    scheme = cls(variant="getfem")
    assert scheme.spec == f"{cls.name}[variant=getfem]"
    row = run_one("clamped_bar", scheme, nx=20, T=1.5).row
    ref = run_one("clamped_bar", "redistributed[beta=0,variant=getfem]", nx=20, T=1.5).row
    assert row["status"] == "ok"
    assert row["err_u_linf_l2"] == pytest.approx(ref["err_u_linf_l2"], rel=1e-8)


def _cli_has_plugins_option() -> bool:
    out = subprocess.run([sys.executable, "-m", "contact_bench", "--help"],
                         capture_output=True, text=True, timeout=120).stdout
    return "--plugins" in out


def test_readme_template_runs_from_a_plugins_folder(tmp_path: Path):
    """The README's command: `contact-bench --plugins DIR run --scheme NAME ...`."""
    if not _cli_has_plugins_option():
        pytest.skip("this checkout's CLI has no --plugins option yet")
    cls, path = load_template(tmp_path)
    cmd = [sys.executable, "-m", "contact_bench", "--plugins", str(path.parent), "run",
           "--scheme", cls.name, "--case", "clamped_bar", "--nx", "20", "--T", "1.5",
           "--format", "csv"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    rows = list(csv.DictReader(io.StringIO(done.stdout)))
    assert [(r["scheme"], r["status"]) for r in rows] == [(cls.name, "ok")]


def test_readme_template_declares_the_compiled_schemes_stability_limit(tmp_path: Path):
    """The template's declared limit is redistributed[beta=0]'s for every mass variant
    (0.556 h/c with the first_element_massless mass's edge mode, h/(c sqrt 3) otherwise)."""
    cls, _ = load_template(tmp_path)
    for variant in cls.params["variant"].choices:
        ref = make_scheme(f"redistributed[beta=0,variant={variant}]")
        for h, c in ((0.1, 2.0), (1e-3, 5e3)):
            assert cls(variant=variant).stability_limit(h, c) == pytest.approx(
                ref.stability_limit(h, c), rel=1e-12), variant
