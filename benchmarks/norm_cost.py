"""Per run of a table: stepping time (wall_s) against error-norm time (Run.norm_s).

    python benchmarks/norm_cost.py                 # the default run (the paper's two scenes)
    python benchmarks/norm_cost.py clamped_bar --nx 80 --dt 0.002 --repeats 3
    python benchmarks/norm_cost.py --alone         # each scheme in a table of its own
    python benchmarks/norm_cost.py --cli-memory    # glibc set up as `contact-bench` does

Every registered scheme, the case's default stride; the table is run `--repeats` times
(5) in the same process and each row reports the medians of its times (the issue's
targets are on medians: a 2 ms time on this VM moves by 20-30% from table to table),
and its worst table. Between tables the metrics cache is cleared: every table's first
scheme on a grid pays its full norm cost again. The first scheme on a (case, mesh,
sample times) also builds the quadrature and sums the exact norms, which the next ones
reuse (contact_bench.harness.metrics; the reference's values too when it is slow to evaluate), so
its
norm time is the larger one. JIT compilation is outside both times. See also
benchmarks/test_norms.py (pytest-benchmark).

`--alone`: every scheme runs in a table of its own (what `contact-bench run --scheme S`
does), so each is the first on its grid and pays the quadrature and the exact norms.
`--cli-memory`: glibc is set up first as the `contact-bench` command sets it up
(`contact_bench.harness.environment.return_freed_memory`: mmap threshold 4 MB, trim threshold 64
MB),
so the times are those of the command's own tables: a run's sample buffers (1.5-2.6 MB
per field on the default scenes) come back from the heap already touched, as in a plain
process.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from contact_bench.api.registry import cases, schemes  # noqa: E402
from contact_bench.core.errors import BenchError  # noqa: E402
from contact_bench.harness import metrics  # noqa: E402
from contact_bench.harness.environment import return_freed_memory  # noqa: E402
from contact_bench.harness.runner import Run, run_table  # noqa: E402


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("case", nargs="*", help="cases (default: those of the default run)")
    p.add_argument("--nx", type=int, default=None)
    p.add_argument("--dt", type=float, default=None)
    p.add_argument("--repeats", type=int, default=5,
                   help="tables run one after the other (default 5): medians per row")
    p.add_argument("--alone", action="store_true",
                   help="each scheme in a table of its own (the first on its grid)")
    p.add_argument("--cli-memory", action="store_true",
                   help="fix glibc's mmap threshold first, as the contact-bench command does")
    args = p.parse_args(argv)
    if args.repeats < 1:
        p.error(f"--repeats must be >= 1, got {args.repeats}")
    if args.cli_memory and not return_freed_memory():
        p.error("--cli-memory needs glibc (mallopt), not found")
    names = args.case or [n for n, c in cases().plugins.items() if c.in_default_run]
    tables = ([[s] for s in schemes().names()] if args.alone else [schemes().names()])
    rows: dict[tuple, dict] = {}  # (case, scheme, nx, dt): samples, wall_s and norm_s lists
    for _ in range(args.repeats):
        runs: list[Run] = []
        for table in tables:
            metrics.clear_cache()  # each table's first scheme on a grid pays again
            try:  # bad cases, nx or dt: the harness's one-line error, before any run
                run_table(names, table, [args.nx], [args.dt], keep=runs, keep_samples=False)
            except BenchError as exc:
                p.error(str(exc))
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
    for (case, scheme, nx, dt), got in sorted(rows.items(), key=lambda kv: kv[0][:2]):
        w, n = statistics.median(got["wall"]), statistics.median(got["norm"])
        worst = max(b / a for a, b in zip(got["wall"], got["norm"], strict=True))
        total_w, total_n = total_w + w, total_n + n
        print(f"{case:<{cw}} {scheme:<16} {nx:>5} {dt:>9.3g} {got['samples']:>7} "
              f"{w * 1e3:>10.2f} {n * 1e3:>10.2f} {n / w:>7.2f} {worst:>7.2f}")
    mode = ("each scheme alone" if args.alone else "all schemes in one table") + (
        ", mmap threshold fixed as by contact-bench" if args.cli_memory else "")
    print(f"{mode}; medians of {args.repeats} repeats; ratio = median norm_s / median "
          f"wall_s, worst = the largest norm_s / wall_s of one repeat; total: wall_s "
          f"{total_w:.3f} s, norm_s {total_n:.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
