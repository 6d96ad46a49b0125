"""`contact-bench`: list plugins, run a product of configurations, write result files."""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

from contact_bench import __version__
from contact_bench.api.problem import BarScale
from contact_bench.api.registry import PLUGINS_ENV, cases, checked_plugin_dirs, make_case, schemes
from contact_bench.cli.checks import numbers, out_folder, time_error_factor
from contact_bench.cli.sweep_cli import COMMANDS as SWEEP_COMMANDS
from contact_bench.cli.sweep_cli import add_commands as add_sweep_commands
from contact_bench.cli.sweep_cli import run_command as run_sweep_command
from contact_bench.core.errors import BenchError
from contact_bench.harness.environment import provenance, return_freed_memory
from contact_bench.harness.io import folder_set, write_text
from contact_bench.harness.metrics import NEEDS
from contact_bench.harness.runner import Run, reference, run_table

if TYPE_CHECKING:  # pandas loads with the first table, not before the runs
    import pandas as pd

#: where the default job writes: untracked (.gitignore), so a newcomer's first run leaves
#: `git status` clean; the published results/default/ is refreshed by --out results/default
DEFAULT_OUT = "contact-bench-output"

#: the printed table's columns (and runs.md's) before and after its error columns ...
SHOWN_FIRST = ["case", "scheme", "nx", "dt", "steps"]
SHOWN_LAST = ["energy_drift_max", "penetration_max", "step_s", "run_s", "status"]
#: ... which are these field norms, for the fields a scene's reference provides
SHOWN_NORMS = ("err_u_linf_l2", "err_v_linf_l2", "err_stress_l2")


def shown_columns(df: pd.DataFrame) -> list[str]:
    """The printed table's columns: `SHOWN_FIRST`, the error columns the table's scenes
    declare, `SHOWN_LAST`. The error columns: the norms of `SHOWN_NORMS` whose field a
    scene's reference provides (`Case.reference`, `Case.provides`), then the relative
    errors `err_<q>` of the scenes' own quantities (`Case.quantities`), sorted by name.
    The first contact's quantities the harness reads from an exact stress, and the
    other norms, are in the CSV."""
    found = [make_case(spec) for spec in dict.fromkeys(df["case"])]
    norms = [c for c in SHOWN_NORMS
             if any(case.reference and NEEDS[c] in case.provides for case in found)]
    own = sorted({f"err_{q}" for case in found for q in case.quantities})
    return SHOWN_FIRST + norms + [c for c in own if c in df] + SHOWN_LAST


def _fmt_table(df: pd.DataFrame) -> str:
    import pandas as pd

    view = df[shown_columns(df)].copy()
    for col in view.columns:
        if col in {"nx", "steps"}:
            view[col] = view[col].map(lambda v: "" if pd.isna(v) else f"{int(v)}")
        elif col not in {"case", "scheme", "status"}:
            view[col] = view[col].map(lambda v: "n/a" if pd.isna(v) else f"{v:.3g}")
    text = view.to_string(index=False)
    notes = [f"  {r.case} / {r.scheme}: {r.notes}" for r in df.itertuples() if r.notes]
    return text + ("\n\nnotes:\n" + "\n".join(notes) if notes else "")


def _markdown(df: pd.DataFrame) -> str:
    view = df[[*shown_columns(df), "notes"]].copy()
    return view.to_markdown(index=False, floatfmt=".3g")


#: `list` output width (text form)
LIST_WIDTH = 100


def _param_records(cls: type) -> list[dict]:
    return [{"name": key, "default": p.default, "allowed": p.allowed(), "doc": p.doc}
            for key, p in cls.params.items()]


def _case_record(name: str, cls: type) -> dict:
    case = cls()
    declared = {key: "x-dependent" if callable(value) else value
                for key, value in case.declarations().items()}
    return {
        "kind": "case", "name": name, "summary": cls.summary, "scene": cls.kind,
        **declared, "declared": list(declared), "T": case.T, "nx": case.nx, "dt": case.dt,
        "stride": case.stride, "reference": case.reference or "none", "form": cls.form,
        "provides": sorted(cls.provides), "in_default_run": bool(cls.in_default_run),
        "contact_label": cls.contact_label, "force_label": cls.force_label,
        "params": _param_records(cls),
    }


