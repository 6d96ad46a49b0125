"""Figures, tables, the HTML page and sweep timings for print: formats and
metadata, distinct curve styles, legends outside, readable tables, option checks before
anything is written, min/median/IQR timings and --retime, the page in headless Chromium."""

from __future__ import annotations

import json
import shutil
import subprocess
import warnings

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from contact_bench.cli.main import main
from contact_bench.core.errors import BenchError
from contact_bench.output import figures
from contact_bench.output.report import check_report_options, to_latex, write_report
from contact_bench.sweeps.cache import Cache
from contact_bench.sweeps.study import plan_study
from contact_bench.sweeps.sweep import (
    NOISY_SPREAD,
    load_table,
    plan,
    read_provenance,
    run_sweep,
    save_table,
    timing_stats,
)

PROV = "made by `contact-bench test` on a test day; git 0 (dirty)"


@pytest.fixture(scope="module")
def study_table() -> pd.DataFrame:
    """A quick study of two schemes on clamped_bar (a few seconds)."""
    tasks = plan_study(quick=True, scheme_specs=["standard", "redistributed[beta=0]"],
                       case_specs=["clamped_bar"])
    return run_sweep(tasks, repeats=2, quiet=True).table


# ------------------------------------------------------------------- figures


def test_twenty_schemes_get_twenty_distinct_looks():
    looks = [tuple(figures.line_style(i).values()) for i in range(70)]
    assert len(set(looks[:20])) == 20 and len(set(looks)) == 70
    # colour and marker alone already differ for 70 curves (tab10 repeats after 10)
    assert len({(lk[0], lk[1]) for lk in looks}) == 70


def test_save_figure_formats_and_metadata_not_drawn(tmp_path):
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1], label="a")
    assert not fig.texts
    files = figures.save_figure(fig, tmp_path / "f", ["png", "pdf", "svg"], PROV)
    names = [p.name for p in files]
    assert names == ["f.png", "f.pdf", "f.svg", "f.fig.json"]
    from PIL import Image

    with Image.open(tmp_path / "f.png") as im:
        assert im.info["Description"] == PROV
        assert round(im.info["dpi"][0]) == figures.PNG_DPI
    assert b"contact-bench test" in (tmp_path / "f.pdf").read_bytes()
    assert "contact-bench test" in (tmp_path / "f.svg").read_text()
    side = json.loads((tmp_path / "f.fig.json").read_text())
    assert side["provenance"] == PROV and side["files"] == names[:3]
    with pytest.raises(BenchError, match="gif"):
        figures.check_formats("png,gif")


def _wp_frame() -> pd.DataFrame:
    rows = []
    for i in range(12):
        for k in range(3):
            rows.append({"curve": f"s{i}", "scheme": f"s{i}", "err_u_linf_l2": 0.1 / 2**k,
                         "time_s": (i + 1) * 1e-3 * 2**k, "pareto": k == 0 and i == 0})
    return pd.DataFrame(rows)


def test_legend_sits_outside_the_axes():
    fig = figures.work_precision_figure(_wp_frame(), "c", "err_u_linf_l2")
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    fig.canvas.draw()
    leg = ax.get_legend().get_window_extent()
    assert leg.x0 >= ax.get_window_extent().x1  # right of the data area
    styles = {(tuple(line.get_color()), line.get_marker(), line.get_linestyle())
              for line in ax.get_lines()[:12]}
    assert len(styles) == 12
    plt.close(fig)


def test_style_hook(tmp_path):
    style = tmp_path / "big.mplstyle"
    style.write_text("lines.linewidth: 7\n")
    with figures.use_style(str(style)):
        fig = figures.work_precision_figure(_wp_frame(), "c", "err_u_linf_l2")
    assert fig.axes[0].get_lines()[0].get_linewidth() == 1.2  # explicit lw wins
    plt.close(fig)
    with figures.use_style("ggplot"):
        fig = figures.energy_figure(pd.DataFrame({"scheme": []}), "c")
    assert fig is None  # no traces: no empty figure
    with pytest.raises(BenchError, match="nosuch"):
        figures.check_style("nosuch")


