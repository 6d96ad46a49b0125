"""The `sweep`, `report` and `study` subcommands of `contact-bench` (hooked in
contact_bench.cli.main)."""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from contact_bench.cli.checks import dask_address, numbers, out_folder, positive_int
from contact_bench.core.errors import BenchError
from contact_bench.harness.environment import provenance

COMMANDS = ("sweep", "report", "study")


def _runner_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("-j", "--jobs", type=int, default=os.cpu_count() or 1,
                   help="local worker processes (default: the number of CPUs)")
    p.add_argument("--dask", metavar="ADDRESS",
                   help="run on Dask distributed: a scheduler address, or 'local' for a "
                        "LocalCluster of -j workers")
    p.add_argument("--cache", metavar="DIR",
                   help="run cache (default: $CONTACT_BENCH_CACHE or ~/.cache/contact-bench)")
    p.add_argument("--no-cache", action="store_true", help="recompute every run")
    p.add_argument("--repeats", type=int, default=None,
                   help="timed repeats per run in the serial timing pass (0: no timing; "
                        "default: sweep 5, study 3, study --quick 2)")
    p.add_argument("--retime", action="store_true",
                   help="measure the timings again, even those in the cache (the runs and "
                        "their errors still come from the cache)")
    p.add_argument("--quiet", action="store_true", help="no progress bar (CI)")
    p.add_argument("--traceback", action="store_true",
                   help="print the full traceback of every 'error' row on stderr")
    p.set_defaults(default_repeats=5)  # timed repeats without --repeats


def _figure_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--fig-format", default="png", metavar="FORMATS",
                   help="figure formats, comma-separated among png, pdf, svg (PNG at 300 dpi; "
                        "default png)")
    p.add_argument("--style", metavar="FILE_OR_NAME",
                   help="matplotlib style for the figures: a name (e.g. seaborn-v0_8-paper) "
                        "or a .mplstyle file")
    p.add_argument("--energy-runs", choices=["finest", "all"], default="finest",
                   help="energy figure: the finest run per scheme (default) or every run")


def add_commands(sub: argparse._SubParsersAction) -> None:
    """Add the sweep, report and study subparsers."""
    s = sub.add_parser("sweep", help="grid of cases x scheme specs x nx x dt (or CFL), one "
                                     "tidy table, cached and parallel")
    s.add_argument("--case", action="append", help="case spec (repeatable; lists expand)")
    s.add_argument("--scheme", action="append",
                   help="scheme spec, lists expand: 'penalty[gamma_p=[1,10,100]]' (repeatable)")
    s.add_argument("--nx", action="append", help="elements, repeatable or comma-separated")
    s.add_argument("--dt", action="append", help="time steps, repeatable or comma-separated")
    s.add_argument("--cfl", action="append",
                   help="CFL = c dt / h at each nx instead of --dt (repeatable or commas)")
    s.add_argument("--T", help="final time (default: the case's)")
    s.add_argument("--stride", default="1", help="keep a sample every K steps")
    s.add_argument("--max-samples", type=int,
                   help="raise the stride so that about this many samples are kept")
    s.add_argument("--grading", type=float, default=1.0, help="mesh grading towards x = 0")
    s.add_argument("--out", default="results/sweep",
                   help="folder for sweep.csv (and sweep.parquet) (default: results/sweep)")
    _runner_options(s)

    r = sub.add_parser("report", help="tables, figures and an HTML page from a saved table")
    r.add_argument("table", help="a sweep table (.csv or .parquet); a time_order.csv "
                                 "beside it (written by study) is shown too")
    r.add_argument("--out", required=True, help="folder for the report")
    r.add_argument("--error", default="err_u_linf_l2", help="error column for the analysis")
    _figure_options(r)

    st = sub.add_parser("study", help="the published default study: sweep + report")
    st.add_argument("--out", default="results/study", help="folder (default: results/study)")
    st.add_argument("--quick", action="store_true", help="tiny grids (smoke test)")
    st.add_argument("--scheme", action="append",
                    help="scheme specs (default: every registered scheme)")
    st.add_argument("--case", action="append", help="scenes (default: the seed scenes)")
    st.add_argument("--error", default="err_u_linf_l2", help="error column for the analysis")
    st.add_argument("--part", choices=("all", "main", "friction"), default="all",
                    help="all (default); main: the study without its friction part; "
                         "friction: only the friction part (friction_* files, "
                         "friction_sweep.csv, friction.html; docs/study.md)")
    _figure_options(st)
    _runner_options(st)
    # the study times each of its ~480 work-precision runs up to 3 times a mode
    # (docs/study.md: where its time goes)
    st.set_defaults(default_repeats=3)


def _cache(args: argparse.Namespace):  # noqa: ANN202
    """The run cache, checked writable before any run (a bad --cache fails first)."""
    from contact_bench.sweeps.cache import Cache, default_cache_dir

    if args.no_cache:
        return Cache(None)
    if args.cache is not None and not args.cache.strip():
        raise BenchError("--cache is empty; give a folder (or --no-cache)")
    cache = Cache(Path(args.cache) if args.cache else default_cache_dir())
    cache.check_writable()
    return cache


def _check_runner(args: argparse.Namespace) -> None:
    """Checks of the runner options and of --out, before any work."""
    out_folder(args.out)
    if args.jobs < 1:
        raise BenchError(f"-j must be >= 1, got {args.jobs}")
    if args.repeats is None:
        args.repeats = 2 if getattr(args, "quick", False) else args.default_repeats
    if args.repeats < 0:
        raise BenchError(f"--repeats must be >= 0, got {args.repeats}")
    dask_address(args.dask)


