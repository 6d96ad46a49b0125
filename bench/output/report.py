"""`contact-bench report`: tables (CSV, Markdown, LaTeX), figures (PNG, PDF, SVG) and one
HTML page, all drawn from a saved sweep table without recomputing anything.

Every file records the command, versions and date that made it (`provenance`): CSV
files are plain (one header line, raw column names) with the provenance and the
columns' readable names and units in a sidecar `<name>.csv.json`; Markdown has an HTML
comment, LaTeX a `%` line (a booktabs table made by pandas' Styler: `\\usepackage{booktabs}`),
figures carry it in their metadata and `<stem>.fig.json`, the page in its header.
"""

from __future__ import annotations

import html
import json
import math
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from contact_bench.api.registry import make_case
from contact_bench.core.errors import BenchError
from contact_bench.exact import converged
from contact_bench.harness.environment import environment, provenance
from contact_bench.harness.io import write_text
from contact_bench.harness.metrics import ERROR_COLUMNS
from contact_bench.output.figures import (
    check_formats,
    check_style,
    convergence_figure,
    energy_figure,
    stability_figure,
    use_style,
    work_precision_figure,
)
from contact_bench.output.page import figure_block, file_links
from contact_bench.output.pictures import scene_pictures, snapshot_figure
from contact_bench.sweeps import analysis
from contact_bench.sweeps.sweep import STABILITY_CLASSES, check_error_column

#: columns shown with 2 decimals (orders); other floats get 3 significant digits
DECIMAL_COLUMNS = {"order", "measured order", "smooth order"}
INT_COLUMNS = {"nx", "points", "floor points", "declared order", "steps", "time_repeats"}
#: raw column -> readable header with its unit (Markdown, LaTeX, HTML); CSV keeps raw names
HEADERS = {
    "case": "scene", "scheme": "scheme", "curve": "curve", "nx": "elements",
    "h": "h", "dt": "dt", "cfl": "CFL (c dt/h)", "cfl_limit": "declared CFL limit",
    "T": "T (final time)", "steps": "steps",
    "err_u_linf_l2": "error u, Linf(L2) (rel.)", "err_u_linf_h1": "error u, Linf(H1) (rel.)",
    "err_v_linf_l2": "error v, Linf(L2) (rel.)", "err_u_l2_l2": "error u, L2(L2) (rel.)",
    "err_u_l2_h1": "error u, L2(H1) (rel.)", "err_v_l2_l2": "error v, L2(L2) (rel.)",
    "err_stress_l2": "error stress, L2 (rel.)",
    "err_free_fall": "error free fall (rel. to the lift)",
    "err_plane_momentum": "error momentum along the plane (rel.)",
    "err_pair_momentum": "drift of the pair's momentum (rel.)",
    "err_sliding_momentum": "error sliding momentum identity (rel.)",
    "err_contact_duration": "error contact duration (rel.)",
    "err_peak_force": "error peak contact force (rel.)",
    "err_hertz_contact_time": "gap to Hertz's contact time (rel.)",
    "err_hertz_peak_force": "gap to Hertz's peak force (rel.)",
    "err_u_numerical": "error u vs numerical reference, Linf (rel.)",
    "err_contact_force_numerical": "error contact force vs numerical reference, l2 (rel.)",
    "time_s": "stepping time [s] (min)", "time_median_s": "stepping time [s] (median)",
    "time_iqr_s": "stepping time IQR [s]", "time_repeats": "timed repeats",
    "time_noisy": "noisy timing", "wall_s": "wall time [s]", "pareto": "Pareto front",
    "stability": "class", "blowup_time": "blow-up time", "energy_trait": "declared energy",
    "energy_growth_max": "max growth (E-E0)/|E0|", "energy_drift_max": "max |E-E0|/|E0|",
    "energy_drift_bound": "declared drift bound", "energy_final_drift": "final (E-E0)/|E0|",
    "against": "against", "at": "at", "points": "points", "order": "fitted order",
    "local orders": "local orders", "declared order": "declared order",
    "floor points": "round-off points", "error": "error norm", "status": "status",
    "runs": "runs", "penetration_max": "max penetration", "notes": "notes",
}



