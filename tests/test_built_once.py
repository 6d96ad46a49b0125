"""A run and a sweep task build the scene's mesh once and its problem once, and hand
them on (the checks, the run, its error columns, its fields and the timing pass read the
same ones): counted on the disc drop, whose mesh constructor (`ring_disc`) and problem
(`DiscDrop.sparse_problem`) are wrapped to count their calls by resolution."""

from __future__ import annotations

import collections

import pytest

from contact_bench.api.kept import BUILT, Kept, built_once
from contact_bench.cases import disc_drop
from contact_bench.cli.entry import main
from contact_bench.harness.runner import run_one
from contact_bench.sweeps.cache import Cache
from contact_bench.sweeps.sweep import plan, run_sweep

SCENE = "disc_drop[degree=1,lift=0.5]"
NX = 3  # the smallest ring mesh whose redistributed mass the scene accepts


@pytest.fixture
def counts(monkeypatch: pytest.MonkeyPatch) -> collections.Counter:
    """Calls of the disc's mesh constructor and problem, by ("mesh" | "problem", nx)."""
    monkeypatch.setenv("CONTACT_BENCH_REFERENCE_CACHE", "off")
    Kept.clear_all()  # as in a new process
    seen: collections.Counter = collections.Counter()
    ring, problem = disc_drop.ring_disc, disc_drop.DiscDrop.sparse_problem

    def counted_ring(n: int):
        seen["mesh", int(n)] += 1
        return ring(n)

    def counted_problem(self, nx, grading, mass_kind):
        seen["problem", int(nx)] += 1
        return problem(self, nx, grading, mass_kind)

    monkeypatch.setattr(disc_drop, "ring_disc", counted_ring)
    monkeypatch.setattr(disc_drop.DiscDrop, "sparse_problem", counted_problem)
    return seen


def test_a_disc_run_builds_its_mesh_once_and_its_problem_once(counts):
    run = run_one(SCENE, "redistributed", nx=NX, T=4.0)
    assert run.row["status"] == "ok", run.row["notes"]
    assert run.row["err_u_numerical"] is not None  # the scene read its mesh again
    assert counts["mesh", NX] == 1 and counts["problem", NX] == 1
    # its numerical reference (twice the rings) is another mesh, built once too
    assert counts["mesh", 2 * NX] == 1 and counts["problem", 2 * NX] == 1


def test_a_disc_run_from_the_cli_with_its_fields_builds_them_once(counts, tmp_path):
    assert main(["run", "--case", SCENE, "--scheme", "redistributed", "--nx", str(NX),
                 "--T", "4", "--out", str(tmp_path)]) in (0, None)
    assert list(tmp_path.glob("snapshots_*.png"))  # the fields read the body again
    assert counts["mesh", NX] == 1 and counts["problem", NX] == 1


def test_a_sweep_task_builds_its_mesh_once_and_its_problem_once(counts):
    tasks = plan([SCENE], ["redistributed"], nxs=[NX], T=4.0)
    result = run_sweep(tasks, jobs=1, cache=Cache(None), repeats=1, quiet=True)
    assert list(result.table["status"]) == ["ok"]
    assert result.timed == 1  # the timing pass ran, on the same problem
    assert counts["mesh", NX] == 1 and counts["problem", NX] == 1


def test_kept_is_bounded_and_keeps_nothing_from_a_failed_build():
    kept: Kept[int] = Kept("test", max_items=2)
    built = []
    for key in (1, 2, 1, 3, 2):
        kept.get_or_build(key, lambda key=key: built.append(key) or key)
    assert built == [1, 2, 3, 2] and len(kept) == 2  # 2 was the oldest when 3 came
    with pytest.raises(ValueError):
        kept.get_or_build(4, lambda: (_ for _ in ()).throw(ValueError("bad mesh")))
    assert 4 not in kept
    kept.clear()
    assert len(kept) == 0


def test_built_once_keys_on_the_scene_not_the_object():
    class Calls:
        n = 0

    @built_once
    def mesh(case, nx):
        Calls.n += 1
        return nx

    BUILT.clear()
    a, b = disc_drop.DiscDrop(degree=1), disc_drop.DiscDrop(degree=1)
    assert mesh(a, 3) == mesh(b, 3) == 3 and Calls.n == 1  # one scene: one build
    mesh(disc_drop.DiscDrop(degree=1, lift=2.0), 3)  # another scene: its own
    assert Calls.n == 2


@pytest.mark.parametrize("spec,nx,scheme,count_on", [
    ("sphere_drop[lift=0.1]", 2, "standard", ("MeshTet1", "init_ball")),
    ("manufactured[dim=2]", 3, "standard", ("MeshTri1", "init_tensor")),
])
def test_the_ball_and_the_manufactured_square_are_built_once(
        monkeypatch: pytest.MonkeyPatch, tmp_path, spec, nx, scheme, count_on) -> None:
    """A CLI run with its fields and pictures: the mesh constructor is called once."""
    import skfem

    monkeypatch.setenv("CONTACT_BENCH_REFERENCE_CACHE", "off")
    Kept.clear_all()
    cls = getattr(skfem, count_on[0])
    build = getattr(cls, count_on[1]).__func__
    calls = []

    def counted(klass, *args, **kwargs):
        calls.append(args)
        return build(klass, *args, **kwargs)

    monkeypatch.setattr(cls, count_on[1], classmethod(counted))
    assert main(["run", "--case", spec, "--scheme", scheme, "--nx", str(nx), "--T", "2",
                 "--stride", "1", "--out", str(tmp_path), "--quiet"]) in (0, None)
    assert list(tmp_path.glob("snapshots_*.png"))  # the fields read the body again
    assert len(calls) == 1