def test_convergence_figure_fits_the_order_and_draws_reference_slopes():
    h = 2.0 ** -np.arange(3, 7)
    refine = pd.DataFrame({"scheme": "two", "status": "ok", "h": h,
                           "err_u_linf_l2": 5 * h**2})
    dts = pd.DataFrame({"scheme": "one", "status": "ok", "dt": h, "err_u_linf_l2": 3 * h})
    fig = figures.convergence_figure(refine, dts, "c", "err_u_linf_l2")
    left, right = fig.axes
    labels = [t.get_text() for t in left.get_legend().get_texts()]
    assert "two (order 2.00)" in labels and "slope 1 (reference)" in labels
    assert "one (order 1.00)" in [t.get_text() for t in right.get_legend().get_texts()]
    assert left.get_xscale() == "log" and left.get_yscale() == "log"
    plt.close(fig)


def test_stability_figure_log_axis_limit_and_every_class():
    rows = pd.DataFrame({
        "scheme": ["a", "a", "a", "b", "b"], "cfl": [0.1, 0.5, 2.0, 1.0, 100.0],
        "cfl_limit": [0.577, 0.577, 0.577, None, None],
        "stability": ["stable", "energy-growing", "blown up", "stable", None]})
    fig = figures.stability_figure(rows, "c")
    ax = fig.axes[0]
    assert ax.get_xscale() == "log"
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert set(figures.CLASS_COLORS) | {"declared CFL limit"} == set(labels)
    limit_lines = [ln for ln in ax.get_lines() if list(ln.get_xdata()) == [0.577, 0.577]]
    assert len(limit_lines) == 1
    plt.close(fig)


def test_energy_figure_finest_or_all(study_table):
    from contact_bench.sweeps import analysis

    rows = analysis.select(study_table, "refine")
    finest = figures.energy_figure(rows, "clamped_bar", "finest")
    every = figures.energy_figure(rows, "clamped_bar", "all")
    assert len(finest.axes[0].get_lines()) == rows["scheme"].nunique()
    assert len(every.axes[0].get_lines()) == len(rows)
    plt.close(finest)
    plt.close(every)


# -------------------------------------------------------------------- tables


def test_latex_is_booktabs_with_readable_headers():
    df = pd.DataFrame({"scheme": ["a_b"], "err_u_linf_l2": [1.234e-3], "nx": [40],
                       "time_s": [0.5]})
    tex = to_latex(df)
    assert "\\toprule" in tex and "\\midrule" in tex and "\\bottomrule" in tex
    assert "a\\_b" in tex and "error u, Linf(L2) (rel.)" in tex
    assert "stepping time [s] (min)" in tex and "0.00123" in tex


def test_sweep_table_param_columns_and_provenance(tmp_path):
    res = run_sweep(plan(["clamped_bar"], ["redistributed[beta=[0.25,0]]", "penalty"], [8],
                         cfls=[0.5], T=0.5), repeats=0, quiet=True)
    df = res.table
    assert list(df["scheme_beta"][:2]) == [0.25, 0.0]
    assert list(df["scheme_variant"][:2]) == ["first_element_massless"] * 2
    assert df["scheme"].iloc[2] == "penalty" and df["scheme_gamma_p"].iloc[2] > 0
    assert pd.isna(df["scheme_gamma_p"].iloc[0]) and pd.isna(df["scheme_variant"].iloc[2])
    files = save_table(df, tmp_path / "sweep.csv", PROV)
    assert pd.read_csv(tmp_path / "sweep.csv").columns[0] == "group"  # plain CSV
    assert read_provenance(tmp_path / "sweep.csv") == PROV
    if any(p.suffix == ".parquet" for p in files):
        assert read_provenance(tmp_path / "sweep.parquet") == PROV
        back = load_table(tmp_path / "sweep.parquet")
        assert list(back["scheme_beta"][:2]) == ["0.25", "0.0"] or \
            list(back["scheme_beta"][:2]) == [0.25, 0.0]


# ------------------------------------------------------------------- timings


def test_timing_stats_min_median_iqr_and_noise_flag():
    st = timing_stats([1.0, 1.1, 1.2, 1.3, 5.0])
    assert st["time_s"] == 1.0 and st["time_median_s"] == 1.2
    assert st["time_iqr_s"] == pytest.approx(0.2) and st["time_repeats"] == 5
    assert st["time_noisy"] is (0.2 > NOISY_SPREAD * 1.2)
    quiet = timing_stats([1.0, 1.001, 1.002], name="step")
    assert set(quiet) == {"step_s", "step_median_s", "step_iqr_s", "step_repeats",
                          "step_noisy"}
    assert quiet["step_noisy"] is False
    assert timing_stats([2.0, 2.0, 4.0, 4.0])["time_noisy"] is True