def _declared_text(r: dict) -> str:
    """A scene's declarations (`Case.declarations`) as `list` prints them."""
    parts = []
    for key in r["declared"]:
        value = r[key]
        if key == "g":
            parts.append(f"g={value:g}" if value > 0 else "no gravity")
        else:
            text = value if isinstance(value, str) else f"{value:g}"
            parts.append(f"{key.replace('_', ' ')}={text}")
    return " ".join(parts)


def _scheme_record(name: str, cls: type) -> dict:
    sch = cls()
    tr = sch.traits()
    try:
        limit = sch.stability_limit(BarScale())
    except (AttributeError, TypeError):  # a limit that needs the whole bar
        limit = None
    return {
        "kind": "scheme", "name": name, "summary": cls.summary, "implicit": bool(tr.implicit),
        "massless_contact_node": bool(tr.massless_contact_node), "contact": tr.contact,
        "family": tr.family, "energy": tr.energy, "mass": sch.mass_kind(),
        "cfl_limit": None if limit is None else float(limit), "order": tr.order,
        "cannot_run": [c for c, ccls in cases().plugins.items()
                       if sch.cannot_run(ccls())
                       or ccls().cannot_run(sch)],
        "params": _param_records(cls),
    }


def list_records(what: str | None = None) -> list[dict]:
    """What `list` shows, as plain records: what = None (all), 'schemes', 'cases' or
    one plugin's name. An unknown name is a BenchError naming it."""
    out: list[dict] = []
    if what in (None, "cases"):
        out += [_case_record(n, c) for n, c in cases().plugins.items()]
    if what in (None, "schemes"):
        out += [_scheme_record(n, c) for n, c in schemes().plugins.items()]
    if what not in (None, "cases", "schemes"):
        if what in cases().plugins:
            out.append(_case_record(what, cases().plugins[what]))
        if what in schemes().plugins:
            out.append(_scheme_record(what, schemes().plugins[what]))
        if not out:
            known = ", ".join([*cases().plugins, *schemes().plugins])
            raise BenchError(f"list: no scheme or case named {what!r} (known: {known}; "
                             "or 'schemes', 'cases')")
    return out


def _wrap(text: str, indent: int) -> list[str]:
    import textwrap

    return textwrap.wrap(text, LIST_WIDTH, initial_indent=" " * indent,
                         subsequent_indent=" " * (indent + 2), break_on_hyphens=False) or [""]


def _list_text(records: list[dict]) -> str:
    out: list[str] = []
    for kind, title in (("case", "Cases (scenes):"), ("scheme", "Schemes:")):
        recs = [r for r in records if r["kind"] == kind]
        if not recs:
            continue
        out.append(title)
        for r in recs:
            out += _wrap(f"{r['name']:<18} {r['summary']}", 2)
            if kind == "case":
                stride = f" stride={r['stride']}" if r["stride"] != 1 else ""
                absent = sorted({"u", "v", "stress", "energy"} - set(r["provides"]))
                out += _wrap(f"defaults T={r['T']:g} nx={r['nx']} dt={r['dt']:g}{stride}; "
                             f"reference={r['reference']}; provides="
                             f"{','.join(r['provides']) or '-'}"
                             + (f" (not: {','.join(absent)})" if absent else "")
                             + f"; form={r['form']}", 6)
                out += _wrap(f"{r['scene']}: {_declared_text(r)}", 6)
            else:
                stab = ("none" if r["cfl_limit"] is None
                        else f"dt <= {r['cfl_limit']:.3g} h/c")
                order = "-" if r["order"] is None else str(r["order"])
                out += _wrap(f"implicit={r['implicit']} massless_contact_node="
                             f"{r['massless_contact_node']} contact={r['contact']} "
                             f"class={r['family']}", 6)
                out += _wrap(f"energy={r['energy']} mass={r['mass']} stability_limit={stab} "
                             f"order={order}", 6)
                if r["cannot_run"]:
                    out += _wrap(f"cannot run (defaults): {', '.join(r['cannot_run'])}", 6)
            for p in r["params"]:
                out += _wrap(f"{p['name']} = {p['default']!r} ({p['allowed']}) {p['doc']}", 6)
    for kind, reg in (("case", cases()), ("scheme", schemes())):
        for name, err in reg.broken.items():
            label = "plugin" if name in cases().broken and name in schemes().broken else kind
            for line in _wrap(f"[broken {label} module {name}: {err}]", 2):
                if line not in out:  # a plugin file is tried as both kinds
                    out.append(line)
    return "\n".join(out)


