"""Start-up cost: the first kernel call of a scheme in a new Python process.

    python benchmarks/startup.py [scheme ...]     # default: every registered scheme

Each scheme is run twice, each time in a fresh process (a short clamped-bar run,
nx = 100): the first process compiles the kernel if numba's cache does not hold it yet,
the second loads it from the cache. Printed: seconds of the first `integrate` call
in each process (imports and assembly excluded).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_CHILD = """
import sys, time
sys.path.insert(0, {root!r})
from bench.fem import mesh_nodes
from bench.problem import discretise
from bench.registry import make_case, make_scheme
case, scheme = make_case("clamped_bar"), make_scheme({spec!r})
semi = discretise(case, mesh_nodes(case.L, 100), scheme.mass_kind())
dt = 0.5 * semi.hmin / semi.c_max
limit = scheme.stability_limit(semi.hmin, semi.c_max)
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
    sys.path.insert(0, str(ROOT))
    from bench.registry import schemes

    specs = argv or schemes().names()
    print(f"{'scheme':<24} {'first process s':>16} {'cached s':>10}")
    for spec in specs:
        print(f"{spec:<24} {first_call(spec):>16.3f} {first_call(spec):>10.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