def reference_floor(case: str, error: str) -> float | None:
    """The estimated error of the converged reference that the column `error` of scene
    `case` is measured against (`contact_bench.exact.converged.error_floor`), or None."""
    try:
        return converged.error_floor(make_case(case), error)
    except BenchError:  # a scene no longer registered: no band
        return None

def slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.-]+", "_", str(text)).strip("_")


def header(col: str) -> str:
    """The readable header of a column (its raw name when there is none; a scene's
    quantity `err_<q>` is "error <q> (rel.)")."""
    if col in HEADERS:
        return HEADERS[col]
    if col.startswith("err_"):
        return f"error {col[4:].replace('_', ' ')} (rel.)"
    if col.startswith(("scheme_", "case_")) and col not in ("scheme_name", "case_name"):
        kind, _, param = col.partition("_")
        return f"{kind} {param}"
    return col


def _fmt(value: object, col: str) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)) or value is pd.NA:
        return ""
    if isinstance(value, bool | np.bool_):
        return "yes" if value else "no"
    if col in INT_COLUMNS:
        try:
            return str(int(value))  # type: ignore[arg-type]
        except (TypeError, ValueError):
            return str(value)
    if isinstance(value, float | np.floating):
        if col in DECIMAL_COLUMNS:
            return f"{value:.2f}"
        return f"{value:.3g}"
    return str(value)


def display(df: pd.DataFrame) -> pd.DataFrame:
    """Strings with sensible significant digits (3; orders with 2 decimals), readable
    headers."""
    out = df.copy()
    for col in out.columns:
        out[col] = [_fmt(v, str(col)) for v in out[col]]
        if col == "error":  # the name of an error column, as a value
            out[col] = out[col].map(header)
    out.columns = [header(str(c)) for c in out.columns]
    return out


def to_latex(df: pd.DataFrame) -> str:
    """A booktabs table (\\toprule, \\midrule, \\bottomrule) of the display strings,
    made by pandas' Styler with LaTeX escaping of cells and headers."""
    shown = display(df)
    if shown.empty:
        return "% (no rows)\n"
    numeric = [not shown[c].map(lambda s: bool(re.search("[A-Za-z]", s))
                                and not re.fullmatch(r"[-+0-9.e]+", s)).any()
               for c in shown.columns]
    styler = shown.style.hide(axis="index").format(escape="latex") \
        .format_index(escape="latex", axis=1)
    return styler.to_latex(hrules=True,
                           column_format="".join("r" if n else "l" for n in numeric))


def write_tables(df: pd.DataFrame, out: Path, stem: str, prov: str) -> list[Path]:
    """stem.csv (plain, 6 significant digits) with stem.csv.json (provenance, headers,
    units), stem.md and stem.tex, each with its provenance."""
    csv = df.to_csv(index=False, float_format="%.6g")
    md = display(df).to_markdown(index=False) if not df.empty else "(no rows)"
    side = {"provenance": prov, "file": f"{stem}.csv",
            "columns": {str(c): header(str(c)) for c in df.columns}}
    return [
        write_text(out / f"{stem}.csv", csv),
        write_text(out / f"{stem}.csv.json", json.dumps(side, indent=1) + "\n"),
        write_text(out / f"{stem}.md", f"<!-- {prov} -->\n\n{md}\n"),
        write_text(out / f"{stem}.tex", f"% {prov}\n% needs \\usepackage{{booktabs}}\n"
                                        f"{to_latex(df)}"),
    ]

# ------------------------------------------------------------------- validation

STATUSES = ("ok", "unstable", "error", "not applicable")
#: columns every row of a sweep fills, whatever its status (checked when the table has
#: them): an empty one means the row was cut short
ALWAYS_FILLED = ("case", "scheme", "status", "key", "run_date", *environment().keys())
#: columns that are > 0 / >= 0 wherever they hold a value
POSITIVE = ("nx", "h", "dt", "cfl", "T", "steps", "stride", "grading")
NON_NEGATIVE = (*ERROR_COLUMNS, "energy_drift_max", "penetration_max", "wall_s",
                "time_s", "step_s", "run_s", "task_s", "time_repeats", "dt_limit",
                "cfl_limit")
