"""Start-up cost: the first kernel call of a scheme in a new Python process.

    python benchmarks/startup.py [--repeat N] [scheme ...]   # default: every scheme, N = 5

Each scheme is run in 1 + N fresh processes (a short clamped-bar run, nx = 100): the
first process compiles the kernel if numba's cache does not hold it yet, the next N
load it from the cache. Printed: seconds of the first `integrate` call in a process
(imports and assembly excluded): the first process's, then the median and the largest
of the N cached ones (one process varies by about +-0.1 s on a busy VM: the issue's
targets are medians).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_CHILD = """
import sys, time
sys.path.insert(0, {root!r})
from contact_bench.api.fem import mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case, make_scheme
case, scheme = make_case("clamped_bar"), make_scheme({spec!r})
semi = discretise(case, mesh_nodes(case.L, 100), scheme.mass_kind())
dt = 0.5 * semi.hmin / semi.c_max
limit = scheme.stability_limit(semi)
dt = dt if limit is None else min(dt, 0.9 * limit)
start = time.perf_counter()
scheme.integrate(semi, dt, 10, 10)
print(time.perf_counter() - start)
"""


def first_call(spec: str) -> float:
    code = _CHILD.format(root=str(ROOT), spec=spec)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    return float(out.stdout.strip().splitlines()[-1])


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scheme", nargs="*", help="scheme specs (default: every registered one)")
    p.add_argument("--repeat", type=int, default=5, help="cached processes per scheme")
    args = p.parse_args(argv)
    if args.repeat < 1:
        p.error(f"--repeat must be >= 1, got {args.repeat}")
    sys.path.insert(0, str(ROOT))
    from contact_bench.api.registry import make_scheme, schemes
    from contact_bench.core.errors import BenchError

    specs = args.scheme or schemes().names()
    try:  # the registry's own check, before any process is started
        for spec in specs:
            make_scheme(spec)
    except BenchError as exc:
        p.error(str(exc))
    print(f"{'scheme':<24} {'first process s':>16} {'cached median s':>16} {'cached max s':>13}")
    for spec in specs:
        first = first_call(spec)
        cached = [first_call(spec) for _ in range(args.repeat)]
        print(f"{spec:<24} {first:>16.3f} {statistics.median(cached):>16.3f} "
              f"{max(cached):>13.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
