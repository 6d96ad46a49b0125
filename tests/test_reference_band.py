"""Work-precision and convergence figures against a converged reference shade the
errors below the reference's own estimated error: those are not resolved."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
import pytest

matplotlib.use("Agg")

from contact_bench.api.registry import make_case  # noqa: E402
from contact_bench.exact.converged import error_floor  # noqa: E402
from contact_bench.output.figures import (  # noqa: E402
    convergence_figure,
    floor_label,
    work_precision_figure,
)
from contact_bench.output.report import reference_floor  # noqa: E402

STORED = Path(__file__).resolve().parents[1] / "results" / "references" / "disc_drop.json"


def test_the_floor_is_the_stored_references_relative_error():
    stored = json.loads(STORED.read_text())
    case = make_case(stored["case"])
    peak = stored["scalars"]["peak_force"]
    assert error_floor(case, "err_peak_force") == pytest.approx(
        abs(peak["error"] / peak["value"]), rel=1e-15)
    assert error_floor(case, "err_force_history") == stored["force_history"]["error"]
    assert reference_floor(stored["case"], "err_peak_force") == error_floor(case, "err_peak_force")
    assert error_floor(case, "err_u_numerical") is None  # not against the stored reference
    assert error_floor(make_case("disc_drop[degree=2]"), "err_peak_force") is None  # another
    assert reference_floor("clamped_bar", "err_u_linf_l2") is None


def _extent(band, axis: int) -> tuple[float, float]:
    """(low, high) of a span along x (0) or y (1): a Rectangle or a Polygon."""
    if hasattr(band, "get_width"):
        lo = band.get_x() if axis == 0 else band.get_y()
        return lo, lo + (band.get_width() if axis == 0 else band.get_height())
    v = np.asarray(band.get_xy())[:, axis]
    return float(v.min()), float(v.max())


def _bands(ax) -> list:
    return [p for p in ax.patches if p.get_label().startswith("below the reference")]


def test_figures_shade_the_unresolved_errors():
    wp = pd.DataFrame({"curve": ["a", "a", "b", "b"], "err_peak_force": [1e-1, 1e-2, 3e-2, 1e-3],
                       "step_s": [1e-3, 4e-3, 2e-3, 9e-3],
                       "pareto": [True, True, False, True]})
    floor = 5e-3
    fig = work_precision_figure(wp, "disc", "err_peak_force", floor)
    ax = fig.axes[0]
    (band,) = _bands(ax)
    assert band.get_label() == floor_label(floor)
    lo, hi = _extent(band, 0)
    assert hi == pytest.approx(floor) and lo <= 1e-3
    assert floor_label(floor) in [t.get_text() for t in ax.get_legend().get_texts()]
    assert not _bands(work_precision_figure(wp, "disc", "err_peak_force").axes[0])
    rows = pd.DataFrame({"scheme": ["s"] * 3, "status": ["ok"] * 3, "h": [0.4, 0.2, 0.1],
                         "dt": [0.04, 0.02, 0.01], "err_peak_force": [0.1, 0.02, 0.004]})
    fig = convergence_figure(rows, rows, "disc", "err_peak_force", floor)
    for ax in fig.axes:
        (band,) = _bands(ax)
        lo, hi = _extent(band, 1)
        assert hi == pytest.approx(floor) and lo <= 0.004
