"""The gross-sliding ratio |J_t| / J_n of `oblique_impact` from the impulses the kernel
records (the normal `extra["impulse"]` and the tangential `extra["tangential_impulse"]`,
per tangent; no difference of large momenta), beside the same ratio from the body's
momentum change, and the tangential impulse balance (`tangential_impulse_residual`).
Each frictional scheme (`Traits.friction`) on the given base at each incidence, mu 0.3,
dt 0.05. Printed as a markdown table (docs/oblique-impact.md quotes it).

    python benchmarks/oblique_ratio.py
    python benchmarks/oblique_ratio.py --base "sphere_drop[degree=1,lift=0.05,ball=lattice]" \
        --nx 2 --T 45 --incidence 89.99,80
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.core.errors import BenchError
from contact_bench.harness import run_one
from contact_bench.harness.impacts import tangential_impulse_residual


def row(base: str, scheme: str, incidence: float, nx: int, T: float, mu: float) -> str:
    spec = f"oblique_impact[of={base},mu={mu},incidence={incidence}]"
    case = make_case(spec)
    reason = make_scheme(scheme).cannot_run(case)
    if reason:
        return f"| {scheme} | {incidence} | refused: {reason} | | | |"
    try:
        run = run_one(spec, scheme, nx=nx, T=T, dt=0.05)
    except BenchError as e:  # a mass the scene refuses on this mesh
        return f"| {scheme} | {incidence} | refused: {e} | | | |"
    if run.trajectory is None or run.row["status"] != "ok":
        return f"| {scheme} | {incidence} | {run.row['status']}: {run.row.get('notes')} | | | |"
    p = case.sparse_problem(nx, 1.0, make_scheme(scheme).mass_kind())
    extra = run.trajectory.extra
    J_t = extra["tangential_impulse"][-1] - extra["tangential_impulse"][0]
    J_n = extra["impulse"][-1] - extra["impulse"][0]
    recorded = float(np.linalg.norm(J_t) / J_n)
    P = case.rigid_motion(p, run.trajectory, nx)["P"]
    dP = P[-1] - P[0]
    v = case.vertical
    momenta = float(np.linalg.norm(np.delete(dP, v)) / dP[v])
    res = tangential_impulse_residual(p, run.trajectory)
    return (f"| {scheme} | {incidence} | {(mu - recorded) / mu:.3e} | "
            f"{(mu - momenta) / mu:.3e} | {res:.1e} | {run.row['impulse_residual']:.1e} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="sphere_drop[degree=1,lift=0.05,ball=lattice]")
    ap.add_argument("--nx", type=int, default=2)
    ap.add_argument("--T", type=float, default=45.0)
    ap.add_argument("--mu", type=float, default=0.3)
    ap.add_argument("--incidence", default="89.99,80")
    ap.add_argument("--schemes", default=None, help="comma-separated (default: frictional)")
    args = ap.parse_args()
    warnings.filterwarnings("ignore")
    names = (args.schemes.split(",") if args.schemes else
             sorted(n for n in schemes().names() if make_scheme(n).traits().friction))
    print(f"{args.base}, nx {args.nx}, T {args.T}, dt 0.05, mu {args.mu}\n")
    print("| scheme | incidence | (mu - |J_t|/J_n) / mu, recorded | the same from momenta | "
          "tangential balance | impulse_residual |")
    print("|---|---:|---:|---:|---:|---:|")
    for scheme in names:
        for inc in args.incidence.split(","):
            print(row(args.base, scheme, float(inc), args.nx, args.T, args.mu), flush=True)


if __name__ == "__main__":
    main()
