"""`contact-bench report`: tables (CSV, Markdown, LaTeX), PNG figures and one HTML page,
all drawn from a saved sweep table without recomputing anything.

Every file records the command, versions and date that made it (`provenance`): a
`#` line in CSV, an HTML comment in Markdown, a `%` line in LaTeX, PNG text metadata
plus a footer line, and the page's header.
"""

from __future__ import annotations

import html
import math
import re
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402

from contact_bench.core.errors import BenchError  # noqa: E402
from contact_bench.harness.environment import environment, provenance  # noqa: E402
from contact_bench.harness.io import atomic_write, write_text  # noqa: E402
from contact_bench.harness.metrics import ERROR_COLUMNS  # noqa: E402
from contact_bench.sweeps import analysis  # noqa: E402
from contact_bench.sweeps.sweep import STABILITY_CLASSES  # noqa: E402

CLASS_COLORS = {"stable": "#4daf4a", "energy-growing": "#ff7f00", "blown up": "#e41a1c"}
#: columns shown with 2 decimals (orders); other floats get 3 significant digits
DECIMAL_COLUMNS = {"order"}
INT_COLUMNS = {"nx", "points", "floor points", "declared order", "steps"}


def slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.-]+", "_", str(text)).strip("_")


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
    """Strings with sensible significant digits (3; orders with 2 decimals)."""
    out = df.copy()
    for col in out.columns:
        out[col] = [_fmt(v, str(col)) for v in out[col]]
    out.columns = [str(c) for c in out.columns]
    return out


_TEX = {"&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_", "{": r"\{", "}": r"\}",
        "~": r"\textasciitilde{}", "^": r"\textasciicircum{}", "\\": r"\textbackslash{}"}


def to_latex(df: pd.DataFrame) -> str:
    """A plain `tabular` (no packages needed) of the display strings."""
    shown = display(df)

    def esc(s: str) -> str:
        return "".join(_TEX.get(ch, ch) for ch in s)

    align = "".join("l" if shown[c].map(lambda s: bool(re.search("[A-Za-z]", s))
                                        and not re.fullmatch(r"[-+0-9.e]+", s)).any()
                    else "r" for c in shown.columns)
    lines = [f"\\begin{{tabular}}{{{align}}}", "\\hline",
             " & ".join(esc(c) for c in shown.columns) + r" \\", "\\hline"]
    lines += [" & ".join(esc(v) for v in row) + r" \\" for row in shown.itertuples(index=False)]
    lines += ["\\hline", "\\end{tabular}"]
    return "\n".join(lines) + "\n"


def write_tables(df: pd.DataFrame, out: Path, stem: str, prov: str) -> list[Path]:
    """stem.csv (4 significant digits), stem.md and stem.tex, each with its provenance."""
    csv = df.to_csv(index=False, float_format="%.4g")
    md = display(df).to_markdown(index=False) if not df.empty else "(no rows)"
    return [
        write_text(out / f"{stem}.csv", f"# {prov}\n{csv}"),
        write_text(out / f"{stem}.md", f"<!-- {prov} -->\n\n{md}\n"),
        write_text(out / f"{stem}.tex", f"% {prov}\n{to_latex(df)}"),
    ]


def _save(fig: plt.Figure, path: Path, prov: str) -> Path:
    short = prov.split(";")[0]
    fig.text(0.005, 0.003, short, fontsize=5, color="0.4", ha="left", va="bottom")
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png",
                                               metadata={"Description": prov,
                                                         "Software": "contact-bench"}))
    plt.close(fig)
    return path


# --------------------------------------------------------------------- figures


def work_precision_figure(wp: pd.DataFrame, case: str, error: str, path: Path,
                          prov: str) -> Path:
    """Error (x) against stepping time (y), log-log; one curve per scheme; Pareto front."""
    fig, ax = plt.subplots(figsize=(7, 5))
    colors = plt.cm.tab10(np.linspace(0, 1, 10))
    for i, (curve, g) in enumerate(wp.groupby("curve", sort=False)):
        g = g.sort_values("time_s")
        ax.loglog(g[error], g["time_s"], "o-", color=colors[i % 10], ms=4, lw=1, label=curve)
    front = wp[wp["pareto"]].sort_values("time_s")
    if not front.empty:
        ax.loglog(front[error], front["time_s"], "k:", lw=1)
        ax.scatter(front[error], front["time_s"], s=70, facecolors="none", edgecolors="k",
                   label="Pareto front", zorder=3)
    ax.set_xlabel(f"{error} (relative)")
    ax.set_ylabel("stepping time [s] (min of repeats, serial)")
    ax.set_title(f"work-precision: {case}")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    fig.tight_layout(rect=(0, 0.02, 1, 1))
    return _save(fig, path, prov)