#: phrases of a note that explain NaN error columns in an ok row
_NAN_REASONS = ("no reference solution", "reference has no")
_SHOWN_PROBLEMS = 5


def _empty(value: object) -> bool:
    return value is None or value is pd.NA or (isinstance(value, float) and math.isnan(value))


def table_problems(df: pd.DataFrame) -> list[str]:
    """What makes a sweep table unfit to publish, one line per problem (empty: fit).

    A row cut short (an always-filled column empty), an unknown status or stability
    class, a value out of its range (nx, h, dt, T, ... <= 0; an error, drift, penetration
    or time < 0 or infinite), an ok row without a finite initial energy, and an ok row
    with a NaN error column that its notes do not explain (`error_metrics` notes why a
    relative error is undefined; a case without that reference says so too)."""
    out: list[str] = []
    # a column empty in every row is one this kind of table lacks (a `run` table: no key)
    always = [c for c in ALWAYS_FILLED if c in df.columns and df[c].notna().any()]
    for pos, (_, r) in enumerate(df.iterrows()):
        row = r.to_dict()
        where = f"row {pos + 1}"
        if not _empty(row.get("case")) and not _empty(row.get("scheme")):
            where += f" ({row['case']}, {row['scheme']})"
        empty = [c for c in always if _empty(row.get(c)) or str(row.get(c)).strip() == ""]
        if empty:
            out.append(f"{where}: cut short ({', '.join(empty[:3])}"
                       f"{', ...' if len(empty) > 3 else ''} empty)")
            continue
        status = row["status"]
        if status not in STATUSES:
            out.append(f"{where}: status {str(status)[:40]!r} is not one of {', '.join(STATUSES)}")
            continue
        stab = row.get("stability")
        if not _empty(stab) and stab not in STABILITY_CLASSES:
            out.append(f"{where}: stability {str(stab)[:40]!r} is not one of "
                       f"{', '.join(STABILITY_CLASSES)}")
        for cols, ok, what in ((POSITIVE, lambda v: v > 0, "> 0"),
                               (NON_NEGATIVE, lambda v: v >= 0, ">= 0")):
            for col in cols:
                v = row.get(col)
                if _empty(v):
                    continue
                try:
                    f = float(v)
                except (TypeError, ValueError):
                    out.append(f"{where}: {col} = {str(v)[:40]!r} is not a number")
                    continue
                if not (math.isfinite(f) and ok(f)):
                    out.append(f"{where}: {col} = {f!r} (must be finite and {what})")
        if status != "ok":
            continue
        if "energy_initial" in df.columns and not math.isfinite(
                float(row["energy_initial"]) if not _empty(row["energy_initial"]) else math.nan):
            out.append(f"{where}: status ok without a finite energy_initial")
        notes = "" if _empty(row.get("notes")) else str(row["notes"])
        if any(p in notes for p in _NAN_REASONS):
            continue
        unexplained = [c for c in ERROR_COLUMNS
                       if c in df.columns and _empty(row.get(c)) and c not in notes]
        if unexplained:
            out.append(f"{where}: status ok with {', '.join(unexplained)} empty and no note "
                       f"saying why")
    return out


def check_table(df: pd.DataFrame) -> None:
    """Refuse (BenchError, one line) a table that `table_problems` finds damaged."""
    problems = table_problems(df)
    if problems:
        more = len(problems) - _SHOWN_PROBLEMS
        shown = "; ".join(problems[:_SHOWN_PROBLEMS]) + (f"; and {more} more" if more > 0
                                                          else "")
        raise BenchError(f"the table is damaged, not publishing it: {shown}")


# ------------------------------------------------------------------------- page


def html_table(df: pd.DataFrame) -> str:
    if df.empty:
        return "<p><em>no rows</em></p>"
    table = display(df).to_html(index=False, escape=True, border=0, classes="t")
    return f'<div class="scroll">{table}</div>'


