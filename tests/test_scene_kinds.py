"""Scenes say what they are: a bar scene (`BarCase`) declares a bar, a body scene
(`BodyCase`) only what a body has (its size, its sparse problem); `list`, the transit
check and the figures read those declarations, and the figures' labels are the scene's
(u(0, t) on a bar, the smallest gap on a body)."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest

from contact_bench.api import BarCase, BodyCase, Case
from contact_bench.api.registry import cases, make_case, make_scheme
from contact_bench.cases.disc_drop import DiscDrop
from contact_bench.cli.main import main
from contact_bench.core.errors import BenchError
from contact_bench.harness.runner import check_run

#: what only a bar has (a body may have a density or gravity of its own)
BAR_ATTRIBUTES = ("L", "E", "far_end", "u_L", "u0", "v0", "wave_speed")


@pytest.mark.parametrize("name", cases().names())
def test_every_scene_is_a_bar_or_a_body_and_declares_a_size(name):
    case = make_case(name)
    assert isinstance(case, (BarCase, BodyCase)), type(case).__mro__
    assert float(case.size) > 0
    assert case.contact_label and case.force_label
    if isinstance(case, BodyCase):
        assert case.form == "sparse"
        faked = [a for a in BAR_ATTRIBUTES if hasattr(case, a)]
        assert faked == [], f"{name} is a body but has bar attributes {faked}"
    else:
        assert case.size == case.L


@pytest.mark.parametrize("name", [n for n in cases().names()
                                  if isinstance(make_case(n), BodyCase)])
def test_every_body_scene_declares_its_dimension(name):
    # the contract a scheme's cannot_run reads (BodyCase.dim), against the dimension of
    # the problem the scene builds (a small grid)
    case = make_case(name)
    assert case.dim in (1, 2, 3), f"{name} declares no dim (BodyCase.dim)"
    assert case.sparse_problem(2, 1.0, "consistent").dim == case.dim
    for spec in ("slanted_drop[of=sphere_drop]", "sliding_block[dim=3]",
                 "manufactured[dim=3]"):  # a derived scene's base, a param
        assert make_case(spec).dim == 3


def test_the_kinds_label_their_contact_observable_and_force():
    assert (BarCase.contact_label, BarCase.force_label) == (
        "u(0, t)", "contact stress E u_x(0, t)")
    assert BodyCase.contact_label == "smallest gap"
    assert BodyCase.force_label.startswith("contact stress (total force")


def test_list_shows_a_body_without_bar_attributes(capsys):
    assert main(["list", "disc_drop"]) == 0
    out = capsys.readouterr().out
    assert "far end" not in out and "E=" not in out and "L=" not in out
    assert "body: size=40" in out
    assert main(["list", "clamped_bar"]) == 0
    assert "bar: L=1 rho=1 E=1 no gravity far end=clamped" in capsys.readouterr().out
    assert main(["list", "disc_drop", "--format", "json"]) == 0
    record = json.loads(capsys.readouterr().out)[0]
    assert record["scene"] == "body" and record["size"] == 40.0
    assert not {"L", "E", "far_end"} & set(record)


def _figure_axes(tmp_path: Path, capsys, args: list[str]) -> list[dict]:
    out = tmp_path / "out"
    assert main(["run", *args, "--out", str(out), "--format", "csv"]) == 0, \
        capsys.readouterr().err
    capsys.readouterr()
    (side,) = out.glob("*.fig.json")
    return json.loads(side.read_text())["axes"]


def test_a_body_figure_has_the_body_labels(tmp_path, capsys):
    axes = _figure_axes(tmp_path, capsys, [
        "--case", "disc_drop[degree=1,lift=0.5]", "--scheme", "redistributed", "--nx", "3",
        "--T", "0.05"])
    assert [a["ylabel"] for a in axes[:2]] == [BodyCase.contact_label, BodyCase.force_label]


def test_a_bar_figure_has_the_bar_labels(tmp_path, capsys):
    axes = _figure_axes(tmp_path, capsys, [
        "--case", "clamped_bar", "--scheme", "redistributed", "--nx", "10", "--T", "0.05"])
    assert [a["ylabel"] for a in axes[:2]] == ["u(0, t)", "contact stress E u_x(0, t)"]


def test_the_transit_check_reads_a_bodys_size():
    class TinyDisc(DiscDrop):
        size = 1e-6

    with pytest.raises(BenchError, match="wave transits of disc_drop"):
        check_run(TinyDisc(degree=1), make_scheme("redistributed"), 3, 0.01, 1.0, 1)

    class SizelessDisc(DiscDrop):
        size = float("nan")

    with pytest.raises(BenchError, match=r"^case disc_drop\[degree=1\]: size = nan must be "):
        check_run(SizelessDisc(degree=1), make_scheme("redistributed"), 3, 0.01, 1.0, 1)


def test_a_body_without_a_size_is_refused_at_its_definition():
    with pytest.raises(TypeError, match=r"^Lump \(lump\) declares no size"):
        class Lump(BodyCase):
            name = "lump"

    class AbstractBody(BodyCase):  # no name: a base for bodies, not a scene
        pass

    with pytest.raises(BenchError, match="declares no size"):
        AbstractBody().size  # noqa: B018


def test_a_scene_deriving_from_case_directly_is_refused():
    with pytest.raises(TypeError, match="^OldBar derives from Case; a scene derives from "
                                        "BarCase"):
        class OldBar(Case):
            name = "old_bar"


def test_a_plugin_file_deriving_from_case_is_listed_as_broken(tmp_path, capsys):
    (tmp_path / "old_bar.py").write_text(textwrap.dedent('''
        from contact_bench.api import Case


        class OldBar(Case):
            name = "old_bar"
            L = 1.0
    '''))
    assert main(["--plugins", str(tmp_path), "list", "cases"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "module old_bar:" in out and "[broken " in out
    assert "OldBar derives from Case; a scene derives from BarCase" in out
