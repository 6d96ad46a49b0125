"""Performance tracking compares like with like (docs/benchmarks.md): every pytest-benchmark
id fixes its work (scene, n, steps), `extra_info` carries n, steps and ns_per_dof_step,
and the save / compare / fail-on-regression workflow works on two saved runs."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ID = re.compile(r"::(?P<test>\w+)\[(?P<spec>.+)-(?P<case>[a-z_]+)"
                r"-n(?P<n>1e\d|\d+)-steps(?P<steps>\d+)(?:-(?P<mode>step|rec1))?\]$")


def _collect() -> list[str]:
    out = subprocess.run([sys.executable, "-m", "pytest", "--collect-only",
                          "-p", "no:cacheprovider", "benchmarks/test_stepping.py"],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    return [ln for ln in out.stdout.splitlines() if "::" in ln]


def test_every_stepping_id_names_its_work():
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import test_stepping as bench
    finally:
        sys.path.pop(0)
    ids = _collect()
    assert len(ids) > 20
    for node in ids:
        m = ID.search(node)
        assert m, node
        n = int(float(m["n"]))
        assert m["case"] == bench.CASE
        steps_for = bench.size_steps_for if m["test"] == "test_sizes" else bench.steps_for
        assert int(m["steps"]) == steps_for(m["spec"], n), node
    assert len(set(ids)) == len(ids)


def _bench(storage: Path, *extra: str) -> subprocess.CompletedProcess:
    # a serial pytest: pytest-benchmark switches itself off in an xdist worker's environment
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_XDIST")}
    return subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
         "benchmarks/test_stepping.py::test_stepping", "-k", "restitution-clamped_bar-n1e3",
         f"--benchmark-storage=file://{storage}", *extra],
        cwd=ROOT, capture_output=True, text=True, timeout=600, env=env)


def test_save_compare_and_fail_on_regression(tmp_path):
    """Two saved runs of one id: the same name, n and steps in both; `pytest-benchmark
    compare` lists both; a run compared with --benchmark-compare-fail=median:10%
    against a saved run made 10x faster (edited) fails."""
    pytest.importorskip("pytest_benchmark")
    store = tmp_path / "store"
    for name in ("first", "second"):
        run = _bench(store, f"--benchmark-save={name}")
        assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    files = sorted(store.rglob("*.json"))
    assert [f.name for f in files] == ["0001_first.json", "0002_second.json"]
    saved = [json.loads(f.read_text())["benchmarks"] for f in files]
    (a,), (b,) = saved
    assert a["name"] == b["name"] == "test_stepping[restitution-clamped_bar-n1e3-steps50000]"
    for key in ("n", "steps"):
        assert a["extra_info"][key] == b["extra_info"][key]
    assert a["extra_info"]["steps"] == 50000 and a["extra_info"]["ns_per_dof_step"] > 0
    cli = Path(sys.executable).with_name("pytest-benchmark")
    if not cli.exists():
        pytest.skip("no pytest-benchmark console script next to this python")
    cmp = subprocess.run([str(cli), f"--storage=file://{store}", "compare", "0001", "0002",
                          "--columns=median,iqr"], cwd=ROOT, capture_output=True, text=True,
                         timeout=120)
    assert cmp.returncode == 0, cmp.stderr
    assert cmp.stdout.count("restitution-clamped_bar-n1e3-steps50000") == 2, cmp.stdout
    # a saved baseline 10x faster than anything this machine does: the run must fail
    data = json.loads(files[0].read_text())
    for key in ("min", "max", "mean", "median", "q1", "q3"):
        data["benchmarks"][0]["stats"][key] /= 10.0
    files[0].write_text(json.dumps(data))
    fail = _bench(store, "--benchmark-compare=0001", "--benchmark-compare-fail=median:10%")
    assert fail.returncode != 0
    assert "Performance has regressed" in fail.stdout + fail.stderr


def test_every_norms_id_names_its_work():
    out = subprocess.run([sys.executable, "-m", "pytest", "--collect-only",
                          "-p", "no:cacheprovider", "benchmarks/test_norms.py"],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    ids = [ln for ln in out.stdout.splitlines() if "::" in ln]
    assert ids and len(set(ids)) == len(ids)
    for node in ids:
        assert re.search(r"\[[a-z_]+-nx\d+-dt[0-9.e-]+-T[0-9.]+-(cold|warm)\]$", node), node
