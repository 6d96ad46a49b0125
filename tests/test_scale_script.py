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
    assert sum(line.count("nan") == 2 for line in lines) == len(kinds)
    printed = capsys.readouterr().out
    for kind in kinds:
        assert f"disc_p2-nx6-dofs{smallest}-{kind}" in printed
        assert f"{smallest} dofs  step" in printed


def test_exponents_are_the_log_log_slopes():
    scale = _scale()
    dofs = np.array([1e3, 4e3, 1.6e4, 6.4e4])
    rows = pd.DataFrame({"label": "disc_p2", "kind": "implicit", "scheme": "redistributed",
                         "dofs": dofs, "step_s": 2e-7 * dofs ** 1.5,
                         "growth_MiB": 3e-3 * dofs, "status": "ok"})
    bad = rows.iloc[:1].assign(kind="explicit", step_s=np.nan, status="error")
    fit = scale.exponents(pd.concat([rows, bad], ignore_index=True))
    assert fit.loc[0, "time_exponent"] == pytest.approx(1.5)
    assert fit.loc[0, "memory_exponent"] == pytest.approx(1.0)
    assert list(fit["kind"]) == ["implicit"] and fit.loc[0, "sizes"] == 4


@pytest.mark.parametrize("argv, message", [(["--max-dofs", "10"], "--max-dofs 10"),
                                           (["--repeats", "0"], "--repeats")])
def test_scale_refuses_bad_options_in_one_line(argv, message, capsys):
    with pytest.raises(SystemExit) as exc:
        _scale().main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert message in err[-1], err
