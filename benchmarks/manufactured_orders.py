"""Convergence orders of every scheme on the manufactured solution with a moving contact zone
(`manufactured[dim=2]` and `[dim=3]`, P1 or P2), space-time refinement at fixed CFL.

dt = CFL h / c_p (h = 1 / nx, c_p = sqrt(3)), T = 1; errors against the closed form
(`cases/manufactured.py`: err_u_l2_l2, err_gap, err_contact_force); pairwise orders
log(e_coarse / e_fine) / log(2) between successive grids (nx doubles). Every registered
scheme adds the time-dependent load; a scheme (a plugin's) whose stepper does not is
listed as not applicable, as is a pair the scene refuses (a lumped mass on P2). A scheme
whose declared stability limit on the coarsest grid is below `--cfl` runs at its own
fixed CFL, 0.9 of that limit rounded down to two digits (`scheme_cfl`, the `cfl` column):
the same CFL on every grid.

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
from contact_bench.harness.runner import declared_limit, problem_for, run_one

ERRORS = ("err_u_l2_l2", "err_gap", "err_contact_force")
C_P = math.sqrt(3.0)  # the P-wave speed (lambda = mu = rho = 1)
#: the fraction of a scheme's declared stability limit it runs at when that is below --cfl
SAFETY = 0.9


def scheme_cfl(case: str, name: str, nx: int, cfl: float) -> float:
    """The CFL `name` runs at: `cfl`, or SAFETY times its declared stability limit on the
    grid nx (in CFL units, limit * nx * c_p) rounded down to two digits, if lower."""
    c, s = make_case(case), make_scheme(name)
    limit = declared_limit(c, s, problem_for(c, s, nx))
    if limit is None:
        return cfl
    return min(cfl, math.floor(100.0 * SAFETY * limit * nx * C_P) / 100.0)


def measure(dim: int, nxs: list[int], cfl: float, names: list[str],
            degree: int = 1) -> pd.DataFrame:
    """One row per (scheme, nx): the errors and the pairwise orders of each."""
    case = f"manufactured[dim={dim}]" if degree == 1 else (
        f"manufactured[dim={dim},degree={degree}]")
    rows = []
    for name in names:
        scheme = make_scheme(name)
        reason = scheme.cannot_run(make_case(case)) or make_case(case).cannot_run(scheme)
        if reason:
            rows.append({"case": case, "scheme": name, "status": "not applicable"})
            continue
        own = scheme_cfl(case, name, nxs[0], cfl)
        for nx in nxs:
            dt = own / (nx * C_P)
            try:
                row = run_one(case, name, nx=nx, dt=dt).row
            except Exception as exc:  # recorded; the others go on
                row = {"status": f"error: {exc}"}
            rows.append({"case": case, "scheme": name, "nx": nx, "cfl": own, "dt": dt,
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
            f"Space-time refinement at fixed CFL {args.cfl:g} (dt = CFL h / c_p, T = 1; a "
            f"scheme whose stability limit is lower at {SAFETY:g} of it: the cfl column); "
            "errors against the closed form (cases/manufactured.py), pairwise orders "
            "between successive grids. Derivation: docs/manufactured.md.", "",
            df.to_markdown(index=False, floatfmt=".4g"), ""]
    write_text(Path(args.out), "\n".join(text))  # atomic; under results/: source recorded
    print("\n".join(text))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
