"""What the energy costs a run: `scheme.integrate` at stride 100 (one energy per 100
steps) and at stride = nsteps (two), in ns per dof-step, median of rounds.

    python benchmarks/energy_cost.py [--n 1000 100000] [--rounds 7] [scheme ...]

Run it in two checkouts to compare an energy change (the kernels compile energy_of in).
"""

from __future__ import annotations

import argparse
import statistics
import time

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case, make_scheme

SPECS = ["redistributed", "standard", "restitution", "taylor_flanagan", "ode_verlet",
         "penalty"]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[1_000, 100_000])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--work", type=float, default=2e7, help="dof-steps per round")
    ap.add_argument("schemes", nargs="*")
    args = ap.parse_args(argv)
    print(f"{'scheme':<16} {'n':>7} {'nsteps':>7} {'stride 100':>11} {'stride nsteps':>14}"
          "  (ns per dof-step, median)")
    for n in args.n:
        for spec in args.schemes or SPECS:
            scheme = make_scheme(spec)
            case = make_case("clamped_bar")
            semi = discretise(case, mesh_nodes(1.0, n), scheme.mass_kind())
            dt = 0.5 * semi.hmin / semi.c_max
            limit = scheme.stability_limit(semi.hmin, semi.c_max)
            if limit is not None:
                dt = min(dt, 0.9 * limit)
            nsteps = max(200, int(args.work / semi.nfree) // 100 * 100)
            scheme.warm_up(semi)
            out = []
            for stride in (100, nsteps):
                scheme.integrate(semi, dt, nsteps, stride)
                times = []
                for _ in range(args.rounds):
                    start = time.perf_counter()
                    scheme.integrate(semi, dt, nsteps, stride)
                    times.append(time.perf_counter() - start)
                out.append(statistics.median(times) / (semi.nfree * nsteps) * 1e9)
            print(f"{spec:<16} {n:>7} {nsteps:>7} {out[0]:>11.3f} {out[1]:>14.3f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
