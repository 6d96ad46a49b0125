"""benchmarks/scale.py (the scale benchmarks' script) runs at its smallest size and writes
its report; its growth exponents are least-squares slopes on log-log; bad options are
one argparse line."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _scale():
    spec = importlib.util.spec_from_file_location("_bench_scale", ROOT / "benchmarks" /
                                                  "scale.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_scale_runs_its_smallest_size_and_writes_the_report(tmp_path, capsys):
    scale = _scale()
    out = tmp_path / "scale.md"
    smallest = min(d for *_, d in scale.SIZES)
    assert scale.main(["--max-dofs", str(smallest), "--same-process", "--repeats", "1",
                       "--out", str(out)]) == 0
    text = out.read_text(encoding="utf-8")
    assert f"python benchmarks/scale.py --max-dofs {smallest}" in text
    assert "a partial run" in text
    lines = [line for line in text.splitlines() if line.startswith("| disc_p2 ")]
    kinds = scale.KINDS["disc_p2"]
    assert sum("| ok " in line for line in lines) == len(kinds)  # the sizes' rows
    # the exponents' rows: one size each, so no slope
    cells = [[c.strip() for c in line.split("|")[1:-1]] for line in lines]
    fits = [c for c in cells if c[4:6] == [str(smallest)] * 2]  # dofs_min, dofs_max
    assert len(fits) == len(kinds) and all(c[-3:] == ["nan"] * 3 for c in fits)
    printed = capsys.readouterr().out
    for kind in kinds:
        assert f"disc_p2-nx6-dofs{smallest}-{kind}" in printed
        assert f"{smallest} dofs  step" in printed
    # the set-up split and the solver floor beside each size
    table = [line.split("|")[1:-1] for line in lines if "| ok " in line]
    head = next(line for line in text.splitlines()
                if line.startswith("| label ") and " nx " in line)
    names = [c.strip() for c in head.split("|")[1:-1]]
    for cells in table:
        row = dict(zip(names, (c.strip() for c in cells), strict=True))
        parts = sum(float(row[c]) for c in ("assembly_s", "limit_s", "prepare_s"))
        assert parts == pytest.approx(float(row["setup_s"]), rel=0.05, abs=2e-3)
        assert float(row["assembly_s"]) > 1e-3  # built, not the warm-up's problem
        if row["kind"] == "implicit":  # its factor: S = M + dt^2/4 K
            assert float(row["solve_ms"]) > 0 and float(row["factor_s"]) > 0
            assert float(row["step_per_solve"]) == pytest.approx(
                float(row["step_ms"]) / float(row["solve_ms"]), rel=1e-3)
            assert float(row["setup_per_factor"]) == pytest.approx(
                float(row["setup_s"]) / float(row["factor_s"]), rel=1e-3)


def test_the_million_dof_ball_runs_only_when_named():
    scale = _scale()
    assert not [c for c in scale.configs() if c["label"] in scale.OPT_IN]
    named = scale.configs(labels=["ball_1e6"])
    assert {c["kind"] for c in named} == {"explicit_lumped"}
    assert max(c["dofs_id"] for c in named) > 9.5e5
    # the ids' dofs are the mesh's: the lattice ball's vertex count, 3 unknowns each
    # (the refined octahedron's formula, (2n+1)(2n^2+2n+3)/3 vertices)
    from contact_bench.api.registry import make_case
    case = make_case(named[0]["scene"])
    for c in named:
        n = c["nx"]
        assert c["dofs_id"] == 3 * (2 * n + 1) * (2 * n * n + 2 * n + 3) // 3
        assert case.footprint(n).unknowns == c["dofs_id"]
    assert case.mesh(16).p.shape[1] * 3 == named[0]["dofs_id"]


def test_exponents_are_the_log_log_slopes():
    scale = _scale()
    dofs = np.array([1e3, 4e3, 1.6e4, 6.4e4])
    rows = pd.DataFrame({"label": "disc_p2", "kind": "implicit", "scheme": "redistributed",
                         "dofs": dofs, "step_s": 2e-7 * dofs ** 1.5,
                         "setup_s": 1e-5 * dofs ** 1.2 * (1 + 0.01 * np.array([1, -1, 1, -1])),
                         "growth_MiB": 3e-3 * dofs, "status": "ok"})
    bad = rows.iloc[:1].assign(kind="explicit", step_s=np.nan, status="error")
    fit = scale.exponents(pd.concat([rows, bad], ignore_index=True))
    assert fit.loc[0, "step_exponent"] == pytest.approx(1.5)
    assert fit.loc[0, "memory_exponent"] == pytest.approx(1.0)
    # the noisy set-up: the slope of the least-squares line (numpy's lstsq, independently)
    x = np.column_stack([np.log(dofs), np.ones(4)])
    slope = np.linalg.lstsq(x, np.log(rows["setup_s"].to_numpy()), rcond=None)[0][0]
    assert fit.loc[0, "setup_exponent"] == pytest.approx(slope, rel=1e-12)
    assert abs(slope - 1.2) > 1e-4  # the noise moved it: not the exponent given
    assert list(fit["kind"]) == ["implicit"] and fit.loc[0, "sizes"] == 4


@pytest.mark.parametrize("argv, message", [(["--max-dofs", "10"], "--max-dofs 10"),
                                           (["--repeats", "0"], "--repeats")])
def test_scale_refuses_bad_options_in_one_line(argv, message, capsys):
    with pytest.raises(SystemExit) as exc:
        _scale().main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert message in err[-1], err
