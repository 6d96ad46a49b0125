"""The time of one step of a scheme on test_stepping.py's bar, stepping only (a sample at
the end), best of 7 runs after a compiling one: a quick per-step comparison between two
checkouts (run it from each with its own environment, alternating).

    python benchmarks/bar_step_time.py laursen_love 20 200000
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from test_stepping import _setup  # noqa: E402


def step_ns(spec: str, n: int, steps: int, repeats: int = 7) -> float:
    """Best time of one step (ns) of `spec` on the bar of n cells, with test_stepping.py's
    set-up (`_setup`: dt 0.5 h / c, 0.9 of the scheme's stability limit where that is
    smaller, compiled outside the timing)."""
    scheme, semi, dt, steps = _setup(spec, n, steps)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        scheme.integrate(semi, dt, steps, steps)
        best = min(best, time.perf_counter() - t0)
    return best / steps * 1e9


if __name__ == "__main__":
    spec, n, steps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    print(f"{spec} n{n}: {step_ns(spec, n, steps):.0f} ns/step")