def check_report_options(df: pd.DataFrame, error: str, fig_format: str | Sequence[str],
                         style: str | None, energy_runs: str) -> list[str]:
    """Every option of `report` checked against the table before anything is written;
    returns the figure formats. A bad one is a one-line BenchError naming it."""
    check_error_column(df, error)
    formats = check_formats(fig_format)
    check_style(style)
    if energy_runs not in ("finest", "all"):
        raise BenchError(f"--energy-runs must be finest or all; got {energy_runs!r}")
    return formats


def command_title(argv: Sequence[str] | None) -> str:
    """The page's title: the command that made it."""
    import shlex

    return "contact-bench " + " ".join(shlex.quote(a) for a in (argv or [])) if argv \
        else "contact-bench report"


def write_report(df: pd.DataFrame, out: str | Path, argv: Sequence[str] | None = None,
                 error: str = "err_u_linf_l2", fig_format: str | Sequence[str] = "png",
                 style: str | None = None, energy_runs: str = "finest",
                 time_orders: pd.DataFrame | None = None,
                 snapshots: bool = True) -> list[Path]:
    """All tables, figures and index.html for the table df, into out.

    `snapshots`: each 2D/3D scene's snapshot figure (`contact_bench.output.pictures.
    scene_pictures`: one of its runs again, with its samples).

    Options are checked first (`check_report_options`): a bad one writes nothing.
    time_orders: the declared and measured orders away from impacts
    (`contact_bench.sweeps.time_order.time_order_table`), if measured: a table of its own
    and a "smooth order" column in the convergence tables.
    """
    formats = check_report_options(df, error, fig_format, style, energy_runs)
    check_table(df)
    from contact_bench.output.friction_report import only_friction_rows, write_friction_report

    # the friction part's rows: its own files (friction_*, friction.html), apart
    friction_files = write_friction_report(df, out, argv, formats, style)
    df = df[~only_friction_rows(df)]
    if df.empty:
        return friction_files
    out = Path(out)
    prov = provenance(argv)
    written: list[Path] = []
    sections: list[str] = []
    toc: list[str] = []

    def figure(fig: Figure, stem: str, alt: str) -> str:
        body, files = figure_block(fig, out, stem, formats, prov, alt)
        written.extend(files)
        return body

    def section(case: str, key: str, title: str, body: str) -> None:
        anchor = f"{slug(case)}-{key}"
        toc.append(f'<li><a href="#{anchor}">{html.escape(title)}</a></li>')
        parts.append(f'<h3 id="{anchor}">{html.escape(title)} '
                     f'<a class="anchor" href="#{anchor}">#</a></h3>{body}')

    runs_table = df.drop(columns=["energy_trace"], errors="ignore")
    written += write_tables(runs_table, out, "runs", prov)
    refine, dts = analysis.select(df, "refine"), analysis.select(df, "dt")
    # a scene's error columns, read on the runs its work-precision figures draw (the
    # refinement runs, when it has them): a column filled only by other runs gets none
    errors = {case: analysis.error_columns(
        refine[refine["case"] == case] if (refine["case"] == case).any()
        else df[df["case"] == case], error) for case in dict.fromkeys(df["case"])}
    wp_all = pd.concat([analysis.work_precision(refine[refine["case"] == case], errs[0])
                        for case, errs in errors.items() if errs] or [pd.DataFrame()])
    conv_all = pd.concat([
        part for case, errs in errors.items() if errs for part in (
            analysis.convergence_table(refine[refine["case"] == case], errs[0],
                                       against=("h",)),
            analysis.convergence_table(dts[dts["case"] == case], errs[0], against=("dt",)))
    ] or [pd.DataFrame()])
    conv_all = analysis.with_time_orders(conv_all, time_orders)
    if time_orders is not None and not time_orders.empty:
        tabs = write_tables(time_orders, out, "time_order", prov)
        written += tabs
        toc.append('<li><a href="#time-order">Time order away from impacts</a></li>')
        sections.append(
            '<h2 id="time-order">Time order away from impacts</h2><p>Declared '
            "(<code>Traits.order</code>) against measured: least-squares slope of log error "
            "against log dt on a smooth motion without contact, the error of a dt being the "
            "difference with the same scheme at dt / 2 (docs/order.md). 'dt only samples': "
            "the output does not change with dt.</p>"
            f"<p>tables: {file_links(tabs)}</p>" + html_table(time_orders))
    energy_rows = analysis.select(df, "energy")
    energy_all = analysis.energy_table(energy_rows)
    stab_rows = analysis.select(df, "stability")
    with use_style(style):
        for case in dict.fromkeys(df["case"]):
            s = slug(case)
            parts: list[str] = []
            toc.append(f'<li><a href="#{s}">{html.escape(case)}</a><ul>')
            for k, err in enumerate(errors[case]):
                wp = (wp_all[wp_all["case"] == case] if k == 0 else
                      analysis.work_precision(refine[refine["case"] == case], err))
                if wp.empty:
                    continue
                stem = f"work_precision_{s}" + ("" if k == 0 else f"_{slug(err)}")
                body = figure(work_precision_figure(wp, case, err,
                                                    reference_floor(case, err)), stem,
                              f"work-precision {case} {err}")
                tabs = write_tables(wp.drop(columns=["case"]), out, stem, prov)
                written.extend(tabs)
                section(case, "work-precision" + ("" if k == 0 else f"-{slug(err)}"),
                        f"Work-precision ({header(err)} against stepping time)",
                        body + f"<p>tables: {file_links(tabs)}</p>"
                        + html_table(wp.drop(columns=["case"])))
            conv = conv_all[conv_all["case"] == case] if not conv_all.empty else conv_all
            if not conv.empty:
                err = errors[case][0]
                body = figure(convergence_figure(refine[refine["case"] == case],
                                                 dts[dts["case"] == case], case, err,
                                                 reference_floor(case, err)),
                              f"convergence_{s}", f"convergence {case}")
                tabs = write_tables(conv.drop(columns=["case"]), out, f"convergence_{s}", prov)
                written.extend(tabs)
                section(case, "convergence",
                        f"Convergence ({header(err)}; fitted and local orders; round-off "
                        "floor points left out; declared order and smooth order: away from "
                        "impacts)",
                        body + f"<p>tables: {file_links(tabs)}</p>"
                        + html_table(conv.drop(columns=["case"])))
            smap = analysis.stability_map(stab_rows, case)
            if not smap.empty:
                body = figure(stability_figure(stab_rows[stab_rows["case"] == case], case),
                              f"stability_{s}", f"stability {case}")
                tab_map = smap.reset_index().rename(columns=lambda c: c if c == "scheme"
                                                    else f"CFL {c:g}")
                tabs = write_tables(tab_map, out, f"stability_map_{s}", prov)
                long = analysis.stability_table(stab_rows[stab_rows["case"] == case])
                tabs += write_tables(long.drop(columns=["case"]), out, f"stability_runs_{s}",
                                     prov)
                written.extend(tabs)
                section(case, "stability", "Stability (worst class per scheme and CFL)",
                        body + f"<p>tables: {file_links(tabs)}</p>" + html_table(tab_map))
            for (name, pname), pmap in analysis.parameter_maps(stab_rows, case).items():
                tab = pmap.reset_index()
                tab.columns = [pname, *(f"CFL {c:g}" for c in pmap.columns)]
                tabs = write_tables(tab, out, f"stability_{slug(name)}_{slug(pname)}_{s}", prov)
                written.extend(tabs)
                section(case, f"stability-{slug(name)}-{slug(pname)}",
                        f"Stability of {name}: CFL against {pname} (worst class per cell)",
                        f"<p>tables: {file_links(tabs)}</p>" + html_table(tab))
            tolerances = _published_tolerances(case)
            ver = analysis.verification_table(df[df["case"] == case], tolerances)
            if not ver.empty:
                tabs = write_tables(ver, out, f"verification_{s}", prov)
                written.extend(tabs)
                tol = ", ".join(f"{q} {t:.0e}" for q, t in tolerances.items())
                section(case, "verification",
                        "Against the published values (every scheme at the published "
                        "grid; relative errors; within: how many within the tolerance)",
                        f"<p>tolerances: {html.escape(tol)}</p><p>tables: {file_links(tabs)}</p>"
                        + html_table(ver))
            if snapshots:  # a 2D/3D scene: the deformed body at its first contact
                try:
                    got = scene_pictures(df[df["case"] == case])
                except Exception:  # noqa: BLE001 - a table from elsewhere: no snapshots
                    got = None
                if got is not None:
                    pics, how = got
                    body = figure(snapshot_figure(pics), f"snapshots_{s}",
                                  f"snapshots {case}")
                    section(case, "snapshots",
                            f"Snapshots ({how['scheme']} at nx {how['nx']}, dt "
                            f"{how['dt']:g}, rerun with its samples: the deformed body "
                            "coloured by the von Mises stress at the first contact's start, "
                            "peak force and release)", body)
            en = energy_all[energy_all["case"] == case]
            if not en.empty:
                fig = energy_figure(energy_rows[energy_rows["case"] == case], case,
                                    energy_runs)
                body = "" if fig is None else figure(fig, f"energy_{s}", f"energy {case}")
                tabs = write_tables(en.drop(columns=["case"]), out, f"energy_{s}", prov)
                written.extend(tabs)
                section(case, "energy", "Energy", body + f"<p>tables: {file_links(tabs)}</p>"
                        + html_table(en.drop(columns=["case"])))
            toc.append("</ul></li>")
            sections.append(f'<h2 id="{s}">{html.escape(case)} '
                            f'<a class="anchor" href="#{s}">#</a></h2>' + "\n".join(parts))
    if friction_files:
        toc.append('<li><a href="friction.html">Friction part (its own page)</a></li>')
    status = df.groupby(["case", "status"]).size().rename("runs").reset_index()
    title = command_title(argv)
    page = _PAGE.format(title=html.escape(title), prov=html.escape(prov),
                        sections="\n".join(sections), toc="\n".join(toc),
                        status=html_table(status), runs=file_links(written[:1]))
    written.append(write_text(out / "index.html", f"<!-- {html.escape(prov)} -->\n{page}"))
    return written + friction_files


