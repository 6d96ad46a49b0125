"""Plugins from anywhere (contact_bench.api.registry, docs/plugin-api.md).

- a plugin folder (``--plugins DIR``, before or after the subcommand, and
  CONTACT_BENCH_PLUGINS): its scheme and scene appear in `list` and run; sweep workers
  (-j 2, dask) load it too;
- an entry-point plugin of a tiny distribution put on the path of a fresh process;
- a clashing name and a missing folder are one-line errors, a broken file a placeholder;
- the templates of docs/plugin-api.md run as they are; the plain-numpy scheme there is
  the Taylor-Flanagan step with a lumped mass, so it agrees with the compiled built-in
  to round-off;
- adding a scheme file and a scene file (copies of built-ins, renamed) keeps the
  registry-driven tests green: they run on the copies in a fresh pytest process.
"""

from __future__ import annotations

import importlib.util
import io
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from contact_bench.api import TrajectoryRecorder, n_samples
from contact_bench.api.fem import mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.api.registry import PLUGINS_ENV, cases, make_case, make_scheme, schemes
from contact_bench.cli.main import main
from contact_bench.harness import run_one
from contact_bench.sweeps.cache import code_hash

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "plugin-api.md"


def _templates() -> tuple[str, str]:
    """The scheme and the scene template of docs/plugin-api.md."""
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)
    assert len(blocks) == 3, ("docs/plugin-api.md: expected a scheme, a scene and an "
                              "implicit scheme template")
    return blocks[0], blocks[1]