def stability_figure(table: pd.DataFrame, case: str, path: Path, prov: str) -> Path:
    """Scheme x CFL, colour = class (white: not run)."""
    classes = list(CLASS_COLORS)
    codes = table.apply(lambda col: col.map(lambda v: classes.index(v) if v in classes
                                            else np.nan)).to_numpy(float)
    fig, ax = plt.subplots(figsize=(4.5 + 0.55 * table.shape[1],
                                    1.6 + 0.38 * max(1, table.shape[0])))
    cmap = ListedColormap([CLASS_COLORS[c] for c in classes]).with_extremes(bad="white")
    ax.imshow(np.ma.masked_invalid(codes), cmap=cmap, vmin=-0.5, vmax=len(classes) - 0.5,
              aspect="auto")
    ax.set_xticks(range(table.shape[1]), [f"{c:g}" for c in table.columns], rotation=60,
                  fontsize=7)
    ax.set_yticks(range(table.shape[0]), list(table.index), fontsize=7)
    ax.set_xlabel("CFL = c dt / h")
    ax.set_title(f"stability: {case}", fontsize=9)
    handles = [plt.Rectangle((0, 0), 1, 1, color=CLASS_COLORS[c]) for c in classes]
    ax.legend(handles, classes, fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1))
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    return _save(fig, path, prov)


