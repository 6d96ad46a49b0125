"""Figures for print: every plotting function returns its matplotlib Figure; `save_figure`
writes it in the asked formats with the provenance in the file's metadata and in a sidecar
JSON (nothing is drawn into the image).

- `contact_figure`: the scene's contact observable and contact stress (`Case.contact_label`,
  `Case.force_label`: u(0, t) on a bar, the smallest gap on a body) and the energy, against
  the exact ones (`run`);
- `work_precision_figure`, `convergence_figure` (error against h and dt, log-log, the
  fitted order in the legend, reference slopes), `stability_figure` (scheme x CFL on a
  log axis, every class in the legend, the declared limits drawn), `energy_figure`
  (relative energy drift of the finest run per scheme, or of all runs).

Lines are told apart by colour, marker and line style together (`line_style`): distinct
for 70 curves, so schemes do not share a look beyond tab10's 10 colours. Legends sit
outside the axes, and files are saved with a tight bounding box so they are not cut.
`use_style` applies a matplotlib style (a name of `plt.style.available` or a file).
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from contact_bench.core.errors import BenchError  # noqa: E402
from contact_bench.harness.io import atomic_write, write_text  # noqa: E402
from contact_bench.sweeps.analysis import WP_TIME, energy_trace, fit_order  # noqa: E402

FIG_FORMATS = ("png", "pdf", "svg")
PNG_DPI = 300
#: tab10, then markers (7: coprime with 10) and line styles: (colour, marker) pairs
#: repeat only after 70 curves, and the line style changes every 10
COLORS = tuple(plt.get_cmap("tab10")(i) for i in range(10))
MARKERS = ("o", "s", "^", "D", "v", "P", "X")
LINESTYLES = ("-", "--", "-.", ":")
CLASS_COLORS = {"stable": "#4daf4a", "energy-growing": "#ff7f00", "blown up": "#e41a1c",
                "not run (error / not applicable)": "#999999"}
CLASS_MARKERS = {"stable": "o", "energy-growing": "s", "blown up": "X",
                 "not run (error / not applicable)": "."}
LEGEND = {"loc": "upper left", "bbox_to_anchor": (1.02, 1.0), "borderaxespad": 0.0,
          "fontsize": 8, "frameon": False}


def line_style(i: int) -> dict[str, Any]:
    """The i-th curve's colour, marker and line style (see the module docstring)."""
    return {"color": COLORS[i % len(COLORS)], "marker": MARKERS[i % len(MARKERS)],
            "linestyle": LINESTYLES[(i // len(COLORS)) % len(LINESTYLES)]}


def check_formats(text: str | Sequence[str]) -> list[str]:
    """'png,pdf' -> ['png', 'pdf']; an unknown format is a BenchError naming it."""
    items = text.split(",") if isinstance(text, str) else list(text)
    out = [f.strip().lower().lstrip(".") for f in items if f.strip()]
    bad = [f for f in out if f not in FIG_FORMATS]
    if bad or not out:
        raise BenchError(f"--fig-format must be a comma-separated list of "
                         f"{', '.join(FIG_FORMATS)}; got {text!r}")
    return list(dict.fromkeys(out))


def check_style(style: str | None) -> str | None:
    """A matplotlib style name or an existing style file; else a BenchError."""
    if style is None:
        return None
    if style in plt.style.available or style in ("default", "classic") or Path(style).is_file():
        return style
    raise BenchError(f"--style must be a matplotlib style ({', '.join(plt.style.available[:6])}"
                     f", ...) or a style file; got {style!r}")


@contextmanager
def use_style(style: str | None) -> Iterator[None]:
    """Draw the figures inside this block with the given style (None: matplotlib's)."""
    if style is None:
        yield
        return
    with plt.style.context(check_style(style)):
        yield


def save_figure(fig: Figure, stem: str | Path, formats: Sequence[str] = ("png",),
                prov: str = "") -> list[Path]:
    """stem.<format> for each format (PNG at PNG_DPI), provenance in each file's
    metadata, plus stem.fig.json (provenance, the files and each panel's title and axis
    labels); closes the figure."""
    stem = Path(stem)
    panels = [{"title": ax.get_title(), "xlabel": ax.get_xlabel(), "ylabel": ax.get_ylabel()}
              for ax in fig.get_axes()]
    written: list[Path] = []
    meta = {"png": {"Description": prov, "Software": "contact-bench"},
            "pdf": {"Subject": prov, "Creator": "contact-bench"},
            "svg": {"Description": prov, "Creator": "contact-bench"}}
    try:
        for fmt in check_formats(list(formats)):
            path = stem.with_name(f"{stem.name}.{fmt}")
            kw = {"dpi": PNG_DPI} if fmt == "png" else {}

            def writer(tmp: str, fmt: str = fmt, kw: dict = kw) -> None:
                fig.savefig(tmp, format=fmt, metadata=meta[fmt], bbox_inches="tight", **kw)

            written.append(atomic_write(path, writer))
    finally:
        plt.close(fig)
    side = {"provenance": prov, "files": [p.name for p in written], "axes": panels}
    written.append(write_text(stem.with_name(f"{stem.name}.fig.json"),
                              json.dumps(side, indent=1) + "\n"))
    return written


def _plain_minor_ticks(ax: plt.Axes) -> None:
    """No labels on the minor ticks of log axes (they overlap over short decades)."""
    from matplotlib.ticker import NullFormatter

    for axis, scale in ((ax.xaxis, ax.get_xscale()), (ax.yaxis, ax.get_yscale())):
        if scale == "log":
            axis.set_minor_formatter(NullFormatter())


def _legend(ax: plt.Axes, **kw: Any) -> None:
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        ax.legend(handles, labels, **{**LEGEND, **kw})


# ------------------------------------------------------------------------ run


def contact_figure(runs: list, exact: Any, title: str, *, contact_label: str,
                   force_label: str) -> Figure:
    """Three panels: the contact observable (`Trajectory.contact_u`), the contact stress
    (axis clipped at 4x the exact minimum), relative energy drift (symlog); one line per
    scheme, legend outside. The first two panels' labels are the scene's
    (`Case.contact_label`, `Case.force_label`)."""
    fig, axes = plt.subplots(3, 1, figsize=(8, 8.5), sharex=True)
    runs = [r for r in runs if r.trajectory is not None]
    for i, run in enumerate(runs):
        tr = run.trajectory
        st = dict(line_style(i), lw=1, markevery=max(1, tr.t.size // 12), ms=4)
        label = run.row["scheme"]
        axes[0].plot(tr.t, tr.contact_u, label=label, **st)
        axes[1].plot(tr.t, tr.stress, label=label, **st)
        e0 = tr.energy[0] if tr.energy[0] != 0 else 1.0
        axes[2].plot(tr.t, (tr.energy - tr.energy[0]) / abs(e0), label=label, **st)
    if exact is not None and runs:
        t = np.linspace(0, max(r.trajectory.t[-1] for r in runs), 4001)
        axes[0].plot(t, exact.u(0.0, t), "k--", lw=1.2, label="exact")
        s_exact = exact.stress(t)
        axes[1].plot(t, s_exact, "k--", lw=1.2, label="exact")
        if s_exact.min() < 0:  # spikes of chattering schemes run off the axis
            axes[1].set_ylim(4.0 * s_exact.min(), -0.5 * s_exact.min())
    axes[0].set_ylabel(contact_label)
    axes[1].set_ylabel(force_label)
    axes[2].set_ylabel("(E(t) - E(0)) / |E(0)|")
    axes[2].set_yscale("symlog", linthresh=1e-5)
    axes[2].set_xlabel("t")
    axes[0].set_title(title)
    _legend(axes[0])
    for ax in axes:
        ax.grid(alpha=0.3)
    return fig


# ---------------------------------------------------------------------- study


#: how the band of errors a converged reference cannot resolve is drawn
FLOOR_STYLE = {"color": "0.8", "alpha": 0.6, "zorder": 0, "lw": 0}


def floor_label(floor: float) -> str:
    """The legend entry of the reference's error band."""
    return f"below the reference's estimated error ({floor:.2g}): not resolved"


def _floor_band(ax: plt.Axes, floor: float | None, axis: str) -> None:
    """Shade the errors below `floor` (the reference's estimated error) along `axis`
    ("x" or "y"), from the axis' lower end, and keep the floor in view."""
    if floor is None or not np.isfinite(floor) or floor <= 0.0:
        return
    lo, hi = ax.get_xlim() if axis == "x" else ax.get_ylim()
    lo, hi = min(lo, floor / 3.0), max(hi, floor * 3.0)
    span = ax.axvspan if axis == "x" else ax.axhspan
    span(lo, floor, label=floor_label(floor), **FLOOR_STYLE)
    (ax.set_xlim if axis == "x" else ax.set_ylim)(lo, hi)


def work_precision_figure(wp: pd.DataFrame, case: str, error: str,
                          floor: float | None = None) -> Figure:
    """Error (x) against stepping time (y), log-log; one curve per scheme; Pareto front.
    `floor`: the reference's estimated error when the error is against a converged
    reference (a shaded band: errors below it are not resolved)."""
    tcol = WP_TIME if WP_TIME in wp.columns else "time_s"  # a table from before step_s
    fig, ax = plt.subplots(figsize=(7, 4.8))
    for i, (curve, g) in enumerate(wp.groupby("curve", sort=False)):
        g = g.sort_values(tcol)
        ax.loglog(g[error], g[tcol], ms=5, lw=1.2, label=curve, **line_style(i))
    front = wp[wp["pareto"].astype(bool)].sort_values(tcol)
    if not front.empty:
        ax.loglog(front[error], front[tcol], "k:", lw=1)
        ax.scatter(front[error], front[tcol], s=90, facecolors="none", edgecolors="k",
                   label="Pareto front", zorder=3)
    _floor_band(ax, floor, "x")
    ax.set_xlabel(f"{error} (relative)")
    ax.set_ylabel(f"stepping time {tcol} [s]\n(stepping alone, no recording; min of repeats)")
    ax.set_title(f"work-precision: {case}")
    ax.grid(alpha=0.3, which="both")
    _plain_minor_ticks(ax)
    _legend(ax)
    return fig


def _fit(x: np.ndarray, e: np.ndarray) -> float:
    return fit_order(x, e).order


def convergence_figure(refine: pd.DataFrame, dts: pd.DataFrame, case: str,
                       error: str, floor: float | None = None) -> Figure:
    """Two log-log panels: error against h (refine runs, fixed CFL) and against dt (dt
    runs, fixed nx); one curve per scheme with its fitted order in the legend, and
    reference slopes 1 and 2 (grey) through the median point. `floor`: the reference's
    estimated error when the error is against a converged reference (a shaded band:
    errors below it are not resolved, and neither are orders fitted through them)."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6))
    names = list(dict.fromkeys([*refine.get("scheme", []), *dts.get("scheme", [])]))
    for ax, rows, xcol, xlabel in ((axes[0], refine, "h", "h (element size)"),
                                   (axes[1], dts, "dt", "dt (time step)")):
        pts: list[tuple[float, float]] = []
        ok = rows[(rows["status"] == "ok") & np.isfinite(rows[error].astype(float))] \
            if not rows.empty else rows
        for scheme, g in ok.groupby("scheme", sort=False):
            g = g.drop_duplicates(xcol).sort_values(xcol)
            if len(g) < 2:
                continue
            x, e = g[xcol].to_numpy(float), g[error].to_numpy(float)
            p = _fit(x, e)
            order = "n/a" if not np.isfinite(p) else f"{p:.2f}"
            ax.loglog(x, e, ms=5, lw=1.2, label=f"{scheme} (order {order})",
                      **line_style(names.index(scheme)))
            pts += list(zip(x, e, strict=True))
        if pts:
            xs, es = np.array(pts).T
            x0, e0 = np.exp(np.median(np.log(xs))), np.exp(np.median(np.log(es)))
            xr = np.array([xs.min(), xs.max()])
            for slope, ls in ((1, (0, (4, 2))), (2, (0, (1, 1)))):
                ax.loglog(xr, e0 * (xr / x0) ** slope, color="0.45", lw=1.4, linestyle=ls,
                          label=f"slope {slope} (reference)")
        else:
            ax.text(0.5, 0.5, "no runs", transform=ax.transAxes, ha="center", va="center")
        _floor_band(ax, floor, "y")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(f"{error} (relative)")
        ax.grid(alpha=0.3, which="both")
        _plain_minor_ticks(ax)
        _legend(ax, loc="upper center", bbox_to_anchor=(0.5, -0.16))
    axes[0].set_title(f"convergence in h: {case}")
    axes[1].set_title(f"convergence in dt: {case}")
    return fig


def stability_figure(rows: pd.DataFrame, case: str) -> Figure:
    """Each run of the stability study at its CFL (log axis), one row per scheme spec;
    marker and colour give its class; the declared CFL limit is a black bar."""
    specs = list(dict.fromkeys(rows["scheme"]))
    fig, ax = plt.subplots(figsize=(9, 1.4 + 0.32 * max(1, len(specs))))
    cls = rows["stability"].where(rows["stability"].notna(), "not run (error / not applicable)")
    y = rows["scheme"].map({s: i for i, s in enumerate(specs)})
    cfl = rows["cfl"].astype(float)
    for name, color in CLASS_COLORS.items():
        m = (cls == name) & np.isfinite(cfl) & (cfl > 0)
        ax.scatter(cfl[m], y[m], c=color, marker=CLASS_MARKERS[name], s=36, zorder=3,
                   edgecolors="k" if name != "not run (error / not applicable)" else "none",
                   linewidths=0.4)
    limits = rows.groupby("scheme", sort=False)["cfl_limit"].first()
    for s, lim in limits.items():
        if pd.notna(lim) and lim > 0:
            ax.plot([lim, lim], [specs.index(s) - 0.4, specs.index(s) + 0.4], color="k", lw=2,
                    zorder=4)
    handles = [Line2D([], [], ls="", marker=CLASS_MARKERS[n], color=c, markeredgecolor="k",
                      ms=7, label=n) for n, c in CLASS_COLORS.items()]
    handles.append(Line2D([], [], color="k", lw=2, label="declared CFL limit"))
    ax.legend(handles=handles, **LEGEND)
    ax.set_xscale("log")
    ax.set_yticks(range(len(specs)), specs, fontsize=8)
    ax.set_ylim(len(specs) - 0.5, -0.5)
    ax.set_xlabel("CFL = c dt / h (log scale)")
    _plain_minor_ticks(ax)
    ax.set_title(f"stability: {case}")
    ax.grid(alpha=0.3, which="both", axis="x")
    return fig


def energy_figure(rows: pd.DataFrame, case: str, which: str = "finest") -> Figure | None:
    """(E(t) - E(0)) / |E(0)| from the stored traces: the finest run per scheme
    (`which` = 'finest') or every run (`which` = 'all'); None when no row has a trace."""
    if which not in ("finest", "all"):
        raise BenchError(f"--energy-runs must be finest or all; got {which!r}")
    picked = []
    for scheme, g in rows.groupby("scheme", sort=False):
        g = g.sort_values("nx")
        for _, row in (g.iloc[[-1]] if which == "finest" else g).iterrows():
            tr = energy_trace(row)
            if tr is not None:
                picked.append((scheme, row, tr))
    if not picked:
        return None
    fig, ax = plt.subplots(figsize=(9, 4.6))
    for i, (scheme, row, (t, E)) in enumerate(picked):
        scale = abs(E[0]) if E[0] else 1.0
        ax.plot(t, (E - E[0]) / scale, lw=1, ms=4, markevery=max(1, t.size // 10),
                label=f"{scheme} (nx {int(row['nx'])}, CFL {float(row['cfl']):.2g})",
                **line_style(i))
    ax.set_yscale("symlog", linthresh=1e-4)
    ax.set_xlabel("t")
    ax.set_ylabel("(E(t) - E(0)) / |E(0)|")
    ax.set_title(f"energy: {case}")
    ax.grid(alpha=0.3)
    _legend(ax)
    return fig


def friction_stability_figure(table: pd.DataFrame, case: str, param: str = "mu") -> Figure:
    """The friction part's stability (`contact_bench.sweeps.analysis.
    friction_stability_table`, one scene variant): the largest stable CFL (log axis)
    against the friction coefficient, one curve per scheme; a hollow marker where every
    CFL tried was stable (the value is then only a lower bound)."""
    fig, ax = plt.subplots(figsize=(7, 4.8))
    for i, (scheme, g) in enumerate(table.groupby("scheme", sort=False)):
        g = g.sort_values(param)
        style = line_style(i)
        ax.semilogy(g[param], g["largest_stable_cfl"], ms=6, lw=1.2, label=scheme, **style)
        bound = g[g["all_stable"].astype(bool)]
        ax.scatter(bound[param], bound["largest_stable_cfl"], s=110, facecolors="none",
                   edgecolors=style["color"], zorder=3)
    ax.scatter([], [], s=110, facecolors="none", edgecolors="k",
               label="every CFL tried stable (lower bound)")
    ax.set_xlabel(f"friction coefficient {param}")
    ax.set_ylabel("largest stable CFL = c dt / h\n(every smaller CFL tried stable too)")
    ax.set_title(f"stability against friction: {case}")
    ax.grid(alpha=0.3, which="both")
    _legend(ax)
    return fig
