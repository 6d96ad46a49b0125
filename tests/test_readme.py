"""The README's "Add your own scheme" template runs as it is.

The first ```python block under that heading is written into a temporary plugins folder,
imported from there, and run on the paper's two scenes and on the disc, on small grids.
It steps the explicit central difference with a lumped mass and the Taylor-Flanagan
contact force on the general problem, which the built-in `taylor_flanagan[mass=lumped]`
steps in compiled code (the bar's banded kernel, the body's sparse one): the two must
agree to round-off, and the template's errors must shrink under refinement.
"""

from __future__ import annotations

import importlib.util
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from contact_bench.api import make_case, make_scheme
from contact_bench.api.plugin import Scheme
from contact_bench.harness import run_one
from contact_bench.harness.runner import problem_for

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


def test_readme_scheme_table_lists_every_scheme_with_its_declared_class():
    """The Schemes table names every built-in scheme once, and its `class` column is the
    scheme's declared `Traits.family` (Doyen, Ern, Piperno's classification)."""
    from contact_bench.api.registry import schemes

    section = README.read_text(encoding="utf-8").split("## Schemes", 1)[1].split("\n## ", 1)[0]
    rows = [line.split("|")[1:-1] for line in section.splitlines() if line.startswith("| `")]
    header = [c.strip() for c in next(line for line in section.splitlines()
                                      if line.startswith("| scheme")).split("|")[1:-1]]
    col = header.index("class")
    listed = {re.match(r" `(\w+)", r[0]).group(1): r[col].strip() for r in rows}
    assert sorted(listed) == sorted(schemes().plugins), "README's scheme table is not the registry"
    for name, family in listed.items():
        assert family == make_scheme(name).traits().family, (name, family)


@pytest.mark.parametrize("case", ["clamped_bar", "dropped_bar"])
def test_readme_template_runs_and_matches_the_compiled_scheme(case: str, tmp_path: Path):
    cls, _ = load_template(tmp_path)
    errors = []
    for nx in (20, 40):
        run = run_one(case, cls(), nx=nx)
        row = run.row
        assert row["status"] == "ok", row["notes"]
        ref = run_one(case, "taylor_flanagan[mass=lumped]", nx=nx).row
        assert row["steps"] == ref["steps"] and row["dt"] == ref["dt"]
        for key in ("err_u_linf_l2", "err_v_linf_l2", "err_stress_l2", "energy_drift_max",
                    "penetration_max"):
            assert row[key] == pytest.approx(ref[key], rel=1e-8, abs=1e-12), key
        errors.append(row["err_u_linf_l2"])
    assert errors[1] < 0.75 * errors[0]  # refinement helps


def test_readme_template_runs_the_disc_as_the_compiled_scheme(tmp_path: Path):
    """The same file on a 2D body: the compiled sparse kernel's trajectory to round-off."""
    cls, _ = load_template(tmp_path)
    mine = run_one("disc_drop[degree=1,lift=0.4]", cls(), nx=2, T=5.0)
    ref = run_one("disc_drop[degree=1,lift=0.4]", "taylor_flanagan[mass=lumped]", nx=2,
                  T=5.0)
    assert mine.row["status"] == ref.row["status"] == "ok"
    assert mine.row["chatter"] == ref.row["chatter"] > 0  # the contact statistics too
    a, b = mine.trajectory, ref.trajectory
    for field in ("U", "V", "contact_u", "stress", "energy"):
        scale = max(float(np.max(np.abs(getattr(b, field)))), 1.0)
        assert np.max(np.abs(getattr(a, field) - getattr(b, field))) <= 1e-11 * scale, field
    # the recorder keeps the compiled loop's impulse (`core.loop.book_step`): the whole
    # run's, the first contact's and each sample's
    for key in ("contact_impulse", "first_contact_impulse"):
        assert a.extra[key] == pytest.approx(b.extra[key], rel=1e-12), key
    assert np.max(np.abs(a.extra["impulse"] - b.extra["impulse"])) <= 1e-12 * b.extra[
        "contact_impulse"]


def _cli_has_plugins_option() -> bool:
    out = subprocess.run([sys.executable, "-m", "contact_bench", "--help"],
                         capture_output=True, text=True, timeout=120).stdout
    return "--plugins" in out


def readme_plugin_commands() -> list[str]:
    """The ```bash block that follows the template: the commands a user types."""
    section = README.read_text(encoding="utf-8").split(HEADING, 1)[1].split("\n## ", 1)[0]
    block = re.findall(r"```bash\n(.*?)```", section, flags=re.S)[0]
    return [line.split("#")[0].strip() for line in block.splitlines()
            if line.startswith("contact-bench ")]


def test_readme_plugin_commands_run_as_printed(tmp_path: Path):
    """The README's commands, word for word, with its folder `my_schemes` holding the
    template as the README says to save it: each exits 0; `list` names the P2 scenes
    the template declares it cannot run, and the run's row is ok."""
    if not _cli_has_plugins_option():
        pytest.skip("this checkout's CLI has no --plugins option yet")
    commands = readme_plugin_commands()
    assert len(commands) == 2 and all("--plugins my_schemes" in c for c in commands)
    folder = tmp_path / "my_schemes"
    folder.mkdir()
    cls, _ = load_template(folder)
    outputs = []
    for command in commands:
        argv = shlex.split(command)
        assert argv[0] == "contact-bench"
        done = subprocess.run([sys.executable, "-m", "contact_bench", *argv[1:]],
                              capture_output=True, text=True, timeout=600, cwd=tmp_path)
        assert done.returncode == 0, (command, done.stderr)
        outputs.append(done.stdout)
    run_out, list_out = outputs
    row = next(line for line in run_out.splitlines() if cls.name in line and "disc_drop" in line)
    assert row.split()[-1] == "ok", row
    cannot = re.search(r"cannot run \(defaults\): (.*)", list_out)
    # curved_drop: the template's gap operator is fixed (Scheme.follows_curved_obstacle)
    assert cannot and set(cannot.group(1).replace(",", " ").split()) == {"disc_drop",
                                                                        "hertz_sphere",
                                                                        "curved_drop"}


def test_readme_template_runs_the_time_dependent_load(tmp_path: Path):
    """The template adds problem.load: on the manufactured scene (closed form, a
    time-dependent load) it runs, and its displacement error shrinks under space-time
    refinement."""
    cls, _ = load_template(tmp_path)
    errs = []
    for nx in (4, 8):
        row = run_one("manufactured", cls(), nx=nx, dt=0.02 * 4 / nx, T=0.2).row
        assert row["status"] == "ok", row["notes"]
        errs.append(row["err_u_linf_l2"])
    assert errs[1] < 0.6 * errs[0] < 0.1, errs


def test_readme_template_declares_the_compiled_schemes_stability_limit(tmp_path: Path):
    """The template's limit (2 / omega_max by eigsh) is the compiled scheme's on the disc
    (the mesh's own eigenvalue); on the lumped bar it lies just above h / c, the 1D formula
    (the sup of 2 / omega_max over every bar length)."""
    cls, _ = load_template(tmp_path)
    ref = make_scheme("taylor_flanagan[mass=lumped]")
    disc = problem_for(make_case("disc_drop[degree=1]"), ref, 2)
    assert cls().stability_limit(disc) == pytest.approx(ref.stability_limit(disc), rel=1e-6)
    bar = problem_for(make_case("clamped_bar"), ref, 40)
    assert 1.0 <= cls().stability_limit(bar) / ref.stability_limit(bar) < 1.001