def energy_figure(rows: pd.DataFrame, case: str, path: Path, prov: str) -> Path:
    """(E(t) - E(0)) / |E(0)| for one run per scheme (its finest energy run)."""
    fig, ax = plt.subplots(figsize=(9.5, 4.5))
    colors = plt.cm.tab10(np.linspace(0, 1, 10))
    for i, (scheme, g) in enumerate(rows.groupby("scheme", sort=False)):
        row = g.sort_values("nx").iloc[-1]
        tr = analysis.energy_trace(row)
        if tr is None:
            continue
        t, E = tr
        scale = abs(E[0]) if E[0] else 1.0
        rel = (E - E[0]) / scale
        ax.plot(t, rel, color=colors[i % 10], lw=1,
                label=f"{scheme} (nx {int(row['nx'])}, CFL {row['cfl']:.2g})")
    ax.set_yscale("symlog", linthresh=1e-4)
    ax.set_xlabel("t")
    ax.set_ylabel("(E(t) - E(0)) / |E(0)|")
    ax.set_title(f"energy: {case}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1))
    fig.tight_layout(rect=(0, 0.02, 1, 1))
    return _save(fig, path, prov)


# ------------------------------------------------------------------- validation

STATUSES = ("ok", "unstable", "error", "not applicable")
#: columns every row of a sweep fills, whatever its status (checked when the table has
#: them): an empty one means the row was cut short
ALWAYS_FILLED = ("case", "scheme", "status", "key", "run_date", *environment().keys())
#: columns that are > 0 / >= 0 wherever they hold a value
POSITIVE = ("nx", "h", "dt", "cfl", "T", "steps", "stride", "grading")
NON_NEGATIVE = (*ERROR_COLUMNS, "energy_drift_max", "penetration_max", "wall_s",
                "time_s", "run_s", "time_repeats", "dt_limit", "cfl_limit")
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
    always = [c for c in ALWAYS_FILLED if c in df.columns]
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


def _html_table(df: pd.DataFrame) -> str:
    if df.empty:
        return "<p><em>no rows</em></p>"
    return display(df).to_html(index=False, escape=True, border=0, classes="t")


def write_report(df: pd.DataFrame, out: str | Path, argv: Sequence[str] | None = None,
                 error: str = "err_u_linf_l2") -> list[Path]:
    """All tables, figures and index.html for the table df, into out (nothing written
    if the table is damaged: `check_table`)."""
    check_table(df)
    out = Path(out)
    prov = provenance(argv)
    written: list[Path] = []
    sections: list[str] = []

    def links(paths: list[Path]) -> str:
        return " ".join(f'<a href="{html.escape(p.name)}">{html.escape(p.suffix[1:])}</a>'
                        for p in paths)

    written += write_tables(df.drop(columns=["energy_trace"], errors="ignore"), out, "runs", prov)
    wp_all = analysis.work_precision(analysis.select(df, "refine"), error)
    conv_all = pd.concat([
        analysis.convergence_table(analysis.select(df, "refine"), error, against=("h",)),
        analysis.convergence_table(analysis.select(df, "dt"), error, against=("dt",))])
    energy_rows = analysis.select(df, "energy")
    energy_all = analysis.energy_table(energy_rows)
    stab_rows = analysis.select(df, "stability")
    for case in dict.fromkeys(df["case"]):
        s = slug(case)
        parts = [f"<h2>{html.escape(case)}</h2>"]
        wp = wp_all[wp_all["case"] == case]
        if not wp.empty:
            fig = work_precision_figure(wp, case, error, out / f"work_precision_{s}.png", prov)
            tabs = write_tables(wp.drop(columns=["case"]), out, f"work_precision_{s}", prov)
            written += [fig, *tabs]
            parts.append(f"<h3>Work-precision ({html.escape(error)} against stepping time)</h3>"
                         f'<img src="{fig.name}" alt="work-precision {html.escape(case)}">'
                         f"<p>tables: {links(tabs)}</p>" + _html_table(wp.drop(columns=["case"])))
        conv = conv_all[conv_all["case"] == case] if not conv_all.empty else conv_all
        if not conv.empty:
            tabs = write_tables(conv.drop(columns=["case"]), out, f"convergence_{s}", prov)
            written += tabs
            parts.append(f"<h3>Convergence orders ({html.escape(error)}; local orders between "
                         f"neighbouring refinements; round-off floor points left out)</h3>"
                         f"<p>tables: {links(tabs)}</p>"
                         + _html_table(conv.drop(columns=["case"])))
        smap = analysis.stability_map(stab_rows, case)
        if not smap.empty:
            fig = stability_figure(smap, case, out / f"stability_{s}.png", prov)
            tab_map = smap.reset_index().rename(columns=lambda c: c if c == "scheme"
                                                else f"CFL {c:g}")
            tabs = write_tables(tab_map, out, f"stability_map_{s}", prov)
            long = analysis.stability_table(stab_rows[stab_rows["case"] == case])
            tabs += write_tables(long.drop(columns=["case"]), out, f"stability_runs_{s}", prov)
            written += [fig, *tabs]
            parts.append("<h3>Stability (worst class per scheme and CFL)</h3>"
                         f'<img src="{fig.name}" alt="stability map {html.escape(case)}">'
                         f"<p>tables: {links(tabs)}</p>" + _html_table(tab_map))
        en = energy_all[energy_all["case"] == case]
        if not en.empty:
            fig = energy_figure(energy_rows[energy_rows["case"] == case], case,
                                out / f"energy_{s}.png", prov)
            tabs = write_tables(en.drop(columns=["case"]), out, f"energy_{s}", prov)
            written += [fig, *tabs]
            parts.append("<h3>Energy</h3>"
                         f'<img src="{fig.name}" alt="energy {html.escape(case)}">'
                         f"<p>tables: {links(tabs)}</p>" + _html_table(en.drop(columns=["case"])))
        sections.append("\n".join(parts))
    status = df.groupby(["case", "status"]).size().rename("runs").reset_index()
    page = _PAGE.format(prov=html.escape(prov), sections="\n".join(sections),
                        status=_html_table(status), runs=links(written[:3]))
    written.append(write_text(out / "index.html", f"<!-- {html.escape(prov)} -->\n{page}"))
    return written


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>contact-bench study</title>
<style>
body {{ font-family: sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }}
img {{ max-width: 100%; display: block; margin: 0.5em 0; }}
table.t {{ border-collapse: collapse; font-size: 12px; margin-bottom: 1em; }}
table.t td, table.t th {{ padding: 2px 8px; border-bottom: 1px solid #ddd; text-align: right; }}
.prov {{ font-size: 11px; color: #555; }}
</style></head><body>
<h1>contact-bench study</h1>
<p class="prov">{prov}</p>
<p>Errors are relative norms against the exact solution. Stepping times are measured
apart from the error runs, serially, with nothing else running from the sweep: one
discarded warm-up call of <code>scheme.integrate</code> (JIT compilation before it), then
the minimum of the repeats, garbage collector off. All runs: {runs}.</p>
{status}
{sections}
<hr><p class="prov">{prov}</p>
</body></html>
"""
