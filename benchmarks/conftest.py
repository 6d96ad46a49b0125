"""pytest-benchmark suite (not in the default test run: pyproject's testpaths is tests/).

    python -m pytest benchmarks --benchmark-save=NAME  # .benchmarks/<machine>/NNNN_NAME.json
    pytest-benchmark compare --columns=median,iqr --sort=name   # compare the saved runs
    python -m pytest benchmarks --benchmark-compare --benchmark-compare-fail=median:10%

Every id fixes its work (scene, n, steps in the name), so runs compare like with like
(docs/benchmarks.md).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def pytest_addoption(parser) -> None:  # noqa: ANN001 - pytest's Parser
    parser.addoption("--scale-max-dofs", type=float, default=None,
                     help="test_scale.py: the sizes up to this many dofs only (default: all)")
