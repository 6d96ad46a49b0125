"""`contact-bench`: list plugins, run a product of configurations, write result files."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

from contact_bench.api.registry import cases, make_case, schemes
from contact_bench.cli.sweep_cli import COMMANDS as SWEEP_COMMANDS
from contact_bench.cli.sweep_cli import add_commands as add_sweep_commands
from contact_bench.cli.sweep_cli import run_command as run_sweep_command
from contact_bench.core.errors import BenchError
from contact_bench.harness.environment import provenance, return_freed_memory
from contact_bench.harness.io import write_text
from contact_bench.harness.runner import Run, form_mismatch, reference, run_table

if TYPE_CHECKING:  # pandas loads with the first table, not before the runs
    import pandas as pd

SHOWN = ["case", "scheme", "nx", "dt", "steps", "err_u_linf_l2", "err_v_linf_l2",
         "err_stress_l2", "energy_drift_max", "penetration_max", "wall_s", "status"]


def _fmt_table(df: pd.DataFrame) -> str:
    import pandas as pd

    view = df[SHOWN].copy()
    for col in view.columns:
        if col in {"nx", "steps"}:
            view[col] = view[col].map(lambda v: "" if pd.isna(v) else f"{int(v)}")
        elif col not in {"case", "scheme", "status"}:
            view[col] = view[col].map(lambda v: "n/a" if pd.isna(v) else f"{v:.3g}")
    text = view.to_string(index=False)
    notes = [f"  {r.case} / {r.scheme}: {r.notes}" for r in df.itertuples() if r.notes]
    return text + ("\n\nnotes:\n" + "\n".join(notes) if notes else "")


def _markdown(df: pd.DataFrame) -> str:
    view = df[SHOWN + ["notes"]].copy()
    return view.to_markdown(index=False, floatfmt=".3g")


def cmd_list(args: argparse.Namespace) -> int:
    out = ["Cases (scenes):"]
    for name, cls in cases().plugins.items():
        case = cls()
        ref = case.reference or "none"
        out.append(f"  {name:<20} {cls.summary}")
        rho, E = ("x-dep" if callable(v) else f"{v:g}" for v in (case.rho, case.E))
        gravity = f"g={case.g:g}" if case.g > 0 else "no gravity"
        stride = f" stride={case.stride}" if case.stride != 1 else ""
        absent = sorted({"u", "v", "stress", "energy"} - set(cls.provides))
        out.append(f"  {'':<20} L={case.L:g} rho={rho} E={E} {gravity}"
                   f" far end={case.far_end}; defaults T={case.T:g} nx={case.nx} dt={case.dt:g}"
                   f"{stride}; reference={ref}; provides={','.join(sorted(cls.provides)) or '-'}"
                   + (f" (not: {','.join(absent)})" if absent else ""))
        out.append(f"  {'':<20} form={cls.form}")
        for key, p in cls.params.items():
            out.append(f"  {'':<22}{key} = {p.default!r} ({p.allowed()}) {p.doc}")
    out.append("Schemes:")
    for name, cls in schemes().plugins.items():
        sch = cls()
        tr = sch.traits()
        out.append(f"  {name:<20} {cls.summary}")
        limit = sch.stability_limit(1.0, 1.0)  # every declared limit scales like h / c
        stab = "none" if limit is None else f"dt <= {limit:.3g} h/c"
        order = "-" if tr.order is None else str(tr.order)
        out.append(f"  {'':<20} implicit={tr.implicit} massless_contact_node="
                   f"{tr.massless_contact_node} contact={tr.contact} energy={tr.energy}"
                   f" mass={sch.mass_kind()} stability_limit={stab} order={order}")
        out.append(f"  {'':<20} forms={','.join(sorted(cls.forms))} (problem forms it "
                   "integrates: banded1d = the 1D bar's bands, sparse = the general problem)")
        refused = [c for c, ccls in cases().plugins.items()
                   if form_mismatch(ccls(), sch) or sch.cannot_run(ccls())
                   or ccls().cannot_run(sch)]
        if refused:
            out.append(f"  {'':<20} cannot run (defaults): {', '.join(refused)}")
        for key, p in cls.params.items():
            out.append(f"  {'':<22}{key} = {p.default!r} ({p.allowed()}) {p.doc}")
    for kind, reg in (("case", cases()), ("scheme", schemes())):
        for name, err in reg.broken.items():
            out.append(f"  [broken {kind} module {name}: {err}]")
    print("\n".join(out))
    return 0


def _write_outputs(out: Path, df: pd.DataFrame, runs: list[Run], argv: Sequence[str]) -> list[Path]:
    from contact_bench.output.figures import contact_figure

    prov = provenance(argv)
    written = [
        write_text(out / "runs.csv", df.to_csv(index=False)),
        write_text(out / "runs.md", f"<!-- {prov} -->\n\n" + _markdown(df) + "\n"),
    ]
    for case_spec in dict.fromkeys(df["case"]):
        case = make_case(case_spec)
        these = [r for r in runs if r.row["case"] == case_spec]
        T = max((r.row["T"] for r in these if r.trajectory is not None), default=case.T)
        exact = reference(case, T) if case.reference == "exact" else None
        fname = case_spec.replace("[", "_").replace("]", "").replace(",", "_").replace("=", "-")
        written.append(contact_figure(these, exact, case.spec, out / f"{fname}.png"))
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


def cmd_run(args: argparse.Namespace, argv: Sequence[str]) -> int:
    default_job = not (args.case or args.scheme or args.nx or args.dt or args.T)
    case_names = args.case or [n for n, c in cases().plugins.items() if c.in_default_run]
    scheme_names = args.scheme or schemes().names()
    runs: list[Run] = []
    df = run_table(case_names, scheme_names, args.nx or [None], args.dt or [None], args.T,
                   args.stride, args.grading, args.allow_unstable, keep=runs,
                   explicit_pair=bool(args.case and args.scheme), keep_samples=False)
    out = args.out or ("results/default" if default_job else None)
    if args.format == "csv":
        sys.stdout.write(df.to_csv(index=False))
    elif args.format == "json":
        sys.stdout.write(df.to_json(orient="records", indent=1) + "\n")
    elif args.format == "markdown":
        print(_markdown(df))
    else:
        print(_fmt_table(df))
    if out:
        written = _write_outputs(Path(out), df, runs, argv)
        if args.format == "table":
            print(f"\nwrote {', '.join(str(p) for p in written)}")
    return 0


class UsageError(Exception):
    """argparse's own complaint (unknown option, bad choice, missing value)."""


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (printed by `main`), not usage + exit."""

    def error(self, message: str) -> NoReturn:  # type: ignore[override]
        message = " ".join(message.split())
        raise UsageError(f"{message} (see '{self.prog} --help')")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="contact-bench", description=__doc__)
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="cases and schemes with their parameters and declarations")
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
    r.add_argument("--allow-unstable", action="store_true",
                   help="run an explicit scheme above its stability limit (row is marked)")
    r.add_argument("--format", choices=["table", "csv", "json", "markdown"], default="table")
    r.add_argument("--out",
                   help="folder for CSV, Markdown and figures (default job: results/default/)")
    add_sweep_commands(sub)  # sweep, report, study (bench/sweep_cli.py)
    return p


_ALLOWED = {"nx": "an integer >= 1", "dt": "a number > 0", "T": "a number > 0",
            "stride": "an integer >= 1"}


def _numbers(values: list[str] | None, kind: type, name: str) -> list | None:
    """Parse option values; ranges are checked by the harness (same messages as the API)."""
    if not values:
        return None
    out = []
    for v in values:
        try:
            if kind is float:
                x: float | int = float(v)
            else:
                try:
                    x = int(v)
                except ValueError:
                    f = float(v)  # 1e3 is an integer too
                    if not f.is_integer():
                        raise
                    x = int(f)
        except (ValueError, OverflowError):
            raise BenchError(f"--{name} must be {_ALLOWED.get(name, kind.__name__)}, "
                             f"got {v!r}") from None
        out.append(x)
    return out


INTERRUPTED = "contact-bench: interrupted (no partial result files written)"


def main(argv: Sequence[str] | None = None) -> int:
    """Exit codes: 0 done, 2 bad input (one line on stderr), 130 interrupted (Ctrl-C)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    return_freed_memory()  # peak memory: freed n-sized arrays are not kept by the heap
    try:
        args = build_parser().parse_args(argv)
        if args.command == "list":
            return cmd_list(args)
        if args.command in SWEEP_COMMANDS:
            return run_sweep_command(args, argv)
        args.nx = _numbers(args.nx, int, "nx")
        args.dt = _numbers(args.dt, float, "dt")
        args.T = _numbers([args.T], float, "T")[0] if args.T else None
        args.stride = (_numbers([args.stride], int, "stride")[0]
                       if args.stride is not None else None)
        return cmd_run(args, argv)
    except (BenchError, UsageError) as exc:
        print(f"contact-bench: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        # results are written atomically: an interrupted run leaves no partial file
        print(INTERRUPTED, file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