def _tracebacks(res, show: bool) -> None:  # noqa: ANN001
    errors = res.table[res.table["status"] == "error"]
    if errors.empty:
        return
    if not show:
        print(f"contact-bench: {len(errors)} error row(s); --traceback shows where they were "
              "raised", file=sys.stderr)
        return
    for row in errors.itertuples():
        tb = res.tracebacks.get(row.key, "(no traceback)")
        print(f"--- {row.case} / {row.scheme} (nx {row.nx}):\n{tb}", file=sys.stderr)


def _summary(res, path: Path, quiet: bool) -> None:  # noqa: ANN001
    counts = res.table["status"].value_counts().to_dict()
    line = (f"{len(res.table)} runs ({res.executed} computed, {res.cached} from the cache, "
            f"{res.timed} timed) in {res.elapsed:.1f} s; status: "
            + ", ".join(f"{k} {v}" for k, v in counts.items()) + f"; wrote {path}")
    print(line, file=sys.stderr if quiet else sys.stdout)


def cmd_sweep(args: argparse.Namespace, argv: Sequence[str]) -> int:
    from contact_bench.api.registry import cases, schemes
    from contact_bench.sweeps.sweep import plan, run_sweep, save_table

    _check_runner(args)
    nxs = numbers(args.nx, int, "nx", commas=True) or [None]
    dts = numbers(args.dt, float, "dt", commas=True)
    cfls = numbers(args.cfl, float, "cfl", commas=True)
    T = numbers([args.T], float, "T")[0] if args.T is not None else None
    stride = numbers([args.stride], int, "stride")[0]
    positive_int(args.max_samples, "max-samples")
    case_specs = args.case or [n for n, c in cases().plugins.items() if c.in_default_run]
    scheme_specs = args.scheme or schemes().names()
    tasks = plan(case_specs, scheme_specs, nxs, dts, cfls, T, stride,
                 args.max_samples, args.grading)
    cache = _cache(args)
    res = run_sweep(tasks, args.jobs, args.dask, cache, args.repeats, args.quiet, args.retime)
    written = save_table(res.table, Path(args.out) / "sweep.csv", provenance(argv))
    _summary(res, written[0], args.quiet)
    _tracebacks(res, args.traceback)
    return 0


def cmd_report(args: argparse.Namespace, argv: Sequence[str]) -> int:
    from contact_bench.output.report import check_report_options, write_report
    from contact_bench.sweeps.sweep import load_table

    out_folder(args.out)
    df = load_table(args.table)
    check_report_options(df, args.error, args.fig_format, args.style, args.energy_runs)
    written = write_report(df, args.out, argv, args.error, args.fig_format, args.style,
                           args.energy_runs, _saved_time_orders(args.table))
    page = next((p for p in written if p.name == "index.html"), written[-1])
    print(f"wrote {len(written)} files to {args.out} (open {page})")
    return 0


def _saved_time_orders(table: str):  # noqa: ANN202 - pandas is imported lazily
    """The study's time_order.csv next to a sweep table, or None."""
    path = Path(table).with_name("time_order.csv")
    if not path.is_file():
        return None
    import pandas as pd

    return pd.read_csv(path, comment="#", keep_default_na=True)


def cmd_study(args: argparse.Namespace, argv: Sequence[str]) -> int:
    from contact_bench.output.figures import check_formats, check_style
    from contact_bench.output.friction_report import friction_rows, only_friction_rows
    from contact_bench.output.report import write_report
    from contact_bench.sweeps.study import plan_friction, plan_study
    from contact_bench.sweeps.sweep import check_error_column, run_sweep, save_table
    from contact_bench.sweeps.time_order import time_order_table

    _check_runner(args)
    check_formats(args.fig_format)
    check_style(args.style)
    check_error_column(None, args.error)  # checked before the sweep, not after it
    start = time.perf_counter()
    tasks = plan_study(args.quick, args.scheme, args.case) if args.part != "friction" else []
    if args.part != "main":
        friction = plan_friction(args.quick, args.scheme, args.case)
        if not friction and args.part == "friction":
            raise BenchError("--part friction: no scene of the study declares frictional "
                             "variants (StudyGrid.friction) or has friction")
        tasks += friction
    cache = _cache(args)
    res = run_sweep(tasks, args.jobs, args.dask, cache, args.repeats, args.quiet,
                    args.retime)
    out = Path(args.out)
    # the friction part's rows in a table of their own (results/study's sweep.csv stays
    # the rest of the study's)
    mine, main = friction_rows(res.table), ~only_friction_rows(res.table)
    written = [*(save_table(res.table[main], out / "sweep.csv", provenance(argv))
                 if main.any() else []),
               *(save_table(res.table[mine], out / "friction_sweep.csv", provenance(argv))
                 if mine.any() else [])]
    _summary(res, written[0], args.quiet)
    _tracebacks(res, args.traceback)
    # declared against measured time order for every scheme spec of the study's tables
    time_orders = (time_order_table(list(res.table[main]["scheme"].dropna()))
                   if main.any() else None)
    files = write_report(res.table, out, argv, args.error, args.fig_format, args.style,
                         args.energy_runs, time_orders)
    page = out / ("index.html" if main.any() else "friction.html")
    print(f"study: {len(files) + len(written)} files in {out} (open {page}); "
          f"{time.perf_counter() - start:.0f} s")
    return 0


def run_command(args: argparse.Namespace, argv: Sequence[str]) -> int:
    """Dispatch one of COMMANDS; Ctrl-C leaves the finished runs in the cache."""
    handler = {"sweep": cmd_sweep, "report": cmd_report, "study": cmd_study}[args.command]
    try:
        return handler(args, argv)
    except KeyboardInterrupt:
        print("contact-bench: interrupted; finished runs are cached: run the same command "
              "again to continue", file=sys.stderr)
        return 130