def test_retime_measures_again_without_rerunning(tmp_path):
    tasks = plan(["clamped_bar"], ["standard", "penalty"], [8, 16], cfls=[0.5], T=1.0)
    cache = Cache(tmp_path / "cache")
    first = run_sweep(tasks, cache=cache, repeats=3, quiet=True)
    assert first.timed == 4
    t = first.table
    assert (t["time_s"] <= t["time_median_s"]).all() and (t["time_iqr_s"] >= 0).all()
    assert (t["time_repeats"] == 3).all() and t["time_noisy"].notna().all()
    again = run_sweep(tasks, cache=cache, repeats=3, quiet=True)
    assert (again.executed, again.timed) == (0, 0)
    assert np.array_equal(again.table["time_s"], t["time_s"])
    retimed = run_sweep(tasks, cache=cache, repeats=3, quiet=True, retime=True)
    assert (retimed.executed, retimed.cached, retimed.timed) == (0, 4, 4)
    pd.testing.assert_series_equal(retimed.table["err_u_linf_l2"], t["err_u_linf_l2"])


# -------------------------------------------------------------------- report


def test_report_of_a_run_table_has_no_empty_plot_nor_warnings(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--case", "clamped_bar", "--scheme", "standard", "--scheme", "penalty",
                 "--nx", "10", "--T", "1", "--quiet", "--out", str(out)]) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["report", str(out / "runs.csv"), "--out", str(tmp_path / "rep")]) == 0
    assert not list((tmp_path / "rep").glob("energy_*.png"))


def test_report_checks_options_before_writing(tmp_path, study_table):
    table = save_table(study_table, tmp_path / "sweep.csv")[0]
    for bad in (["--error", "BAD"], ["--fig-format", "png,gif"], ["--style", "nosuch"]):
        out = tmp_path / f"out{bad[0]}"
        assert main(["report", str(table), "--out", str(out), *bad]) == 2
        assert not out.exists()
    with pytest.raises(BenchError, match="energy-runs"):
        check_report_options(study_table, "err_u_linf_l2", "png", None, "some")


def test_report_formats_title_and_contents(tmp_path, study_table):
    out = tmp_path / "rep"
    argv = ["report", "sweep.csv", "--out", str(out), "--fig-format", "png,svg"]
    write_report(study_table, out, argv, fig_format="png,svg", energy_runs="all")
    page = (out / "index.html").read_text()
    assert f"<title>contact-bench report sweep.csv --out {out}" in page
    assert '<nav><h2 id="contents">' in page and 'href="#clamped_bar-convergence"' in page
    assert 'id="clamped_bar-convergence"' in page and 'class="scroll"' in page
    for stem in ("work_precision", "convergence", "stability", "energy"):
        assert (out / f"{stem}_clamped_bar.png").exists()
        assert (out / f"{stem}_clamped_bar.svg").exists()
        assert not (out / f"{stem}_clamped_bar.pdf").exists()
    runs = pd.read_csv(out / "runs.csv")
    assert "scheme_beta" in runs and "time_median_s" in runs


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(CHROMIUM is None, reason="needs chromium (Debian: apt-get install chromium)")
def test_page_renders_in_headless_chromium(tmp_path, study_table):
    """The documented check (docs/outputs.md): a screenshot of the page, not blank, and
    as wide as the window (wide tables scroll inside the page, not the page itself)."""
    out = tmp_path / "rep"
    write_report(study_table, out, ["report"])
    shot = tmp_path / "page.png"
    proc = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu",
                           "--hide-scrollbars", "--window-size=1280,2000",
                           f"--screenshot={shot}", (out / "index.html").as_uri()],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and shot.exists(), proc.stderr[-2000:]
    from PIL import Image

    with Image.open(shot) as im:
        assert im.size == (1280, 2000)
        pixels = np.asarray(im.convert("L"), float)
    assert pixels.std() > 10  # text and figures, not an empty page
    dark = (pixels < 128).mean()
    assert 0.001 < dark < 0.5


def test_work_precision_table_shows_the_spread_and_the_flag(study_table):
    from contact_bench.sweeps import analysis

    wp = analysis.work_precision(analysis.select(study_table, "refine"))
    assert {"time_median_s", "time_iqr_s", "time_repeats", "time_noisy"} <= set(wp.columns)
    assert (wp["time_repeats"] == 2).all()
