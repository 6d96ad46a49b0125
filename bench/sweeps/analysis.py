"""From a sweep table to the study's tables: work-precision, orders, stability, energy.

Everything here reads a saved table (`contact_bench.sweeps.sweep.load_table`); nothing is rerun.

- Work-precision: per scene, the chosen error against the serial stepping time
  `step_s` (the stepping alone, no recording beyond the scheme's own: what the scheme
  costs); one curve per scheme (and CFL) over its refinements; the Pareto front (no
  other run is both faster and more accurate) is marked. The table keeps `time_s`,
  the same run with the recording the error norms need, next to it. A scene without
  the chosen norm (a 2D/3D scene) is drawn on each error column it fills
  (`error_columns`: its reference quantities, `Case.quantities`).
- Convergence orders: least-squares slope of log error against log h over runs at a
  fixed CFL (dt proportional to h), and against log dt at the finest nx that has at
  least three dt; pairwise local orders between neighbouring refinements next to the
  fit; errors at the round-off floor (below `ROUNDOFF_FLOOR`) left out. Next to them
  the declared order (`Traits.order`, saved in each row) and, when the study measured
  it, the order away from impacts (`with_time_orders`).
- Stability: the class of each run ('stable', 'energy-growing' beyond the declared
  behaviour, 'blown up'); a map scheme x CFL holding the worst class per cell.
- Energy: drift, growth and final drift against the declared behaviour.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from contact_bench.harness.metrics import ERROR_COLUMNS

#: relative errors below this are at the round-off floor (about 1e6 machine epsilons)
ROUNDOFF_FLOOR = 1e-10
MIN_POINTS = 3
CLASS_RANK = {"stable": 0, "energy-growing": 1, "blown up": 2}


def _sig(x: float, digits: int = 3) -> float:
    if not (isinstance(x, float | int) and math.isfinite(x)) or x == 0:
        return x
    return round(x, digits - 1 - int(math.floor(math.log10(abs(x)))))


def tagged(df: pd.DataFrame, group: str) -> pd.Series:
    """Which rows carry the tag `group` in their ';'-separated `group` column (none
    without the column)."""
    if "group" not in df:
        return pd.Series(False, index=df.index)
    tags = df["group"].astype("string").fillna("").str.split(";")
    return tags.map(lambda t: group in t).astype(bool)


def select(df: pd.DataFrame, group: str) -> pd.DataFrame:
    """Rows tagged with `group` (`tagged`); all rows if none is."""
    if df.empty:
        return df
    mask = tagged(df, group)
    return df[mask] if mask.any() else df


def error_columns(df: pd.DataFrame, error: str = "err_u_linf_l2") -> list[str]:
    """The error columns a scene's rows fill (ok rows, finite values): `error` first
    when filled, then every other `err_` column a scene's reference quantities give
    (`Case.quantities`: err_free_fall, err_peak_force, ...). Empty: none."""
    ok = df[df["status"] == "ok"] if "status" in df else df

    def filled(col: str) -> bool:
        return col in ok and bool(np.isfinite(pd.to_numeric(ok[col], errors="coerce")
                                              .astype(float)).any())

    others = [c for c in df.columns if str(c).startswith("err_") and c != error
              and c not in ERROR_COLUMNS]
    return [c for c in (error, *others) if filled(c)]


# ------------------------------------------------------------------- order fits


@dataclass
class OrderFit:
    """Least-squares slope of log err against log x, and the pairwise local orders."""

    order: float
    intercept: float
    n_used: int
    n_dropped: int
    x: np.ndarray  # used points, decreasing x
    err: np.ndarray
    local: np.ndarray  # local[i]: order between x[i] and x[i + 1]


def fit_order(x: np.ndarray | list[float], err: np.ndarray | list[float],
              floor: float = ROUNDOFF_FLOOR) -> OrderFit:
    """Fit err ~ C x^p on the points above the round-off floor (p = NaN if < 2 points)."""
    x = np.asarray(x, float)
    err = np.asarray(err, float)
    ok = np.isfinite(x) & np.isfinite(err) & (x > 0) & (err > floor)
    n_dropped = int((~ok).sum())
    xs, es = x[ok], err[ok]
    order_idx = np.argsort(-xs, kind="stable")
    xs, es = xs[order_idx], es[order_idx]
    if np.unique(xs).size < 2:
        return OrderFit(math.nan, math.nan, int(xs.size), n_dropped, xs, es, np.array([]))
    lx, le = np.log(xs), np.log(es)
    p, c = np.polyfit(lx, le, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        local = np.diff(le) / np.diff(lx)
    return OrderFit(float(p), float(c), int(xs.size), n_dropped, xs, es, local)


def _ok(df: pd.DataFrame, error: str) -> pd.DataFrame:
    if error not in df:
        raise KeyError(f"no column {error!r} in the table")
    return df[(df["status"] == "ok") & np.isfinite(df[error].astype(float))]


def _t_key(T: pd.Series) -> pd.Series:
    return T.astype(float).map(lambda v: _sig(v, 2))


def convergence_table(df: pd.DataFrame, error: str = "err_u_linf_l2",
                      floor: float = ROUNDOFF_FLOOR,
                      against: tuple[str, ...] = ("h", "dt")) -> pd.DataFrame:
    """Orders against h (fixed CFL, dt proportional to h) and dt (finest nx with >= 3 dt)."""
    ok = _ok(df, error).copy()
    out = []
    if ok.empty:
        return pd.DataFrame(columns=["case", "scheme", "against", "at", "T", "points", "order",
                                     "local orders", "declared order", "floor points", "error"])
    ok["_T"] = _t_key(ok["T"])
    ok["_cfl"] = ok["cfl"].map(lambda v: _sig(float(v), 3))
    for (case, scheme, T, cfl), g in ok.groupby(["case", "scheme", "_T", "_cfl"], sort=False):
        if "h" in against and g["nx"].nunique() >= MIN_POINTS:
            g = g.drop_duplicates("nx")
            out.append(_fit_row(case, scheme, "h", f"CFL = {cfl:g}", T, g["h"], g[error], g,
                                error, floor))
    for (case, scheme, T), g in ok.groupby(["case", "scheme", "_T"], sort=False):
        counts = g.groupby("nx")["dt"].nunique()
        good = counts[counts >= MIN_POINTS]
        if "dt" not in against or good.empty:
            continue
        nx = int(good.index.max())
        gg = g[g["nx"] == nx].drop_duplicates("dt")
        out.append(_fit_row(case, scheme, "dt", f"nx = {nx}", T, gg["dt"], gg[error], gg,
                            error, floor))
    return pd.DataFrame(out)


def _fit_row(case: str, scheme: str, against: str, at: str, T: float, x: pd.Series,
             err: pd.Series, g: pd.DataFrame, error: str, floor: float) -> dict:
    fit = fit_order(x.to_numpy(float), err.to_numpy(float), floor)
    declared = g["order_declared"].dropna()
    return {
        "case": case, "scheme": scheme, "against": against, "at": at, "T": T,
        "points": fit.n_used, "order": fit.order,
        "local orders": " ".join("n/a" if not math.isfinite(v) else f"{v:.2f}"
                                 for v in fit.local),
        "declared order": int(declared.iloc[0]) if len(declared) else None,
        "floor points": fit.n_dropped, "error": error,
    }


def with_time_orders(conv: pd.DataFrame, time_orders: pd.DataFrame | None) -> pd.DataFrame:
    """The convergence table with the order measured away from impacts
    (`contact_bench.sweeps.time_order.time_order_table`, column "measured order") as a
    "smooth order" column next to "declared order", matched on the scheme spec."""
    if time_orders is None or time_orders.empty or conv.empty:
        return conv
    smooth = time_orders.drop_duplicates("scheme").set_index("scheme")["measured order"]
    out = conv.copy()
    at = list(out.columns).index("declared order") + 1
    out.insert(at, "smooth order", out["scheme"].map(smooth).astype(float))
    return out


# -------------------------------------------------------------- work-precision


def pareto_mask(time_s: np.ndarray, err: np.ndarray) -> np.ndarray:
    """True for the points no other point beats in both time and error."""
    time_s, err = np.asarray(time_s, float), np.asarray(err, float)
    mask = np.zeros(time_s.size, bool)
    best = math.inf
    for i in np.lexsort((err, time_s)):
        if err[i] < best:
            mask[i] = True
            best = err[i]
    return mask


#: the time work-precision compares (module docstring)
WP_TIME = "step_s"


def work_precision(df: pd.DataFrame, error: str = "err_u_linf_l2") -> pd.DataFrame:
    """Timed ok runs with their error; `curve` names the line, `pareto` marks the front
    over `step_s` (`WP_TIME`); `time_s` (the run with its recording) is kept beside it."""
    ok = _ok(df, error)
    if WP_TIME not in ok:  # a table from before step_s: nothing to compare
        ok = ok.assign(**{WP_TIME: np.nan})
    if "time_s" not in ok:
        ok = ok.assign(time_s=np.nan)
    ok = ok[np.isfinite(ok[WP_TIME].astype(float))].copy()
    cols = ["case", "curve", "scheme", "nx", "dt", "cfl", error, WP_TIME, "time_s", "pareto"]
    cols += [c for c in ("step_median_s", "step_iqr_s", "step_repeats", "step_noisy",
                         "time_median_s", "time_iqr_s", "time_repeats", "time_noisy")
             if c in df.columns]  # the spread of the repeats, and the flag of a noisy one
    if ok.empty:
        return pd.DataFrame(columns=cols)
    ok["_cfl"] = ok["cfl"].map(lambda v: _sig(float(v), 2))
    n_cfl = ok.groupby(["case", "scheme"])["_cfl"].transform("nunique")
    ok["curve"] = [s if n == 1 else f"{s} (CFL {c:g})"
                   for s, n, c in zip(ok["scheme"], n_cfl, ok["_cfl"], strict=True)]
    parts = []
    for _, g in ok.groupby("case", sort=False):
        g = g.copy()
        g["pareto"] = pareto_mask(g[WP_TIME].to_numpy(), g[error].to_numpy())
        parts.append(g.sort_values(["curve", WP_TIME]))
    return pd.concat(parts)[cols].reset_index(drop=True)


# ------------------------------------------------------------------- stability


def stability_table(df: pd.DataFrame) -> pd.DataFrame:
    """One line per run that ran: its class, and the blow-up time when it blew up."""
    rows = df[df["stability"].notna()]
    cols = ["case", "scheme", "nx", "cfl", "cfl_limit", "T", "stability", "blowup_time",
            "energy_trait", "energy_growth_max", "energy_drift_bound"]
    return rows[cols].sort_values(["case", "scheme", "cfl"]).reset_index(drop=True)


def stability_map(df: pd.DataFrame, case: str) -> pd.DataFrame:
    """Scheme x CFL for one scene: the worst class over the runs of each cell."""
    rows = df[(df["case"] == case) & df["stability"].notna()].copy()
    if rows.empty:
        return pd.DataFrame()
    rows["CFL"] = rows["cfl"].map(lambda v: _sig(float(v), 2))
    rows["_rank"] = rows["stability"].map(CLASS_RANK)
    worst = rows.groupby(["scheme", "CFL"], sort=False)["_rank"].max()
    inv = {v: k for k, v in CLASS_RANK.items()}
    table = worst.map(inv).unstack("CFL")
    table = table[sorted(table.columns)]
    return table.loc[list(dict.fromkeys(rows["scheme"]))]


def parameter_maps(df: pd.DataFrame, case: str) -> dict[tuple[str, str], pd.DataFrame]:
    """For one scene, each scheme parameter declaring a sweep (`Param.sweep`, e.g. a
    penalty parameter) that the stability rows vary: (scheme name, parameter) -> the
    worst class of the runs at each (parameter value, CFL), values as rows. Only
    parameters with at least two values, each run at two CFL or more."""
    from contact_bench.api.registry import make_scheme

    rows = df[(df["case"] == case) & df["stability"].notna()].copy()
    if rows.empty:
        return {}
    rows["CFL"] = rows["cfl"].map(lambda v: _sig(float(v), 2))
    rows["_rank"] = rows["stability"].map(CLASS_RANK)
    found: dict[tuple[str, str], list[tuple[Any, float, int]]] = {}
    for spec, g in rows.groupby("scheme", sort=False):
        try:
            scheme = make_scheme(spec)
        except Exception:  # noqa: BLE001 - a plugin no longer registered: not mapped
            continue
        for pname, param in type(scheme).params.items():
            if param.sweep:
                key = (type(scheme).name, pname)
                value = getattr(scheme, pname)
                found.setdefault(key, []).extend(
                    (value, c, r) for c, r in zip(g["CFL"], g["_rank"], strict=True))
    inv = {v: k for k, v in CLASS_RANK.items()}
    out = {}
    for key, cells in found.items():
        t = pd.DataFrame(cells, columns=[key[1], "CFL", "_rank"])
        worst = t.groupby([key[1], "CFL"])["_rank"].max().map(inv).unstack("CFL")
        if len(worst.index) >= 2 and worst.notna().sum(axis=1).min() >= 2:
            out[key] = worst[sorted(worst.columns)].sort_index()
    return out


# ---------------------------------------------------------------------- energy


def energy_table(df: pd.DataFrame) -> pd.DataFrame:
    """Drift max |E - E0|/|E0|, growth max (E - E0)/|E0|, final drift, against the claim."""
    rows = df[df["status"].isin(["ok", "unstable"]) & df["energy_initial"].notna()].copy()
    cols = ["case", "scheme", "nx", "cfl", "T", "energy_trait", "energy_drift_bound",
            "energy_drift_max", "energy_growth_max", "energy_final_drift", "stability"]
    if rows.empty:
        return pd.DataFrame(columns=cols)
    E0 = rows["energy_initial"].astype(float)
    scale = E0.abs().where(E0 != 0, 1.0)
    rows["energy_final_drift"] = (rows["energy_final"].astype(float) - E0) / scale
    return rows[cols].sort_values(["case", "scheme", "nx"]).reset_index(drop=True)


def energy_trace(row: pd.Series) -> tuple[np.ndarray, np.ndarray] | None:
    """The stored (t, E(t)) of a row, or None."""
    raw = row.get("energy_trace")
    if not isinstance(raw, str) or not raw:
        return None
    data = json.loads(raw)
    t = np.array([np.nan if v is None else v for v in data["t"]], float)
    E = np.array([np.nan if v is None else v for v in data["E"]], float)
    return t, E


def verification_table(df: pd.DataFrame, tolerances: dict[str, float]) -> pd.DataFrame:
    """A verification case's rows (group "verification": every scheme once at the case's
    published grid) as scheme, status, err_published_<q> for each published quantity q,
    and `within`: how many of the errors the run has are within q's published tolerance
    (`tolerances`: q -> relative tolerance, `Case.published`), e.g. "4/5". Empty: the
    table has no such rows."""
    rows = df[tagged(df, "verification")]
    if rows.empty:
        return pd.DataFrame()
    cols = [f"err_published_{q}" for q in tolerances if f"err_published_{q}" in rows]
    out = rows[["scheme", "status", *cols]].copy()

    def within(r: pd.Series) -> str:
        have = [(q, r[f"err_published_{q}"]) for q in tolerances
                if f"err_published_{q}" in r and pd.notna(r[f"err_published_{q}"])]
        ok = sum(1 for q, e in have if float(e) <= tolerances[q])
        return f"{ok}/{len(tolerances)}" if r["status"] == "ok" else ""
    out["within"] = rows.apply(within, axis=1)
    return out.sort_values("scheme").reset_index(drop=True)


# --------------------------------------------------------------------- friction

#: the column `finest_run_error` adds: the friction work against the finest run
FRICTION_WORK_ERROR = "err_friction_work_finest"


def without_param(spec: str, name: str) -> str:
    """The canonical scene spec with its parameter `name` back at its default (the friction
    part's stability rows of one variant, whatever their mu); the spec itself when it does
    not parse."""
    from contact_bench.api.params import parse_spec
    from contact_bench.api.registry import make_case

    try:
        base, params = parse_spec(spec)
        params.pop(name, None)
        inner = ",".join(f"{k}={v}" for k, v in params.items())
        return make_case(f"{base}[{inner}]" if inner else base).spec
    except Exception:  # noqa: BLE001 - a scene no longer registered: its spec as it is
        return spec


def finest_run_error(df: pd.DataFrame) -> pd.DataFrame:
    """df with `FRICTION_WORK_ERROR`: |W - W_f| / |W_f|, W the run's `friction_work` and
    W_f that of the finest ok run (largest nx) of the same scene, scheme and CFL; NaN for
    the finest run itself, a run without W and a W_f of 0. The error a scene without an
    exact friction quantity still has (a self-convergence error)."""
    out = df.copy()
    out[FRICTION_WORK_ERROR] = np.nan
    if "friction_work" not in out or out.empty:
        return out
    W = pd.to_numeric(out["friction_work"], errors="coerce").astype(float)
    ok = (out["status"] == "ok") & np.isfinite(W)
    key = out["cfl"].astype(float).map(lambda v: _sig(v, 3))
    for _, g in out[ok].groupby([out["case"], out["scheme"], key], sort=False):
        finest = g["nx"].astype(int).idxmax()
        wf = float(W[finest])
        if wf == 0.0:
            continue
        rest = g.index[g.index != finest]
        out.loc[rest, FRICTION_WORK_ERROR] = (W[rest] - wf).abs() / abs(wf)
    return out


def friction_stability_table(df: pd.DataFrame, param: str = "mu") -> pd.DataFrame:
    """The friction part's stability in CFL against mu: one row per (scene variant, its
    `param` aside; scheme; value of `param`) of the rows tagged "friction-stability".
    Columns: the runs and the CFL tried; `largest_stable_cfl`, the largest CFL whose run
    and every run at a smaller CFL are 'stable' (NaN: none is); `first_unstable_cfl` and
    `first_unstable_class`, the smallest CFL whose run is not stable and its class
    ('energy-growing', 'blown up', or 'error' for a run that failed: its notes say why);
    `all_stable`; the declared CFL limit."""
    from contact_bench.api.registry import make_case

    cols = ["case", "scheme", param, "nx", "T", "runs", "cfl_tried", "largest_stable_cfl",
            "first_unstable_cfl", "first_unstable_class", "all_stable", "cfl_limit"]
    rows = df[tagged(df, "friction-stability") & (df["status"] != "not applicable")]
    if rows.empty:
        return pd.DataFrame(columns=cols)
    values = {}
    for spec in dict.fromkeys(rows["case"]):
        try:
            values[spec] = float(getattr(make_case(spec), param))
        except Exception:  # noqa: BLE001 - a scene no longer registered: no value
            values[spec] = math.nan
    rows = rows.assign(_family=rows["case"].map(lambda s: without_param(s, param)),
                       _value=rows["case"].map(values),
                       _class=[("error" if st == "error" else c) for st, c in
                               zip(rows["status"], rows["stability"], strict=True)])
    out = []
    for (family, scheme, value), g in rows.groupby(["_family", "scheme", "_value"],
                                                   sort=False, dropna=False):
        g = g.sort_values("cfl")
        cfl = g["cfl"].astype(float).to_numpy()
        bad = (g["_class"] != "stable").to_numpy()
        first = int(np.argmax(bad)) if bad.any() else None
        largest = (cfl[first - 1] if first else math.nan) if first is not None else cfl[-1]
        lim = pd.to_numeric(g["cfl_limit"], errors="coerce").dropna()
        out.append({
            "case": family, "scheme": scheme, param: value, "nx": int(g["nx"].iloc[0]),
            "T": float(g["T"].iloc[0]), "runs": len(g),
            "cfl_tried": " ".join(f"{_sig(c, 3):g}" for c in cfl),
            "largest_stable_cfl": float(largest),
            "first_unstable_cfl": math.nan if first is None else float(cfl[first]),
            "first_unstable_class": "" if first is None else str(g["_class"].iloc[first]),
            "all_stable": first is None,
            "cfl_limit": float(lim.iloc[0]) if len(lim) else math.nan})
    return pd.DataFrame(out, columns=cols).sort_values(
        ["case", "scheme", param]).reset_index(drop=True)
