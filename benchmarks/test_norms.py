"""Cost of the error norms against the stepping, at each case's default sampling.

Issue #6: "error norms against exact solutions are computed vectorised and at the
default sampling cost no more than the stepping itself". Each benchmark times
`contact_bench.harness.metrics.error_metrics` on one run (the case's default stride, which is 1 for
the
default-run cases: every step is a sample) in two modes:

- cold: the first scheme on a (case, mesh, sample times): the quadrature is built, the
  reference evaluated at every quadrature point and the exact norms summed
  (`metrics.clear_cache()` before each round);
- warm: the next schemes on the same grid (the default run and `run_table` run every
  scheme of a case on the same grid), which reuse the quadrature and the exact norms
  and evaluate these fast references again (contact_bench.harness.metrics keeps the values of slow
  references only).

Each id fixes the work: the case, nx and dt (None: the case's default), so the number of
steps and samples. `extra_info` holds `n` (free dofs), `steps`, `ns_per_dof_step` (the
median norm time per dof and step), the stepping time of every registered scheme on the same
configuration (`scheme.integrate`, JIT excluded, median of 3: what the harness reports
as wall_s), the median norm time and `ratio` = norm time / stepping time for the
fastest scheme (`ratio_fastest`) and for `standard`.

    python -m pytest benchmarks/test_norms.py --benchmark-json=norms.json
    python benchmarks/summary.py norms.json
"""

from __future__ import annotations

import statistics
import time

import pytest

from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.harness import metrics
from contact_bench.harness.runner import reference, run_one

#: (case, nx, dt): the default run's two scenes at their defaults, and the clamped bar
#: at nx = 80, dt = 0.002 (6000 steps)
CONFIGS = [("clamped_bar", None, None), ("dropped_bar", None, None),
           ("clamped_bar", 80, 0.002)]


def _stepping(case: str, nx: int | None, dt: float | None, same_dt: float
              ) -> dict[str, float]:
    """Median stepping time of every scheme that runs this configuration with dt = same_dt
    (explicit schemes may lower the case's default dt: another grid of samples)."""
    out = {}
    for spec in schemes().names():
        run = run_one(case, spec, nx=nx, dt=dt)
        if run.row["status"] != "ok" or run.row["dt"] != same_dt:
            continue
        times = []
        for _ in range(3):
            start = time.perf_counter()
            make_scheme(spec).integrate(run.semi, run.row["dt"], run.row["steps"],
                                        run.row["stride"])
            times.append(time.perf_counter() - start)
        out[spec] = statistics.median(times)
    return out


def _config_id(config: tuple) -> str:
    """The work in the id: scene, nx, dt and T, defaults resolved (`CONFIGS`)."""
    name, nx, dt = config
    case = make_case(name)
    return f"{name}-nx{nx or case.nx}-dt{dt or case.dt:g}-T{case.T:g}"


@pytest.mark.parametrize("mode", ["cold", "warm"])
@pytest.mark.parametrize("config", CONFIGS, ids=_config_id)
def test_norms_vs_stepping(benchmark, config: tuple, mode: str) -> None:
    case_name, nx, dt = config
    run = run_one(case_name, "standard", nx=nx, dt=dt)
    case = make_case(case_name)
    exact = reference(case, run.row["T"])
    metrics.warm_up()
    args = (run.semi, run.trajectory, exact, case.provides)
    if mode == "warm":
        metrics.error_metrics(*args)  # the first scheme's evaluation, kept

        def setup() -> None:
            pass
    else:
        setup = metrics.clear_cache
    benchmark.pedantic(lambda: metrics.error_metrics(*args), setup=setup, rounds=7,
                       iterations=1, warmup_rounds=1)
    norm_s = benchmark.stats.stats.median
    stepping = _stepping(case_name, nx, dt, run.row["dt"])
    fastest = min(stepping, key=stepping.get)
    benchmark.extra_info.update(
        case=case_name, n=int(run.semi.nfree), steps=int(run.row["steps"]),
        ns_per_dof_step=norm_s / (run.semi.nfree * run.row["steps"]) * 1e9,
        nx=run.row["nx"], dt=run.row["dt"], stride=run.row["stride"],
        samples=int(run.trajectory.t.size), mode=mode, norm_s=norm_s,
        stepping_s={s: round(t, 6) for s, t in stepping.items()},
        fastest=fastest, ratio_fastest=norm_s / stepping[fastest],
        ratio_standard=norm_s / stepping["standard"])
