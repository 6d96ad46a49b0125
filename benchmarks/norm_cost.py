"""Per run of a table: stepping time (wall_s) against error-norm time (Run.norm_s).

    python benchmarks/norm_cost.py                 # the default run (both seed scenes)
    python benchmarks/norm_cost.py clamped_bar --nx 80 --dt 0.002 --repeats 3

Every registered scheme, the case's default stride; the table is run `--repeats` times
(5) in the same process and each row reports the medians of its times (the issue's
targets are on medians: a 2 ms time on this VM moves by 20-30% from table to table),
and its worst table. Between tables the metrics cache is cleared: every table's first
scheme on a grid pays its full norm cost again. The first scheme on a (case, mesh,
sample times) also builds the quadrature and sums the exact norms, which the next ones
reuse (bench.metrics; the reference's values too when it is slow to evaluate), so its
norm time is the larger one. JIT compilation is outside both times. See also
benchmarks/test_norms.py (pytest-benchmark).
"""

from __future__ import annotations

import argparse
import statistics
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
    p.add_argument("--repeats", type=int, default=5,
                   help="tables run one after the other (default 5): medians per row")
    args = p.parse_args(argv)
    if args.repeats < 1:
        p.error(f"--repeats must be >= 1, got {args.repeats}")
    names = args.case or [n for n, c in cases().plugins.items() if c.in_default_run]
    rows: dict[tuple, dict] = {}  # (case, scheme, nx, dt): samples, wall_s and norm_s lists
    for _ in range(args.repeats):
        metrics.clear_cache()  # each table's first scheme on a grid pays again
        runs: list[Run] = []
        run_table(names, schemes().names(), [args.nx], [args.dt], keep=runs,
                  keep_samples=False)
        for r in runs:
            if r.row["wall_s"] is None or r.norm_s is None:
                continue
            key = (r.row["case"], r.row["scheme"], r.row["nx"], r.row["dt"])
            got = rows.setdefault(key, {"samples": r.trajectory.t.size, "wall": [], "norm": []})
            got["wall"].append(r.row["wall_s"])
            got["norm"].append(r.norm_s)
    cw = max([len("case"), *(len(str(k[0])) for k in rows)])
    print(f"{'case':<{cw}} {'scheme':<16} {'nx':>5} {'dt':>9} {'samples':>7} {'wall_s ms':>10} "
          f"{'norm_s ms':>10} {'ratio':>7} {'worst':>7}")
    total_w = total_n = 0.0
    for (case, scheme, nx, dt), got in rows.items():
        w, n = statistics.median(got["wall"]), statistics.median(got["norm"])
        worst = max(b / a for a, b in zip(got["wall"], got["norm"], strict=True))
        total_w, total_n = total_w + w, total_n + n
        print(f"{case:<{cw}} {scheme:<16} {nx:>5} {dt:>9.3g} {got['samples']:>7} "
              f"{w * 1e3:>10.2f} {n * 1e3:>10.2f} {n / w:>7.2f} {worst:>7.2f}")
    print(f"medians of {args.repeats} tables; ratio = median norm_s / median wall_s, worst = "
          f"the largest norm_s / wall_s of one table; total: wall_s {total_w:.3f} s, norm_s "
          f"{total_n:.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