def cmd_list(args: argparse.Namespace) -> int:
    records = list_records(args.what)
    if args.format == "json":
        text = json.dumps(records, indent=1, default=str)
    else:
        text = _list_text(records)
    try:
        print(text)
    except BrokenPipeError:  # `contact-bench list | head`
        sys.stderr.close()
    return 0


def _write_outputs(out: Path, df: pd.DataFrame, runs: list[Run], argv: Sequence[str],
                   formats: Sequence[str] = ("png",), style: str | None = None,
                   pictures: BodyPictures | None = None) -> list[Path]:
    """The result set (tables, figures, README.md), written as one (`folder_set`)."""
    with folder_set(out) as tmp:
        names = [p.name for p in _write_set(tmp, df, runs, argv, formats, style, pictures)]
    return [out / n for n in names]


def _write_set(out: Path, df: pd.DataFrame, runs: list[Run], argv: Sequence[str],
               formats: Sequence[str] = ("png",), style: str | None = None,
               pictures: BodyPictures | None = None) -> list[Path]:
    from contact_bench.output.figures import contact_figure, save_figure, use_style
    from contact_bench.output.pictures import snapshot_figure, write_movie

    prov = provenance(argv)
    written = [
        write_text(out / "runs.csv", df.to_csv(index=False)),
        write_text(out / "runs.csv.json", json.dumps(
            {"provenance": prov, "file": "runs.csv", "cases": list(dict.fromkeys(df["case"])),
             "schemes": list(dict.fromkeys(df["scheme"]))}, indent=1) + "\n"),
        write_text(out / "runs.md", f"<!-- {prov} -->\n\n" + _markdown(df) + "\n"),
    ]
    for case_spec in dict.fromkeys(df["case"]):
        case = make_case(case_spec)
        these = [r for r in runs if r.row["case"] == case_spec]
        T = max((r.row["T"] for r in these if r.trajectory is not None), default=case.T)
        exact = reference(case, T) if case.reference == "exact" else None
        fname = (case_spec.replace("[", "_").replace("]", "").replace(",", "_")
                 .replace("=", "-").replace("/", "_"))
        with use_style(style):
            fig = contact_figure(these, exact, case.spec, contact_label=case.contact_label,
                                 force_label=case.force_label)
        written += save_figure(fig, out / fname, formats, prov)
    for stem, pics in pictures.pictures if pictures is not None else ():
        with use_style(style):  # the deformed body at contact start, peak force, release
            written += save_figure(snapshot_figure(pics), out / f"snapshots_{stem}",
                                   formats, prov)
        if pictures.movie:
            written.append(write_movie(pics, out / f"movie_{stem}.{pictures.movie}"))
    tables = [r.trajectory.extra["impact_table"].assign(
        case=r.row["case"], scheme=r.row["scheme"], nx=r.row["nx"], dt=r.row["dt"])
        for r in runs if r.trajectory is not None and "impact_table" in r.trajectory.extra]
    if tables:  # impact by impact: start, end, energy after, rebound ratio
        import pandas as pd

        impacts = pd.concat(tables, ignore_index=True)
        front = ["case", "scheme", "nx", "dt"]
        impacts = impacts[front + [c for c in impacts.columns if c not in front]]
        written.append(write_text(out / "impacts.csv", impacts.to_csv(index=False)))
    listing = "\n".join(f"- `{p.name}`" for p in written)
    write_text(out / "README.md", f"# Results\n\n{prov}\n\nFiles:\n{listing}\n")
    return written


