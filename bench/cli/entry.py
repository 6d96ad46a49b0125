"""The console script's entry point (`contact-bench`, `python -m contact_bench`).

It imports the command line inside a guard, so a Ctrl-C while the modules import (a
second or more: numpy, scikit-fem, numba) ends with one line and exit 130 like one during
the work, not a KeyboardInterrupt traceback.
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Sequence

STARTING = "contact-bench: interrupted while starting (nothing written)"


def main(argv: Sequence[str] | None = None) -> int:
    try:
        from contact_bench.cli.main import main as run
    except KeyboardInterrupt:
        print(STARTING, file=sys.stderr)
        return 130
    return run(argv)
