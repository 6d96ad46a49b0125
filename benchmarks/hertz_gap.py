"""The hertz_sphere scene against Hertz's contact time and peak force: the relative gaps
at two impact speeds and two meshes (the finite-element answer approaches Hertz's
quasi-static law as v / c_p and h shrink).

    python benchmarks/hertz_gap.py [--scheme redistributed] [--nx 8 16] [--v 0.01 0.001]

Contact time: from the first step with a contact force to the first step after it
without (the row's first_contact_start and first_contact_end, minus one step: the
impact is at t = 0); peak force: the largest total contact force of a step.
"""

from __future__ import annotations

import argparse

from contact_bench.api.registry import make_case
from contact_bench.harness.runner import run_one


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scheme", default="redistributed")
    ap.add_argument("--nx", type=int, nargs="+", default=[8, 16])
    ap.add_argument("--v", type=float, nargs="+", default=[0.01, 0.001])
    args = ap.parse_args(argv)
    print("| v | nx | dofs | T_c Hertz | T_c FE | gap | F_max Hertz | F_max FE | gap |"
          " energy drift | switches | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for v in args.v:
        for nx in args.nx:
            spec = f"hertz_sphere[v={v!r}]"
            h = make_case(spec).hertz()
            run = run_one(spec, args.scheme, nx=nx)
            row = run.row
            tc = row["first_contact_end"] - row["first_contact_start"] + row["dt"]
            fm = row["peak_contact_force"]
            print(f"| {v:g} | {nx} | {run.semi.nfree} | {h.contact_time:.4g} | {tc:.4g} | "
                  f"{tc / h.contact_time - 1:+.1%} | {h.peak_force:.4g} | {fm:.4g} | "
                  f"{fm / h.peak_force - 1:+.1%} | {row['energy_drift_max']:.2g} | "
                  f"{row['chatter']:.0f} | {row['wall_s']:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
