"""Per run of a table: stepping time (wall_s) against error-norm time (Run.norm_s).

    python benchmarks/norm_cost.py                 # the default run (both seed scenes)
    python benchmarks/norm_cost.py clamped_bar --nx 80 --dt 0.002

Every registered scheme, the case's default stride. The first scheme on a (case, mesh,
sample times) also builds the quadrature and sums the exact norms, which the next ones
reuse (bench.metrics; the reference's values too when it is slow to evaluate), so its
norm time is the larger one. JIT compilation is outside both times. See also
benchmarks/test_norms.py (pytest-benchmark).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench import metrics  # noqa: E402
from bench.harness import Run, run_table  # noqa: E402
from bench.registry import cases, schemes  # noqa: E402


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("case", nargs="*", help="cases (default: those of the default run)")
    p.add_argument("--nx", type=int, default=None)
    p.add_argument("--dt", type=float, default=None)
    args = p.parse_args(argv)
    names = args.case or [n for n, c in cases().plugins.items() if c.in_default_run]
    metrics.clear_cache()
    runs: list[Run] = []
    run_table(names, schemes().names(), [args.nx], [args.dt], keep=runs, keep_samples=False)
    w = max([len("case"), *(len(str(r.row["case"])) for r in runs)])
    print(f"{'case':<{w}} {'scheme':<16} {'nx':>5} {'dt':>9} {'samples':>7} {'wall_s ms':>10} "
          f"{'norm_s ms':>10} {'ratio':>7}")
    total_w = total_n = 0.0
    for r in runs:
        w, n = r.row["wall_s"], r.norm_s
        if w is None or n is None:
            continue
        total_w, total_n = total_w + w, total_n + n
        print(f"{r.row['case']:<{w}} {r.row['scheme']:<16} {r.row['nx']:>5} {r.row['dt']:>9.3g} "
              f"{r.trajectory.t.size:>7} {w * 1e3:>10.2f} {n * 1e3:>10.2f} {n / w:>7.2f}")
    print(f"total: wall_s {total_w:.3f} s, norm_s {total_n:.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
