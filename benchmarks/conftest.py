"""pytest-benchmark suite (not in the default test run: pyproject's testpaths is tests/).

    python -m pytest benchmarks --benchmark-autosave      # saves .benchmarks/<machine>/NNNN_*.json
    pytest-benchmark compare --columns=median,iqr --sort=name   # compare the saved runs
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