class Progress:
    """One line on stderr per run ("run 3/20: clamped_bar / hht ..."), telling when a
    scheme's kernels compile on first use; redrawn in place on a terminal. Shown when
    stderr is a terminal (`--progress`: also when it is not, e.g. a CI log)."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.tty = sys.stderr.isatty()
        self.seen: set[str] = set()
        self.width = 0

    def __call__(self, i: int, total: int, case: object, scheme: object) -> None:
        if not self.enabled:
            return
        name = getattr(scheme, "name", str(scheme))
        first = name not in self.seen
        self.seen.add(name)
        note = (" (first run of this scheme: its kernels may compile, up to a minute)"
                if first else "")
        line = (f"contact-bench: run {i + 1}/{total}: {getattr(case, 'spec', case)} / "
                f"{getattr(scheme, 'spec', scheme)}{note}")
        if self.tty:
            sys.stderr.write("\r" + line.ljust(self.width))
            self.width = len(line)
        else:
            sys.stderr.write(line + "\n")
        sys.stderr.flush()

    def done(self) -> None:
        if self.enabled and self.tty and self.width:
            sys.stderr.write("\r" + " " * self.width + "\r")
            sys.stderr.flush()


def cmd_run(args: argparse.Namespace, argv: Sequence[str]) -> int:
    default_job = not (args.case or args.scheme or args.nx or args.dt or args.T)
    case_names = args.case or [n for n, c in cases().plugins.items() if c.in_default_run]
    scheme_names = args.scheme or schemes().names()
    out = args.out if args.out is not None else (DEFAULT_OUT if default_job else None)
    if out is not None:
        out_folder(out)  # before any run: a bad --out is not found after the work
    if args.movie and not out:
        raise BenchError("--movie needs --out (the movies are written with the results)")
    if args.fields:
        out_folder(args.fields)
    runs: list[Run] = []
    progress = Progress(not args.quiet and (args.progress or sys.stderr.isatty()))
    with contextlib.ExitStack() as stack:
        fields_tmp = (stack.enter_context(folder_set(Path(args.fields)))
                      if args.fields else None)
        pictures = BodyPictures(fields_tmp, movie=args.movie, draw=bool(out))
        try:
            df = run_table(case_names, scheme_names, args.nx or [None], args.dt or [None],
                           args.T, args.stride, args.grading, args.allow_unstable, keep=runs,
                           explicit_pair=bool(args.case and args.scheme),
                           keep_samples=False, progress=progress,
                           time_error=args.time_error,
                           after_run=pictures if pictures.wanted else None)
        finally:
            progress.done()
    if args.format == "csv":
        sys.stdout.write(df.to_csv(index=False))
    elif args.format == "json":
        sys.stdout.write(df.to_json(orient="records", indent=1) + "\n")
    elif args.format == "markdown":
        print(_markdown(df))
    else:
        print(_fmt_table(df))
        _print_reference_costs(runs)
    errors = [r for r in runs if r.row.get("status") == "error"]
    if args.traceback:
        for r in errors:
            print(f"--- {r.row['case']} / {r.row['scheme']}:\n{r.traceback or '(no traceback)'}",
                  file=sys.stderr)
    elif errors and args.format == "table":  # machine formats keep stderr for real errors
        print(f"contact-bench: {len(errors)} error row(s); --traceback shows where they "
              "were raised", file=sys.stderr)
    for line in pictures.skipped:
        print(f"contact-bench: {line}", file=sys.stderr)
    if args.fields and args.format == "table":
        print(f"\nfields: {', '.join(str(Path(args.fields) / n) for n in pictures.series)}"
              if pictures.series else f"\nfields: none written to {args.fields}")
    if out:
        written = _write_outputs(Path(out), df, runs, argv, args.fig_format, args.style,
                                 pictures)
        if args.format == "table":
            print(f"\nwrote {', '.join(str(p) for p in written)}")
    return 0


class BodyPictures:
    """`run_table`'s `after_run` of `contact-bench run --fields DIR / --out / --movie`:
    for each body run whose scene gives its body (`BodyCase.body`), the VTU series of
    its fields into DIR (`contact_bench.output.fields`) and the picture data of its
    snapshots and movie (`contact_bench.output.pictures.RunPictures`), kept small so
    that the run's samples can go. A run it cannot draw is named in `skipped`."""

    def __init__(self, fields_dir: Path | None, movie: str | None, draw: bool) -> None:
        self.fields_dir = fields_dir
        self.movie = movie
        self.draw = draw
        self.series: list[str] = []
        self.pictures: list = []
        self.skipped: list[str] = []

    @property
    def wanted(self) -> bool:
        return bool(self.fields_dir is not None or self.draw)

    def __call__(self, run: Run) -> None:
        from contact_bench.output.fields import body_fields, file_stem, write_series
        from contact_bench.output.pictures import run_pictures

        case = make_case(run.row["case"])
        if case.form != "sparse" or run.problem is None:
            return
        body = case.body(int(run.row["nx"]))
        if body is None:
            self.skipped.append(f"no fields or pictures of {run.row['case']} / "
                                f"{run.row['scheme']}: the scene gives no body "
                                "(BodyCase.body)")
            return
        try:
            fields = body_fields(body, run.problem)
        except ValueError as exc:
            self.skipped.append(f"no fields or pictures of {run.row['case']} / "
                                f"{run.row['scheme']}: {exc}")
            return
        tr = run.trajectory
        stem = file_stem(run.row["case"], run.row["scheme"])
        if self.fields_dir is not None:
            write_series(self.fields_dir, stem, fields, tr.t, tr.U, tr.V)
            self.series.append(f"{stem}.pvd")
        if self.draw:
            pics = run_pictures(f"{run.row['case']} / {run.row['scheme']}", fields,
                                run.problem, tr, movie=bool(self.movie))
            if pics is None:
                self.skipped.append(f"no snapshots of {run.row['case']} / "
                                    f"{run.row['scheme']}: no contact in the run")
            else:
                self.pictures.append((stem, pics))