def implicit_template(tmp_path: Path):
    """docs/plugin-api.md's implicit scheme template, loaded from a file."""
    code = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)[2]
    path = tmp_path / "plain_newmark.py"
    path.write_text(code, encoding="utf-8")
    spec = importlib.util.spec_from_file_location("plain_newmark_template", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.PlainNewmark()


@pytest.mark.parametrize("scene", sorted(cases().names()))
def test_the_implicit_template_runs_every_scene(scene: str, tmp_path: Path) -> None:
    """The implicit template (its contact through the suite's LCP solver) on every scene's
    smallest grid, shortly after its first impact: the compiled `standard`'s status (the
    same scheme: where it blows up, so does the template), no penetration beyond
    round-off when it runs."""
    case = make_case(scene)
    grid = case.study
    nx = grid.small_nx[-1] if grid is not None else 20
    T = grid.small_T if grid is not None else min(float(case.T), 2.0)
    spec = grid.small if grid is not None else scene
    template = implicit_template(tmp_path)
    if case.cannot_run(template) is not None:  # a curved obstacle: the template's G is fixed
        assert not template.follows_curved_obstacle()
        return
    run = run_one(spec, template, nx=nx, T=T)
    compiled = run_one(spec, "standard", nx=nx, T=T)
    assert run.row["status"] == compiled.row["status"], run.row["notes"]
    if run.row["status"] == "ok":
        assert run.trajectory.min_contact_u >= -1e-9 * max(case.size, 1.0)


def test_the_implicit_template_is_the_compiled_standard(tmp_path: Path) -> None:
    """Independent of the compiled kernels (scipy's factor, numpy's products): the same
    trajectory as the compiled `standard` to 1e-7 (its velocity carries round-off over
    beta dt^2), on the disc before it chatters
    and on the tilted plane."""
    for scene, T in (("disc_drop[degree=1,lift=0.4]", 3.0),
                     ("slanted_drop[of=disc_drop[degree=1,lift=0.4]]", 3.0)):
        a = run_one(scene, implicit_template(tmp_path), nx=2, T=T).trajectory
        b = run_one(scene, "standard", nx=2, T=T).trajectory
        assert b.extra["peak_contact_force"] > 0
        for field in ("U", "V", "contact_u", "stress", "energy"):
            x, y = getattr(a, field), getattr(b, field)
            assert np.max(np.abs(x - y)) <= 1e-7 * max(float(np.max(np.abs(y))), 1.0), field


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    """A plugin folder holding the two templates (plain_central, released_bar)."""
    scheme, scene = _templates()
    d = tmp_path / "my plugins"  # a space in the path on purpose
    d.mkdir()
    (d / "plain_central.py").write_text(scheme)
    (d / "released_bar.py").write_text(scene)
    return d


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", PLUGINS_ENV)}
    env.update(extra)
    return env


def test_a_plugin_folder_is_listed_and_runs(folder: Path, capsys) -> None:
    assert PLUGINS_ENV not in os.environ
    assert main(["--plugins", str(folder), "list"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"^  plain_central +template", out, re.M)
    assert re.search(r"^  released_bar +template", out, re.M)
    assert "contact=exact" in out and "energy=may grow" in out  # enums print their values
    assert PLUGINS_ENV not in os.environ  # main restores the environment
    assert "plain_central" not in schemes().plugins  # ... and so the registry
    for argv in (["--plugins", str(folder), "run"], ["run", "--plugins", str(folder)]):
        code = main([*argv, "--case", "clamped_bar", "--case", "released_bar",
                     "--scheme", "plain_central", "--nx", "20", "--T", "2", "--format", "csv"])
        captured = capsys.readouterr()
        assert code == 0, captured.err
        df = pd.read_csv(io.StringIO(captured.out))
        assert list(df["status"]) == ["ok", "ok"] and df["err_u_linf_l2"].iloc[0] < 0.2


def test_the_environment_variable_names_folders(folder: Path, tmp_path: Path,
                                                monkeypatch) -> None:
    other = tmp_path / "other"
    other.mkdir()
    monkeypatch.setenv(PLUGINS_ENV, os.pathsep.join([str(other), "", str(folder)]))
    assert {"plain_central"} <= set(schemes().plugins)
    assert {"released_bar"} <= set(cases().plugins)
    cls = schemes().get("plain_central")
    assert cls.__module__ == "contact_bench.plugins.plain_central"  # hashed like built-ins
    assert len(code_hash(cases().get("released_bar"), cls)) == 16


def test_the_template_runs_the_embedded_bar_as_the_bar(folder: Path, monkeypatch) -> None:
    """The docs' 2D template on the 2D embedded clamped bar gives the 1D clamped bar's row
    (the same file on both problem shapes), and the compiled scheme's."""
    monkeypatch.setenv(PLUGINS_ENV, str(folder))
    bar = run_one("clamped_bar", "plain_central", nx=40).row
    body = run_one("embedded_bar[of=clamped_bar,dim=2]", "plain_central", nx=40).row
    compiled = run_one("embedded_bar[of=clamped_bar,dim=2]", "taylor_flanagan[mass=lumped]",
                       nx=40).row
    assert bar["status"] == body["status"] == "ok" and bar["steps"] == body["steps"]
    for key in ("err_u_linf_l2", "err_v_linf_l2", "err_u_l2_h1", "energy_drift_max"):
        assert body[key] == pytest.approx(bar[key], rel=1e-9, abs=1e-12), key
        assert body[key] == pytest.approx(compiled[key], rel=1e-9, abs=1e-12), key
    assert body["chatter"] == compiled["chatter"] > 0


def test_the_template_is_the_compiled_taylor_flanagan_step(folder: Path, monkeypatch) -> None:
    """An independent check of the template (and of TrajectoryRecorder): plain numpy
    against the numba kernel of the same step, to round-off, over impacts."""
    monkeypatch.setenv(PLUGINS_ENV, str(folder))
    case = make_case("clamped_bar")
    mine = make_scheme("plain_central")
    built_in = make_scheme("taylor_flanagan[mass=lumped]")
    semi = discretise(case, mesh_nodes(case.L, 40), mine.mass_kind())
    a, b = mine.integrate(semi, 0.01, 1000, 3), built_in.integrate(semi, 0.01, 1000, 3)
    assert a.t.size == b.t.size == n_samples(1000, 3) and (a.stress < 0).sum() > 20
    for field in ("t", "U", "V", "contact_u", "stress", "energy"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), rtol=0, atol=1e-11)
    assert a.min_contact_u == pytest.approx(b.min_contact_u, abs=1e-12)
    assert a.steps_done == b.steps_done == 1000 and a.blowup_time is None


def test_the_recorder_stops_at_the_first_blown_up_sample() -> None:
    case = make_case("clamped_bar")
    semi = discretise(case, mesh_nodes(case.L, 10), "lumped")
    rec = TrajectoryRecorder(semi, 0.1, 20, 4)
    U, V = semi.U0.copy(), semi.V0.copy()
    for step in range(1, 21):
        V = np.full_like(V, 0.5 * 3.0 ** (step - 4))  # E(0) = 1/8: past 1e3 E(0) at step 8
        if rec.record(step, U, V, 0.0):
            break
    traj = rec.trajectory()
    assert step == 8 and traj.steps_done == 8 and traj.blowup_time == pytest.approx(0.8)
    assert list(traj.t) == pytest.approx([0.0, 0.4, 0.8])  # samples 0, 4, 8: kept, then stop
    assert traj.energy[-1] > 1e3 * traj.energy[0] > traj.energy[-2]


def test_sweep_workers_load_the_plugin_folder(folder: Path, tmp_path: Path) -> None:
    base = ["--case", "released_bar", "--scheme", "plain_central", "--nx", "8,16", "--cfl",
            "0.5", "--T", "1", "--repeats", "0", "--quiet", "--no-cache"]
    runs = [["-j", "2"]]
    try:
        import distributed  # noqa: F401

        runs.append(["-j", "2", "--dask", "local"])
    except ImportError:
        pass
    for extra in runs:
        out = tmp_path / f"sweep{len(extra)}"
        assert main(["--plugins", str(folder), "sweep", *base, *extra, "--out", str(out)]) == 0
        df = pd.read_csv(out / "sweep.csv")
        assert len(df) == 2 and (df["status"] == "ok").all(), df["notes"].tolist()


def test_a_name_defined_twice_names_both_files(folder: Path, tmp_path: Path, capsys) -> None:
    scheme, _ = _templates()
    twin = tmp_path / "twin"
    twin.mkdir()
    (twin / "copy_of_it.py").write_text(scheme)
    assert main(["--plugins", str(folder), "--plugins", str(twin), "list"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "two scheme plugins are named 'plain_central'" in err
    assert str(folder / "plain_central.py") in err and str(twin / "copy_of_it.py") in err
    builtin = tmp_path / "builtin"
    builtin.mkdir()
    (builtin / "mine.py").write_text(scheme.replace('"plain_central"', '"standard"'))
    assert main(["--plugins", str(builtin), "list"]) == 2
    err = capsys.readouterr().err.strip()
    assert str(ROOT / "schemes" / "standard.py") in err and str(builtin / "mine.py") in err


def test_a_missing_folder_is_one_line_and_a_broken_file_a_placeholder(folder: Path,
                                                                     capsys) -> None:
    assert main(["--plugins", str(folder / "nope"), "list"]) == 2
    assert capsys.readouterr().err.strip() == (
        f"contact-bench: error: --plugins {folder / 'nope'}: not a folder")
    (folder / "broken_one.py").write_text("import not_a_module_anywhere\n")
    assert main(["--plugins", str(folder), "list"]) == 0
    out = capsys.readouterr().out
    assert out.count("[broken plugin module broken_one:") == 1 and "plain_central" in out
    assert "ModuleNotFoundError" in out


def test_an_entry_point_plugin_is_listed_and_runs(tmp_path: Path) -> None:
    """A tiny distribution (a package and its dist-info with entry_points.txt) on the path
    of a fresh process: one module entry point per group."""
    scheme, scene = _templates()
    site = tmp_path / "site"
    pkg = site / "cb_tiny"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "scheme.py").write_text(scheme.replace('"plain_central"', '"ep_central"'))
    (pkg / "scene.py").write_text(scene.replace('"released_bar"', '"ep_bar"'))
    info = site / "cb_tiny-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: cb-tiny\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[contact_bench.schemes]\nep_central = cb_tiny.scheme\n\n"
        "[contact_bench.cases]\nep_bar = cb_tiny.scene\n")
    env = _env(PYTHONPATH=str(site))
    listed = subprocess.run([sys.executable, "-m", "contact_bench", "list"], env=env,
                            cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert listed.returncode == 0, listed.stderr
    assert re.search(r"^  ep_central ", listed.stdout, re.M)
    assert re.search(r"^  ep_bar ", listed.stdout, re.M)
    ran = subprocess.run([sys.executable, "-m", "contact_bench", "run", "--case", "ep_bar",
                          "--case", "clamped_bar", "--scheme", "ep_central", "--nx", "20",
                          "--T", "2", "--format", "csv"], env=env, cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    assert ran.returncode == 0, ran.stderr
    df = pd.read_csv(io.StringIO(ran.stdout))
    assert list(df["status"]) == ["ok", "ok"] and set(df["scheme"]) == {"ep_central"}


#: the registry-driven tests, run on the added plugins (-k on their names and on the
#: tests that loop over the whole registry)
REGISTRY_DRIVEN = ["tests/test_scheme_properties.py", "tests/test_properties.py",
                   "tests/test_scenes.py", "tests/test_reliability.py",
                   "tests/test_benchmark_scripts.py::test_scripts_refuse_bad_arguments_in_one_line"]


def test_adding_a_scheme_file_and_a_scene_file_keeps_the_suite_green(tmp_path: Path) -> None:
    """Copies of one built-in scheme and one built-in scene, renamed, in a plugin folder:
    the registry-driven tests run on them (and the whole-registry ones) and pass."""
    d = tmp_path / "added"
    d.mkdir()
    scheme = (ROOT / "schemes" / "standard.py").read_text()
    scene = (ROOT / "cases" / "clamped_bar.py").read_text()
    assert 'name = "standard"' in scheme and 'name = "clamped_bar"' in scene
    (d / "standard_copy.py").write_text(scheme.replace('name = "standard"',
                                                       'name = "standard_copy"'))
    (d / "clamped_copy.py").write_text(scene.replace('name = "clamped_bar"',
                                                     'name = "clamped_copy"'))
    select = ("standard_copy or clamped_copy or every or list_shows or refuse_bad "
              "or bad_input_list")
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-o", "addopts=", "-q", "-p", "no:cacheprovider",
         *REGISTRY_DRIVEN,
         "-k", select], cwd=ROOT, env=_env(**{PLUGINS_ENV: str(d)}), capture_output=True,
        text=True, timeout=1200)
    tail = proc.stdout[-3000:]
    assert proc.returncode == 0, tail
    collected = [line for line in proc.stdout.splitlines() if " passed" in line]
    assert collected and int(collected[-1].split()[0]) >= 15, tail


def test_the_code_hash_covers_an_entry_point_plugins_own_package(tmp_path: Path,
                                                                 monkeypatch) -> None:
    """A plugin outside the project namespace: its module and the modules of its own
    top-level package that it reaches count (an edited helper gives a new hash)."""
    from contact_bench.sweeps.cache import module_hash

    pkg = tmp_path / "cb_hash_probe"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "helper.py").write_text("def step(x):\n    return x + 1\n")
    (pkg / "scheme.py").write_text("from cb_hash_probe.helper import step\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    for name in ("cb_hash_probe", "cb_hash_probe.helper", "cb_hash_probe.scheme"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    before = module_hash.__wrapped__("cb_hash_probe.scheme")
    (pkg / "helper.py").write_text("def step(x):\n    return x + 2\n")
    assert module_hash.__wrapped__("cb_hash_probe.scheme") != before


def test_the_code_hash_covers_the_scenes_converged_reference(tmp_path: Path,
                                                              monkeypatch) -> None:
    """A scene reads its converged reference (results/references/<name>.json) at run
    time: a regenerated reference gives the scene's runs new keys, so rows against the old
    one are not served from the cache; another scene's keys stay."""
    from contact_bench.exact import converged

    monkeypatch.setattr(converged, "REFERENCES", tmp_path)
    disc, bar, scheme = cases().get("disc_drop"), cases().get("clamped_bar"), \
        schemes().get("redistributed")
    none, bar0 = code_hash(disc, scheme), code_hash(bar, scheme)
    (tmp_path / "disc_drop.json").write_text('{"value": 1}')
    one = code_hash(disc, scheme)
    (tmp_path / "disc_drop.json").write_text('{"value": 2}')
    assert len({none, one, code_hash(disc, scheme)}) == 3
    assert code_hash(bar, scheme) == bar0


def test_traits_take_enums_or_their_values_and_refuse_others() -> None:
    from contact_bench.api import BenchError, Contact, Energy, Traits

    t = Traits(implicit=True, massless_contact_node=False, contact="exact", energy="may grow")
    assert t.contact is Contact.EXACT and t.energy is Energy.MAY_GROW
    assert f"{t.contact} {t.energy}" == "exact may grow" and t.energy == "may grow"
    with pytest.raises(BenchError, match=r"Traits.energy = 'grows': not one of 'conserved'"):
        Traits(implicit=True, massless_contact_node=False, contact="exact", energy="grows")
