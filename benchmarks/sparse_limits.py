"""Explicit schemes on sparse scenes: the declared step limit against the 1D formula, and
runs at 0.95 x and 1.05 x of it.

    python benchmarks/sparse_limits.py [--quick]

For each (scene, nx, T, scheme): `stability_limit(hmin, c_max)` (the 1D element formula
the harness used for every form before `Scheme.sparse_stability_limit`), the declared
sparse limit (`contact_bench.kernels.sparse_explicit.stable_dt`: ARPACK on the mesh),
their ratio, and the status and energy drift of runs at 0.95 x and 1.05 x the declared
limit (`contact_bench.harness.runner.run_one`).
"""

from __future__ import annotations

import argparse

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.harness.runner import run_one

RUNS = [("embedded_bar[of=clamped_bar,dim=2]", 16, 10.0, s) for s in (
    "penalty[beta=0]", "penalty[beta=0,mass=lumped]", "penalty[beta=0,mass=getfem]",
    "nitsche[beta=0]", "nitsche[beta=0,theta=-1]", "taylor_flanagan")]
RUNS += [("disc_drop[degree=1]", 3, 40.0, s) for s in (
    "penalty[beta=0]", "penalty[beta=0,mass=lumped]", "penalty[beta=0,mass=getfem]",
    "nitsche[beta=0]", "nitsche[beta=0,theta=-1]", "taylor_flanagan",
    "taylor_flanagan[mass=lumped]")]
RUNS += [("disc_drop", 3, 40.0, s) for s in ("penalty[beta=0]", "nitsche[beta=0]",
                                              "taylor_flanagan")]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the first two rows only")
    args = parser.parse_args(argv)
    runs = RUNS[:2] if args.quick else RUNS
    print(f"{'case':36s} {'scheme':30s} {'1D formula':>10s} {'declared':>10s} {'ratio':>6s} "
          f"{'0.95x':>9s} {'drift':>8s} {'1.05x':>9s} {'drift':>8s}")
    for case, nx, T, spec in runs:
        scheme = make_scheme(spec)
        p = make_case(case).sparse_problem(nx, 1.0, scheme.mass_kind())
        formula = scheme.stability_limit(p.hmin, p.c_max)
        limit = scheme.sparse_stability_limit(p)
        rows = [run_one(case, spec, nx=nx, T=T, dt=f * limit, allow_unstable=True,
                        step_repeats=1).row for f in (0.95, 1.05)]
        print(f"{case:36s} {spec:30s} {formula:10.4g} {limit:10.4g} {formula / limit:6.3f} "
              + " ".join(f"{r['status']:>9s} {r['energy_drift_max']:8.3g}" for r in rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