def _print_reference_costs(runs: list[Run]) -> None:
    """One line per distinct numerical reference of the table: its cost, apart from the
    runs' (`ref_compute_s`), and whether this table computed it or read it back."""
    seen: set[tuple] = set()
    for r in runs:
        cost = r.row.get("ref_compute_s")
        key = (r.row.get("case"), r.row.get("nx"), r.row.get("dt"), r.row.get("T"))
        if cost is None or key in seen:
            continue
        seen.add(key)
        how = "read back from the reference cache" if r.row.get("ref_from_cache") else "computed"
        print(f"reference of {r.row['case']} at nx = {r.row['nx']}, dt = {r.row['dt']:g}: "
              f"{how}; computing it takes {cost:.3g} s (ref_compute_s)")


class UsageError(Exception):
    """argparse's own complaint (unknown option, bad choice, missing value)."""


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (printed by `main`), not usage + exit."""

    def error(self, message: str) -> NoReturn:  # type: ignore[override]
        message = " ".join(message.split())
        raise UsageError(f"{message} (see '{self.prog} --help')")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="contact-bench", description=__doc__)
    p.add_argument("--plugins", action="append", default=[], metavar="DIR", help=PLUGINS_HELP)
    sub = p.add_subparsers(dest="command", required=True)
    p.add_argument("--version", action="version",
                   version=f"contact-bench {__version__}")
    li = sub.add_parser("list", help="cases and schemes with their parameters and declarations")
    li.add_argument("what", nargs="?", metavar="schemes|cases|NAME",
                    help="only the schemes, only the cases, or one plugin by name")
    li.add_argument("--format", choices=["text", "json"], default="text")
    r = sub.add_parser("run", help="run cases x schemes x nx x dt (no options: the default job)")
    r.add_argument("--case", action="append", help="case spec (repeatable)")
    r.add_argument("--scheme", action="append",
                   help="scheme spec, e.g. redistributed[variant=getfem]")
    r.add_argument("--nx", action="append", type=str, help="number of elements (repeatable)")
    r.add_argument("--dt", action="append", type=str, help="time step (repeatable)")
    r.add_argument("--T", type=str, help="final time (default: the case's)")
    r.add_argument("--stride", type=str, default=None,
                   help="keep a sample every K steps (default: the case's, 1 for most)")
    r.add_argument("--grading", type=float, default=1.0, help="mesh grading towards x=0 (>= 1)")
    r.add_argument("--time-error", type=str, default=None, metavar="K",
                   help="also err_time_u, err_time_stress: the error against the same scheme, "
                        "mesh and mass at dt / K, K an integer >= 2 (the time integrator's "
                        "own; cached)")
    r.add_argument("--allow-unstable", action="store_true",
                   help="run an explicit scheme above its stability limit (row is marked)")
    r.add_argument("--format", choices=["table", "csv", "json", "markdown"], default="table")
    r.add_argument("--out",
                   help=f"folder for CSV, Markdown and figures (default job: {DEFAULT_OUT}/, "
                        "not tracked by git; published results only with --out results/...)")
    r.add_argument("--quiet", action="store_true", help="no progress line on stderr")
    r.add_argument("--progress", action="store_true",
                   help="progress lines on stderr even when it is not a terminal")
    r.add_argument("--fig-format", default="png", metavar="FORMATS",
                   help="figure formats, comma-separated among png, pdf, svg (default png)")
    r.add_argument("--style", metavar="FILE_OR_NAME", help="matplotlib style for the figures")
    r.add_argument("--fields", metavar="DIR",
                   help="2D/3D runs: displacement, velocity, von Mises stress and contact "
                        "pressure at the samples, as a VTU series and its .pvd per run "
                        "(open the .pvd in ParaView)")
    r.add_argument("--movie", choices=["gif", "mp4"], default=None,
                   help="with --out: a movie of each 2D/3D run beside its contact force "
                        "(imageio; mp4 also needs imageio-ffmpeg)")
    r.add_argument("--traceback", action="store_true",
                   help="print the full traceback of every 'error' row on stderr")
    add_sweep_commands(sub)  # sweep, report, study (bench/sweep_cli.py)
    for command in sub.choices.values():  # --plugins after the subcommand too
        command.add_argument("--plugins", action="append", default=[], metavar="DIR",
                             dest="plugins_after", help=PLUGINS_HELP)
    return p


PLUGINS_HELP = (f"folder of plugin files (schemes, scenes; repeatable; added to ${PLUGINS_ENV}, "
                "which sweep workers inherit)")


INTERRUPTED = "contact-bench: interrupted (no partial result files written)"


def main(argv: Sequence[str] | None = None) -> int:
    """Exit codes: 0 done, 2 bad input (one line on stderr), 130 interrupted (Ctrl-C)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    return_freed_memory()  # peak memory: freed n-sized arrays are not kept by the heap
    saved = os.environ.get(PLUGINS_ENV)
    try:
        args = build_parser().parse_args(argv)
        dirs = checked_plugin_dirs(args.plugins + args.plugins_after)
        if dirs:  # the registry and every worker process read the folders from there
            os.environ[PLUGINS_ENV] = os.pathsep.join(([saved] if saved else []) + dirs)
        if args.command == "list":
            return cmd_list(args)
        if args.command in SWEEP_COMMANDS:
            return run_sweep_command(args, argv)
        args.nx = numbers(args.nx, int, "nx")
        args.dt = numbers(args.dt, float, "dt")
        args.T = numbers([args.T], float, "T")[0] if args.T is not None else None
        args.stride = (numbers([args.stride], int, "stride")[0]
                       if args.stride is not None else None)
        args.time_error = time_error_factor(args.time_error)
        from contact_bench.output.figures import check_formats, check_style

        args.fig_format = check_formats(args.fig_format)
        check_style(args.style)
        if args.movie:
            from contact_bench.output.pictures import movie_formats

            if args.movie not in movie_formats():
                raise BenchError(f"--movie {args.movie} needs imageio"
                                 + (" and imageio-ffmpeg" if args.movie == "mp4" else "")
                                 + " (pip install -e \".[movie]\"); this installation "
                                 f"writes: {', '.join(movie_formats()) or 'none'}")
        return cmd_run(args, argv)
    except (BenchError, UsageError) as exc:
        print(f"contact-bench: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        # results are written atomically: an interrupted run leaves no partial file
        print(INTERRUPTED, file=sys.stderr)
        return 130
    finally:
        if saved is None:
            os.environ.pop(PLUGINS_ENV, None)
        else:
            os.environ[PLUGINS_ENV] = saved


if __name__ == "__main__":
    sys.exit(main())
