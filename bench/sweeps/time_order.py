"""The time order of a scheme measured on a smooth stretch, to set against `Traits.order`.

`Traits.order` is the order in dt a scheme expects away from impacts. `measure_time_order`
measures it the way diffrax's `test_ode_order` does: a smooth motion, several dt at a
fixed mesh, an error for each, the least-squares slope of log error against log dt
(`contact_bench.sweeps.analysis.fit_order`, points at the round-off floor left out).
docs/order.md describes the method and its choices.

The motion (`SmoothStretch`): a free-free bar of unit length, wave speed and density,
v0 = 0 and u0 = A (2 - b((x - x0) / w)) with the C-infinity bump b(y) = exp(1 - 1/(1 - y^2))
on (-1, 1), x0 = 0.6, w = 0.4: flat (u0 = 2A) on [0, 0.2], so the initial data meet the
equilibrium of a massless contact node (u0 = u1 without load) on any mesh with h <= 0.2,
and the end x = 0 stays above A > 0 until T: no contact is ever active (no impact, no
penalty or Nitsche force).

The error of a dt is its difference with the same scheme at dt / 2 on the same mesh
(the successive differences of a convergent sequence shrink like dt^p): the order is
that of the time stepping towards the scheme's own semi-discretisation (its mass matrix,
contact node and contact law), so no scheme needs a reference of its own, and no run is
taken at a dt so small that the round-off of a displacement-form Newmark step (which
grows as dt shrinks) matters. The difference is the largest, over the sample times
shared by all runs, of the displacements (relative to the finest run's largest |u|) and
of the velocities (relative to its largest |v|); a massless contact node's velocity is
left out (see `_samples`).

A scheme whose output does not change with dt at all (an adaptive integrator whose dt
only picks the sample times) has every difference at the round-off floor: `dt_free` is
then True and there is no order in dt to measure (it should declare None).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.plugin import BarCase, Scheme, Semidiscrete
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_scheme, schemes
from contact_bench.core.errors import BenchError
from contact_bench.sweeps.analysis import fit_order

if TYPE_CHECKING:
    import pandas as pd

#: elements of the fixed mesh, final time, number of dt, CFL c dt / h of the coarsest dt
NX = 8
T = 0.5
LEVELS = 5
CFL = 0.03
#: relative differences at or below this are round-off (runs of thousands of steps)
FLOOR = 1e-11
#: largest |measured - declared| counted as agreement
TOLERANCE = 0.3
AMPLITUDE, CENTER, WIDTH = 0.1, 0.6, 0.4


class SmoothStretch(BarCase):
    """A smooth free motion that never reaches the obstacle (see the module docstring)."""

    name = "smooth_stretch"
    summary = "free-free bar, a smooth bump on a rigid shift: no contact before T"
    L, rho, E, g = 1.0, 1.0, 1.0, 0.0
    far_end, u_L = "free", 0.0
    T, nx = T, NX

    def u0(self, x: np.ndarray) -> np.ndarray:
        y = (np.asarray(x, float) / self.L - CENTER) / WIDTH
        inside = np.abs(y) < 1.0
        bump = np.exp(1.0 - 1.0 / np.where(inside, 1.0 - y * y, 1.0))
        return AMPLITUDE * (2.0 - np.where(inside, bump, 0.0))


@dataclass(frozen=True)
class TimeOrder:
    """Errors against dt, the fitted order and what the scheme declares."""

    declared: int | None
    dt: np.ndarray  # decreasing
    error: np.ndarray  # relative difference of the run at each dt with the run at dt / 2
    order: float  # least-squares slope over the points above the floor (NaN: < 2 points)
    points: int  # points used in the fit
    local: np.ndarray  # orders between neighbouring dt (points above the floor)
    dt_free: bool  # every error at the floor: the output does not depend on dt
    min_contact_u: float  # smallest u(0, t) over all runs (> 0: no contact)
    problem: str | None = None  # a run that blew up or stopped early, else None

    @property
    def verdict(self) -> str:
        """'agrees', 'differs', 'dt only samples', 'no order declared' or 'run failed'."""
        if self.problem:
            return "run failed"
        if self.dt_free:
            return "dt only samples" if self.declared is None else "differs"
        if self.declared is None:
            return "no order declared"
        ok = math.isfinite(self.order) and abs(self.order - self.declared) <= TOLERANCE
        return "agrees" if ok and self.points >= 3 else "differs"

    def describe(self) -> str:
        errs = " ".join(f"{e:.2e}" for e in self.error)
        return (f"declared {self.declared}, measured {self.order:.2f} "
                f"({self.points} points; dt {self.dt[0]:.3g} .. {self.dt[-1]:.3g}; "
                f"errors {errs})")


def _samples(scheme: Scheme, semi: Semidiscrete, T_end: float, steps: int,
             stride: int) -> tuple[np.ndarray, np.ndarray, float, str]:
    """Displacement and velocity samples of one run, its smallest u(0, t), and what went
    wrong ('' if nothing).

    A massless contact node's velocity is a difference quotient the scheme reports, not
    part of the stepped state (e.g. the backward difference of `redistributed`, first
    order by construction): it is left out, its displacement is kept.
    """
    tr = scheme.integrate(semi, T_end / steps, steps, stride)
    problem = ""
    if tr.blowup_time is not None or tr.steps_done != steps:
        problem = f"{steps} steps: blow-up at t = {tr.blowup_time}, {tr.steps_done} steps done"
    V = np.asarray(tr.V, float)
    return (np.asarray(tr.U, float), V[:, 1:] if semi.massless else V,
            float(tr.min_contact_u), problem)


def measure_time_order(scheme: Scheme, nx: int = NX, levels: int = LEVELS,
                       cfl: float = CFL, case: BarCase | None = None) -> TimeOrder:
    """The scheme's order in dt on `SmoothStretch` or the given case, up to its T (see
    the module docstring).

    Runs at dt = T / (n0 2^k), k = 0 .. levels, with n0 the fewest steps keeping c dt / h
    at most `cfl` and at most half the scheme's declared stability limit, sampled every
    2^k steps, so that all are compared at the same n0 + 1 times; the error of dt_k
    (k < levels) is the difference of runs k and k + 1.
    """
    case = SmoothStretch() if case is None else case
    T_end = float(case.T)
    semi = discretise(case, mesh_nodes(case.L, nx), scheme.mass_kind())
    h, c = semi.hmin, semi.c_max
    dt_max = cfl * h / c
    limit = scheme.stability_limit(semi)
    if limit is not None:
        dt_max = min(dt_max, 0.5 * limit)
    n0 = math.ceil(T_end / dt_max - 1e-9)
    runs, problem, min_u = [], "", math.inf
    for k in range(levels + 1):
        U, V, low, bad = _samples(scheme, semi, T_end, n0 * 2**k, 2**k)
        runs.append((U, V))
        problem, min_u = problem or bad, min(min_u, low)
    scale_u = max(float(np.max(np.abs(runs[-1][0]))), 1e-300)
    scale_v = max(float(np.max(np.abs(runs[-1][1]))), 1e-300)
    dts, errors = [], []
    for k in range(levels):
        (U, V), (U2, V2) = runs[k], runs[k + 1]
        err = math.inf
        if not problem and U.shape == U2.shape:
            err = max(float(np.max(np.abs(U - U2))) / scale_u,
                      float(np.max(np.abs(V - V2))) / scale_v)
        dts.append(T_end / (n0 * 2**k))
        errors.append(err if math.isfinite(err) else math.inf)
    dt_arr, err_arr = np.array(dts), np.array(errors)
    fit = fit_order(dt_arr, err_arr, FLOOR)
    return TimeOrder(scheme.traits().order, dt_arr, err_arr, fit.order, fit.n_used, fit.local,
                     bool(np.all(err_arr <= FLOOR)), min_u, problem or None)


def scheme_variants() -> list[Scheme]:
    """Every registered scheme at its defaults and, one parameter at a time, at every
    other choice of a choice parameter and at the closed finite ends of a numeric range
    (where a declared order may change, e.g. gamma = 1); values a scheme refuses are
    left out. Read from the registry: a new scheme is included with no code."""
    out: dict[str, Scheme] = {}
    for _, cls in sorted(schemes().plugins.items()):
        tries: list[dict] = [{}]
        for key, p in cls.params.items():
            if p.choices is not None:
                tries += [{key: v} for v in p.choices if v != p.default]
            elif p.kind in (int, float):
                ends = [(p.low, p.low_open), (p.high, p.high_open)]
                tries += [{key: v} for v, is_open in ends
                          if v is not None and not is_open and v != p.default]
        for given in tries:
            try:
                scheme = cls(**given)
            except BenchError:  # a combination the scheme refuses
                continue
            out.setdefault(scheme.spec, scheme)
    return list(out.values())


def time_order_table(specs: Sequence[str]) -> pd.DataFrame:
    """One row per scheme spec: declared and measured order side by side.

    A spec that cannot be built or run, or a scheme that cannot run `SmoothStretch`,
    gets a row whose `notes` say why.
    """
    import pandas as pd

    rows = []
    for spec in dict.fromkeys(specs):
        row: dict = {"scheme": spec}
        try:
            scheme = make_scheme(spec)
            reason = scheme.cannot_run(SmoothStretch())
            if reason:
                row.update({"verdict": "not applicable", "notes": reason})
                rows.append(row)
                continue
            res = measure_time_order(scheme)
        except Exception as exc:  # noqa: BLE001 - a failure is a row, the table goes on
            row.update({"verdict": "run failed", "notes": str(exc).splitlines()[0]})
            rows.append(row)
            continue
        row.update({
            "declared order": res.declared,
            "measured order": res.order,
            "local orders": " ".join(f"{v:.2f}" for v in res.local),
            "points": res.points,
            "dt": f"{res.dt[0]:.3g} .. {res.dt[-1]:.3g}",
            "max error": float(np.max(res.error)),
            "verdict": res.verdict,
            "notes": res.problem or "",
        })
        rows.append(row)
    cols = ["scheme", "declared order", "measured order", "local orders", "points", "dt",
            "max error", "verdict", "notes"]
    return pd.DataFrame(rows, columns=cols)


if __name__ == "__main__":  # the table of docs/order.md
    table = time_order_table([s.spec for s in scheme_variants()])
    table["declared order"] = [("" if v is None or v != v else str(int(v)))
                               for v in table["declared order"]]
    table["measured order"] = [f"{v:.2f}" for v in table["measured order"]]
    table["max error"] = [f"{v:.3g}" for v in table["max error"]]
    print(table.drop(columns=["notes"]).to_markdown(index=False, disable_numparse=True))
