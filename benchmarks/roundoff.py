"""How much the errors of a run depend on round-off: the numba kernel, the plain scipy
reference (bench/reference.py, the same algorithm with other roundings) and the kernel
from U0 scaled by 1 +- 1e-15, on the default run's scenes.

    python benchmarks/roundoff.py [scheme ...]     # default: standard redistributed

A well-posed semi-discrete problem (the massless contact node) gives the same published
digits whatever the rounding; the standard scheme's chattering contact node amplifies
round-off, so its errors are reproducible in size only.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from contact_bench.api.registry import cases, make_case, make_scheme  # noqa: E402
from contact_bench.harness.metrics import error_metrics  # noqa: E402
from contact_bench.harness.runner import reference, run_one  # noqa: E402
from contact_bench.harness.scipy_reference import reference_for  # noqa: E402

COLUMNS = ("err_u_linf_l2", "err_v_linf_l2", "err_stress_l2")


def main(argv: list[str]) -> int:
    specs = argv or ["standard", "redistributed"]
    names = [n for n, c in cases().plugins.items() if c.in_default_run]
    print(f"{'case':<12} {'scheme':<14} {'run':<22} " + " ".join(f"{c:>14}" for c in COLUMNS))
    for name in names:
        case = make_case(name)
        for spec in specs:
            run = run_one(case, spec)
            semi, row = run.semi, run.row
            scheme = make_scheme(spec)
            dt, nsteps, stride = float(row["dt"]), int(row["steps"]), int(row["stride"])
            exact = reference(case, row["T"])
            runs = {"kernel": run.trajectory,
                    "scipy reference": reference_for(scheme, semi, dt, nsteps, stride)}
            for f in (1 + 1e-15, 1 - 1e-15):
                start = dataclasses.replace(semi, U0=semi.U0 * f)
                runs[f"kernel, U0 x (1{f - 1:+.0e})"] = scheme.integrate(start, dt, nsteps, stride)
            for label, traj in runs.items():
                m = error_metrics(semi, traj, exact, case.provides)
                print(f"{name:<12} {spec:<14} {label:<22} "
                      + " ".join(f"{m[c]:>14.6g}" for c in COLUMNS))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