def _published_tolerances(case: str) -> dict[str, float]:
    """q -> relative tolerance of a verification case's published values
    (`Case.published`); empty for another scene or one this install does not have."""
    try:
        published = make_case(case).published
    except Exception:  # noqa: BLE001 - a table from elsewhere: no verification section
        return {}
    return {q: float(p.tolerance) for q, p in published.items()}


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
body {{ font-family: sans-serif; max-width: 1200px; margin: 2em auto; padding: 0 1em;
       color: #222; }}
img {{ width: 100%; max-width: 1100px; height: auto; display: block; margin: 0.5em 0; }}
div.scroll {{ overflow-x: auto; max-width: 100%; margin-bottom: 1em; }}
table.t {{ border-collapse: collapse; font-size: 13px; }}
table.t td, table.t th {{ padding: 2px 8px; border-bottom: 1px solid #ddd; text-align: right;
                          white-space: nowrap; }}
table.t th {{ position: sticky; top: 0; background: #f4f4f4; }}
a.anchor {{ color: #bbb; text-decoration: none; font-size: 0.8em; }}
nav ul {{ margin: 0.2em 0; }}
.prov {{ font-size: 12px; color: #555; overflow-wrap: anywhere; }}
</style></head><body>
<h1>{title}</h1>
<p class="prov">{prov}</p>
<nav><h2 id="contents">Contents</h2><ul>
<li><a href="#runs">Runs</a></li>
{toc}
</ul></nav>
<h2 id="runs">Runs <a class="anchor" href="#runs">#</a></h2>
<p>Errors are relative norms against the exact solution. Stepping times are measured
apart from the error runs, serially, with nothing else running from the sweep: the
scheme's stepper prepared once (its set-up not timed), one warm-up call of its
<code>run</code> (JIT compilation before it; discarded, unless it took a second or more
without compiling: then it is the first timed call), then
the repeats with the garbage collector off: minimum, median and interquartile range.
Work-precision plots <code>step_s</code>, the stepping alone (samples at the first and
last step only); its tables also give <code>time_s</code>, the same run recording the
samples the error norms need. All runs: {runs}.</p>
{status}
{sections}
<hr><p class="prov">{prov}</p>
</body></html>
"""
