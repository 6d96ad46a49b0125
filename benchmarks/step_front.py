"""Preview of the work-precision Pareto front on `step_s`, from a saved study table.

    python benchmarks/step_front.py [results/study/sweep.csv] [--repeats 3]

For every timed ok run of the table's `refine` group it measures `step_s` with the code
of this tree (`contact_bench.sweeps.sweep.time_integrate(stepping=True)`: stride = steps,
a warm-up call, the minimum of `repeats`) and prints, per scene, each run's error, the
table's `time_s` (recording included, as published), the new `step_s`, and whether the
run is on the Pareto front over each. The errors are the table's: nothing else is rerun,
and the table is not written. What the lead's regenerated study will show, measured
ahead on a shared machine (the ratios, not the absolute times, carry over).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from contact_bench.sweeps import analysis  # noqa: E402
from contact_bench.sweeps.sweep import load_table, time_integrate  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("table", nargs="?", default="results/study/sweep.csv")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--error", default="err_u_linf_l2")
    args = ap.parse_args(argv)
    df = load_table(args.table)
    runs = analysis.select(df, "refine")
    runs = runs[(runs["status"] == "ok") & np.isfinite(runs["time_s"].astype(float))
                & np.isfinite(runs[args.error].astype(float))].copy()
    runs["step_s"] = [time_integrate(row, args.repeats, stepping=True)[0]
                      for row in runs.to_dict("records")]
    print(f"table {args.table}; step_s: min of {args.repeats} after a warm-up, this tree")
    for case, g in runs.groupby("case", sort=False):
        g = g.copy()
        g["front_time_s"] = analysis.pareto_mask(g["time_s"].to_numpy(), g[args.error].to_numpy())
        g["front_step_s"] = analysis.pareto_mask(g["step_s"].to_numpy(), g[args.error].to_numpy())
        print(f"\n{case}\n")
        print(f"| scheme | nx | {args.error} | time_s [ms] | step_s [ms] | "
              "ns/dof-step (step_s) | front (time_s) | front (step_s) |")
        print("|---|---|---|---|---|---|---|---|")
        for r in g.sort_values(["scheme", "nx"]).itertuples():
            ns = r.step_s / (int(r.nx) * int(r.steps)) * 1e9
            print(f"| {r.scheme} | {int(r.nx)} | {getattr(r, args.error):.4g} | "
                  f"{r.time_s * 1e3:.3g} | {r.step_s * 1e3:.3g} | {ns:.3g} | "
                  f"{'x' if r.front_time_s else ''} | {'x' if r.front_step_s else ''} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
