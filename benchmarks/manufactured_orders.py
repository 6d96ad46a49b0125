"""Convergence orders of every scheme on the manufactured solution with a moving contact zone
(`manufactured[dim=2]` and `[dim=3]`, P1 or P2), space-time refinement at fixed CFL.

dt = CFL h / c_p (h = 1 / nx, c_p = sqrt(3)), T = 1; errors against the closed form
(`cases/manufactured.py`: err_u_l2_l2, err_gap, err_contact_force); pairwise orders
log(e_coarse / e_fine) / log(2) between successive grids (nx doubles). Schemes whose
stepper does not add a time-dependent load are listed as not applicable.

    python benchmarks/manufactured_orders.py [--out results/manufactured_orders.md]
        [--nx2 4 8 16 32 64] [--nx3 4 8 16] [--cfl 0.5] [--degree 1] [--schemes a b ...]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.harness.io import write_text
from contact_bench.harness.runner import run_one

ERRORS = ("err_u_l2_l2", "err_gap", "err_contact_force")


def measure(dim: int, nxs: list[int], cfl: float, names: list[str],
            degree: int = 1) -> pd.DataFrame:
    """One row per (scheme, nx): the errors and the pairwise orders of each."""
    case = f"manufactured[dim={dim}]" if degree == 1 else (
        f"manufactured[dim={dim},degree={degree}]")
    c_p = math.sqrt(3.0)
    rows = []
    for name in names:
        scheme = make_scheme(name)
        reason = scheme.cannot_run(make_case(case)) or make_case(case).cannot_run(scheme)
        if reason:
            rows.append({"case": case, "scheme": name, "status": "not applicable"})
            continue
        for nx in nxs:
            try:
                row = run_one(case, name, nx=nx, dt=cfl / (nx * c_p)).row
            except Exception as exc:  # recorded; the others go on
                row = {"status": f"error: {exc}"}
            rows.append({"case": case, "scheme": name, "nx": nx, "dt": cfl / (nx * c_p),
                         "status": row.get("status"),
                         **{e: row.get(e) for e in ERRORS}})
    df = pd.DataFrame(rows)
    for e in ERRORS:
        if e not in df:
            df[e] = np.nan
        order = np.full(len(df), np.nan)
        for i in range(1, len(df)):
            same = df["scheme"].iat[i] == df["scheme"].iat[i - 1]
            a, b = df[e].iat[i - 1], df[e].iat[i]
            if same and a and b and np.isfinite(a) and np.isfinite(b):
                order[i] = math.log(float(a) / float(b)) / math.log(
                    float(df["nx"].iat[i]) / float(df["nx"].iat[i - 1]))
        df["order_" + e[4:]] = order
    return df


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="results/manufactured_orders.md")
    ap.add_argument("--nx2", type=int, nargs="+", default=[4, 8, 16, 32, 64])
    ap.add_argument("--nx3", type=int, nargs="+", default=[4, 8, 16])
    ap.add_argument("--cfl", type=float, default=0.5)
    ap.add_argument("--degree", type=int, choices=(1, 2), default=1)
    ap.add_argument("--schemes", nargs="+", default=None)
    args = ap.parse_args(argv)
    names = args.schemes or sorted(schemes().names())
    parts = [measure(2, args.nx2, args.cfl, names, args.degree),
             measure(3, args.nx3, args.cfl, names, args.degree)]
    df = pd.concat(parts, ignore_index=True)
    command = "python benchmarks/manufactured_orders.py " + " ".join(argv or sys.argv[1:])
    text = [f"# Orders on the manufactured solution (moving contact zone), P{args.degree}", "",
            f"Command: `{command.strip()}`", "",
            f"Space-time refinement at fixed CFL {args.cfl:g} (dt = CFL h / c_p, T = 1); "
            "errors against the closed form (cases/manufactured.py), pairwise orders "
            "between successive grids. Derivation: docs/manufactured.md.", "",
            df.to_markdown(index=False, floatfmt=".4g"), ""]
    write_text(Path(args.out), "\n".join(text))  # atomic; under results/: source recorded
    print("\n".join(text))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
