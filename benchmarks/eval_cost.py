"""Cost of evaluating a reference at the error norms' quadrature points, per point.

    python benchmarks/eval_cost.py                 # the default run's two scenes
    python benchmarks/eval_cost.py pulse --repeats 50

For each case at its defaults (nx, dt, T; one sample per step): the reference's
`fields_into` at the 4 Gauss points of every element (`bench.metrics`' geometry) for
every sample time, by the norms' blocks of sample times into one reused block of
values, as `bench.metrics` calls it. Prints the median and the minimum over `--repeats`
passes (JIT compilation and the reference's construction outside the timing) in ns per
quadrature point: the evaluation's part of a run's norm time (`norm_cost.py`).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench import metrics  # noqa: E402
from bench.harness import reference  # noqa: E402
from bench.registry import cases  # noqa: E402


def _once(exact: Any, X: np.ndarray, t: np.ndarray, step: int, u: np.ndarray,
          ux: np.ndarray, ut: np.ndarray | None) -> None:
    """One pass: every block of `step` sample times into the same arrays."""
    for a in range(0, t.size, step):
        k = min(step, t.size - a)
        exact.fields_into(X, t[a:a + k], u[:k], ux[:k], None if ut is None else ut[:k])


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("case", nargs="*", help="cases (default: those of the default run)")
    p.add_argument("--repeats", type=int, default=20, help="passes timed (default 20)")
    args = p.parse_args(argv)
    if args.repeats < 1:
        p.error(f"--repeats must be >= 1, got {args.repeats}")
    plugins = cases().plugins
    names = args.case or [n for n, c in plugins.items() if c.in_default_run]
    for name in names:
        if name not in plugins:
            p.error(f"unknown case {name!r}; known: {', '.join(sorted(plugins))}")
    print(f"{'case':<18} {'points':>9} {'median ns/pt':>13} {'min ns/pt':>10}")
    for name in names:
        case = plugins[name]()
        exact = reference(case, case.T) if case.reference else None
        if exact is None or getattr(exact, "fields_into", None) is None:
            print(f"{name:<18} (no reference with fields_into)")
            continue
        x = np.linspace(0.0, case.L, case.nx + 1)
        t = np.linspace(0.0, case.T, int(round(case.T / case.dt)) + 1)
        ec, step = metrics._blocks(case.nx)
        g = metrics._Geometry.of(x, 0, min(ec, case.nx))
        X = g.X.reshape(-1)
        kb = min(step, t.size)
        u, ux, ut = (np.empty((kb, X.size)) for _ in range(3))
        want_v = "v" in case.provides

        _once(exact, X, t, step, u, ux, ut if want_v else None)  # compiled, pages touched
        times = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            _once(exact, X, t, step, u, ux, ut if want_v else None)
            times.append(time.perf_counter() - start)
        n = t.size * X.size
        print(f"{name:<18} {n:>9} {statistics.median(times) * 1e9 / n:>13.2f} "
              f"{min(times) * 1e9 / n:>10.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
