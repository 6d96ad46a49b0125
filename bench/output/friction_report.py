"""The study's friction part drawn from a saved table (`contact_bench.sweeps.study.
plan_friction`; `contact-bench study --part friction`): tables (CSV, Markdown, LaTeX),
figures and one page, `friction.html`, every file named `friction_*`.

- work-precision per frictional scene variant (rows tagged "friction-refine"): each error
  column the scene fills (its own reference quantities, e.g. the sliding block's
  `err_sliding_momentum`) and the friction work against the finest run of the same scheme
  (`contact_bench.sweeps.analysis.finest_run_error`), against the stepping time `step_s`:
  `friction_work_precision_<variant>[_<column>]`;
- stability in CFL against mu (rows tagged "friction-stability"): the largest stable CFL
  of each scheme at each mu (`contact_bench.sweeps.analysis.friction_stability_table`),
  `friction_stability_<variant>` (table and figure) and every run in
  `friction_stability_runs`;
- the schemes refused (a 'not applicable' row: no friction law, or none in this
  dimension) with their reasons: `friction_refused`.
"""

from __future__ import annotations

import html
from collections.abc import Sequence
from pathlib import Path

import pandas as pd
from matplotlib.figure import Figure

from contact_bench.harness.environment import provenance
from contact_bench.harness.io import write_text
from contact_bench.output.figures import (
    check_formats,
    friction_stability_figure,
    use_style,
    work_precision_figure,
)
from contact_bench.output.page import figure_block, file_links
from contact_bench.output.report import header, html_table, slug, write_tables
from contact_bench.sweeps import analysis
from contact_bench.sweeps.study import FRICTION_GROUPS, FRICTION_PARAM


def friction_rows(df: pd.DataFrame) -> pd.Series:
    """Which rows belong to the friction part (tagged with one of its groups)."""
    mask = pd.Series(False, index=df.index)
    for group in FRICTION_GROUPS:
        mask |= analysis.tagged(df, group)
    return mask


def only_friction_rows(df: pd.DataFrame) -> pd.Series:
    """Which rows belong to the friction part and to no other part of the study."""
    if "group" not in df:
        return pd.Series(False, index=df.index)
    tags = df["group"].astype("string").fillna("").str.split(";")
    return tags.map(lambda t: bool(t) and all(g in FRICTION_GROUPS for g in t)).astype(bool)


def write_friction_report(df: pd.DataFrame, out: str | Path,
                          argv: Sequence[str] | None = None,
                          fig_format: str | Sequence[str] = "png",
                          style: str | None = None) -> list[Path]:
    """The friction part's tables, figures and friction.html (module docstring) for the
    friction rows of df, into out; nothing when df has none."""
    formats = check_formats(fig_format)
    df = df[friction_rows(df)]
    if df.empty:
        return []
    out = Path(out)
    prov = provenance(argv)
    written: list[Path] = []
    parts: list[str] = []

    def figure(fig: Figure, stem: str) -> str:
        body, files = figure_block(fig, out, stem, formats, prov, stem)
        written.extend(files)
        return body

    def tables(tab: pd.DataFrame, stem: str) -> str:
        files = write_tables(tab, out, stem, prov)
        written.extend(files)
        return f"<p>tables: {file_links(files)}</p>" + html_table(tab)

    refine = analysis.finest_run_error(df[analysis.tagged(df, FRICTION_GROUPS[0])])
    stab = df[analysis.tagged(df, FRICTION_GROUPS[1])]
    with use_style(style):
        for case in dict.fromkeys(refine["case"]):
            rows = refine[refine["case"] == case]
            s = slug(case)
            for k, err in enumerate(analysis.error_columns(rows, analysis.FRICTION_WORK_ERROR)
                                    [::-1]):
                wp = analysis.work_precision(rows, err)
                if wp.empty:
                    continue
                stem = f"friction_work_precision_{s}" + ("" if k == 0 else f"_{slug(err)}")
                body = figure(work_precision_figure(wp, case, err), stem)
                parts.append(f"<h2>{html.escape(case)}: work-precision ({html.escape(header(err))}"
                             f" against stepping time)</h2>{body}"
                             + tables(wp.drop(columns=["case"]), stem))
        table = analysis.friction_stability_table(stab, FRICTION_PARAM)
        for case in dict.fromkeys(table["case"]):
            mine = table[table["case"] == case]
            stem = f"friction_stability_{slug(case)}"
            body = figure(friction_stability_figure(mine, case, FRICTION_PARAM), stem)
            parts.append(f"<h2>{html.escape(case)}: stability in CFL against "
                         f"{FRICTION_PARAM}</h2>{body}" + tables(mine.drop(columns=["case"]),
                                                                 stem))
    if not stab.empty:
        runs = analysis.stability_table(stab)
        parts.append("<h2>Every stability run</h2>" + tables(runs, "friction_stability_runs"))
    refused = df[df["status"] == "not applicable"][["case", "scheme", "notes"]]
    if not refused.empty:
        parts.append("<h2>Refused (not run)</h2>"
                     + tables(refused.drop_duplicates().reset_index(drop=True),
                              "friction_refused"))
    page = (f"<!DOCTYPE html>\n<!-- {html.escape(prov)} -->\n<html lang=\"en\"><head>"
            f"<meta charset=\"utf-8\"><title>friction part</title></head><body>"
            f"<h1>The study's friction part</h1><p>{html.escape(prov)}</p>"
            + "\n".join(parts) + "</body></html>\n")
    written.append(write_text(out / "friction.html", page))
    return written
