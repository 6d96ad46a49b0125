"""Cost of evaluating a reference at the error norms' quadrature points, per point.

    python benchmarks/eval_cost.py                 # the default run's two scenes
    python benchmarks/eval_cost.py pulse --repeats 50
    python benchmarks/eval_cost.py rough_data --cells-per-length 1000

For each case at its defaults (nx, dt, T; one sample per step): the reference at the 4
Gauss points of every element (`contact_bench.harness.metrics`' geometry) for every sample time, by
the norms' blocks of sample times and the norms' own call
(`contact_bench.harness.metrics._evaluate`:
`fields_into` into one reused block of values, else `fields`). Prints the median and
the minimum over `--repeats` passes (JIT compilation and the reference's construction
outside the timing) in ns per quadrature point: the evaluation's part of a run's norm
time (`norm_cost.py`).
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

from contact_bench.api.registry import cases, make_case  # noqa: E402
from contact_bench.core.errors import BenchError  # noqa: E402
from contact_bench.exact.characteristics import CharacteristicsSolution  # noqa: E402
from contact_bench.harness import metrics  # noqa: E402
from contact_bench.harness.runner import reference  # noqa: E402


def _once(exact: Any, g: Any, t: np.ndarray, step: int, need_v: bool,
          block: np.ndarray | None) -> None:
    """One pass: every block of `step` sample times, by the norms' own call
    (`contact_bench.harness.metrics._evaluate`: `fields_into` into the reused block, else
    `fields`)."""
    for a in range(0, t.size, step):
        k = min(step, t.size - a)
        out = None if block is None else block[:, :k]
        metrics._evaluate(exact, g, t[a:a + k], need_v, out)


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("case", nargs="*", help="cases (default: those of the default run)")
    p.add_argument("--repeats", type=int, default=20, help="passes timed (default 20)")
    p.add_argument("--cells-per-length", type=int, default=None,
                   help="a characteristics reference rebuilt on this many cells per length")
    args = p.parse_args(argv)
    if args.repeats < 1:
        p.error(f"--repeats must be >= 1, got {args.repeats}")
    if args.cells_per_length is not None and args.cells_per_length < 1:
        p.error(f"--cells-per-length must be >= 1, got {args.cells_per_length}")
    names = args.case or [n for n, c in cases().plugins.items() if c.in_default_run]
    try:  # the registry's own check: a one-line error naming the bad case
        objs = [make_case(name) for name in names]
    except BenchError as exc:
        p.error(str(exc))
    exacts = [reference(case, case.T) if case.reference else None for case in objs]
    if args.cells_per_length is not None:  # refused before anything is printed
        for name, exact in zip(names, exacts, strict=True):
            if exact is not None and not isinstance(exact, CharacteristicsSolution):
                p.error(f"--cells-per-length: the reference of {name} is not a "
                        f"characteristics solution ({type(exact).__name__})")
    print(f"{'case':<18} {'points':>9} {'median ns/pt':>13} {'min ns/pt':>10}")
    for name, case, exact in zip(names, objs, exacts, strict=True):
        if exact is None:
            print(f"{name:<18} (no reference)")
            continue
        if args.cells_per_length is not None:
            exact = CharacteristicsSolution(
                L=exact.L, E=exact.E, rho=exact.rho, g=exact.g, far_end=exact.far_end,
                u_L=exact.u_L, u0=case.u0, v0=case.v0, T=exact.T,
                cells_per_length=args.cells_per_length)
        x = np.linspace(0.0, case.L, case.nx + 1)
        t = np.linspace(0.0, case.T, int(round(case.T / case.dt)) + 1)
        ec, step = metrics._blocks(case.nx)
        g = metrics._Geometry.of(x, 0, min(ec, case.nx))
        need_v = "v" in case.provides
        into = getattr(exact, "fields_into", None) is not None
        block = np.empty((3, min(step, t.size), *g.X.shape)) if into else None
        _once(exact, g, t, step, need_v, block)  # compiled, pages touched
        times = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            _once(exact, g, t, step, need_v, block)
            times.append(time.perf_counter() - start)
        n = t.size * g.X.size
        print(f"{name:<18} {n:>9} {statistics.median(times) * 1e9 / n:>13.2f} "
              f"{min(times) * 1e9 / n:>10.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
