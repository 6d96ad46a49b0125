"""Stepping cost per dof-step of a few schemes on the clamped bar, for a quick before/after
comparison of two checkouts (the pytest-benchmark suite is the tracked measurement).

Each (scheme, n): the scheme's stepper prepared once (`scheme.prepare`, outside the
timing), one warm-up call (JIT compilation), then the minimum of 5 calls of
`stepper.run` with samples at the first and last step only, at CFL 0.5.

    python benchmarks/kernel_cost.py redistributed standard restitution nitsche
"""

from __future__ import annotations

import sys
import time

from contact_bench.api import as_problem
from contact_bench.api.fem import mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case, make_scheme

SIZES = ((1000, 200_000), (100_000, 4000))  # (n, steps): 2e8 and 4e8 dof-steps a call


def main(specs: list[str]) -> None:
    case = make_case("clamped_bar")
    for spec in specs:
        scheme = make_scheme(spec)
        for n, steps in SIZES:
            semi = discretise(case, mesh_nodes(1.0, n), scheme.mass_kind())
            dt = 0.5 * semi.hmin / semi.c_max
            stepper = scheme.prepare(as_problem(semi, scheme.mass_kind()), dt)
            stepper.run(steps, steps)
            best = float("inf")
            for _ in range(5):
                start = time.perf_counter()
                stepper.run(steps, steps)
                best = min(best, time.perf_counter() - start)
            print(f"{spec:14s} n={n:6d} {best / (n * steps) * 1e9:6.3f} ns/dof-step")


if __name__ == "__main__":
    main(sys.argv[1:] or ["redistributed", "standard", "restitution", "nitsche"])
