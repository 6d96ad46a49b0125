"""Explicit schemes on sparse scenes: the declared step limit against the 1D formula, and
runs at 0.95 x and 1.05 x of it.

    python benchmarks/sparse_limits.py [--quick] [--coercivity]

For each (scene, nx, T, scheme): `stability_limit(BarScale(hmin, c_max))` (the 1D
element formula at the mesh's hmin, which the harness once used for every scene), the
declared limit on the body's problem, `stability_limit(problem)`
(`contact_bench.kernels.sparse_explicit.stable_dt`: ARPACK on the mesh),
their ratio, and the status and energy drift of runs at 0.95 x and 1.05 x the declared
limit (`contact_bench.harness.runner.run_one`). `--coercivity`: instead, the two
smallest generalized eigenvalues of Nitsche's (K', M) (theta = 1, no contact active) on
the disc at nx = 3 (dense `scipy.linalg.eigh`: 254 dofs at most).
"""

from __future__ import annotations

import argparse

import scipy.linalg as sla

from contact_bench.api.problem import BarScale
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
    parser.add_argument("--coercivity", action="store_true",
                        help="Nitsche's K' on the disc: its smallest eigenvalues")
    args = parser.parse_args(argv)
    if args.coercivity:
        for case in ("disc_drop", "disc_drop[degree=1]"):
            for gamma0 in (5.0, 50.0):
                scheme = make_scheme(f"nitsche[theta=1,gamma0={gamma0:g}]")
                p = make_case(case).sparse_problem(3, 1.0, scheme.mass_kind())
                K = (p.K + scheme.contact_law(p).K_extra).toarray()
                low = sla.eigh(K, p.M.toarray(), eigvals_only=True)[:2]
                print(f"{case:20s} gamma0 = {gamma0:4g}: smallest eigenvalues {low}")
        return 0
    runs = RUNS[:2] if args.quick else RUNS
    print(f"{'case':36s} {'scheme':30s} {'1D formula':>10s} {'declared':>10s} {'ratio':>6s} "
          f"{'0.95x':>9s} {'drift':>8s} {'1.05x':>9s} {'drift':>8s}")
    for case, nx, T, spec in runs:
        scheme = make_scheme(spec)
        p = make_case(case).sparse_problem(nx, 1.0, scheme.mass_kind())
        formula = scheme.stability_limit(BarScale(p.hmin, p.c_max))
        limit = scheme.stability_limit(p)
        rows = [run_one(case, spec, nx=nx, T=T, dt=f * limit, allow_unstable=True,
                        step_repeats=1).row for f in (0.95, 1.05)]
        print(f"{case:36s} {spec:30s} {formula:10.4g} {limit:10.4g} {formula / limit:6.3f} "
              + " ".join(f"{r['status']:>9s} {r['energy_drift_max']:8.3g}" for r in rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
