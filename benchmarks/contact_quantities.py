"""The first-contact quantities of the 1D references and their error columns on runs.

Prints three markdown tables (docs/exact-solutions.md quotes them):
1. every registered scene's reference first contact (`contact_bench.exact.contacts`) where
   `Case.reference_quantities` declares one, with the closed forms where the scene has
   them (the tests check these: tests/test_contact_quantities.py);
2. the err_contact_* and err_peak_force columns of the redistributed and standard
   schemes on each such scene (default nx and dt; T as given per scene below);
3. their convergence for redistributed as nx doubles and dt halves.

    python benchmarks/contact_quantities.py > results/contact_quantities.md
"""

from __future__ import annotations

import math

import pandas as pd

from contact_bench.api.plugin import CONTACT_QUANTITIES
from contact_bench.api.registry import cases, make_case
from contact_bench.exact.contacts import first_contact
from contact_bench.harness.runner import run_one

COLUMNS = [f"err_{q}" for q in CONTACT_QUANTITIES]
#: the runs' final times: past the first contact, short of the long scenes' T
RUN_T = {"clamped_bar": 3.0, "embedded_bar": 3.0, "long_time": 3.0, "dropped_bar": 2.5,
         "pulse": 1.0, "rough_data": 2.0}


def closed_forms(name: str) -> tuple[float, ...] | None:
    """(start, duration, peak force, impulse) in closed form, for the scenes that have
    one (tests/test_contact_quantities.py derives them)."""
    case = make_case(name)
    if name in ("clamped_bar", "long_time"):
        return 1.0, 1.0, 0.5, 0.5
    if name == "dropped_bar":
        t1 = math.sqrt(2 * case.height / case.g)
        c = case.wave_speed
        first = case.rho * c * case.g * t1
        peak = first + 2 * case.rho * case.g * case.L
        return t1, 2 * case.L / c, peak, 0.5 * (first + peak) * 2 * case.L / c
    if name in ("steel_bar", "fast_impact"):
        gap, v = float(case.u0([0.0])[0]), -float(case.v0([0.0])[0])
        return (gap / v, 2 * case.L / case.wave_speed, case.rho * case.wave_speed * v,
                2 * case.rho * case.L * v)
    return None


def main() -> None:
    names = [n for n in sorted(cases().names())  # the first contact of an exact stress
             if set(CONTACT_QUANTITIES) <= set(make_case(n).reference_quantities)
             and make_case(n).reference == "exact" and "stress" in make_case(n).provides]
    rows = []
    for name in names:
        case = make_case(name)
        fc = first_contact(case.exact(case.T).stress, case.T)
        closed = closed_forms(name)
        row = {"scene": name, "start": fc.start, "end": fc.end, "duration": fc.duration,
               "peak force": fc.peak_force, "impulse": fc.impulse}
        if closed is not None:
            row["closed form (start, duration, peak, impulse)"] = ", ".join(
                f"{v:.15g}" for v in closed)
        rows.append(row)
    print("## Reference first contacts (T: the scene's)\n")
    print(pd.DataFrame(rows).to_markdown(index=False, floatfmt=".15g"))
    rows = []
    for name in names:
        for scheme in ("redistributed", "standard"):
            r = run_one(name, scheme, T=RUN_T.get(name)).row
            rows.append({"scene": name, "scheme": scheme, "nx": r["nx"], "dt": r["dt"],
                         "T": r["T"], "stride": r["stride"], **{c: r[c] for c in COLUMNS}})
    print("\n## Error columns (default nx, dt, stride)\n")
    print(pd.DataFrame(rows).to_markdown(index=False, floatfmt=".3g"))
    rows = []
    for name, nx, dt in (("clamped_bar", 40, 0.01), ("dropped_bar", 50, 0.004),
                         ("fast_impact", 40, 0.01), ("pulse", 40, 0.01)):
        for k in (1, 2, 4, 8):
            r = run_one(name, "redistributed", nx=nx * k, dt=dt / k, T=RUN_T.get(name)).row
            rows.append({"scene": name, "nx": nx * k, "dt": dt / k,
                         **{c: r[c] for c in COLUMNS}})
    print("\n## Convergence, redistributed\n")
    print(pd.DataFrame(rows).to_markdown(index=False, floatfmt=".3g"))


if __name__ == "__main__":
    main()
