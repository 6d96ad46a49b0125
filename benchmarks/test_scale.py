"""Scale benchmarks: one step of the disc (P2) and the sphere (P1, P2), implicit and
explicit, from about 1e3 to 5e5 dofs (the configurations of benchmarks/scale.py).

    python -m pytest benchmarks/test_scale.py                        # every size
    python -m pytest benchmarks/test_scale.py --scale-max-dofs 2e4   # the small ones

Each id fixes its work (`label-nxN-dofsD-kind-stepsS`). The problem is built and the
stepper prepared outside the timing (`setup_s` in extra_info), the kernels compiled by a
first call; a round is `stepper.run(steps, steps)` (the stepping alone). extra_info:
`dofs`, `steps`, `step_s` (median round / steps), `setup_s` and its split
(`assembly_s`, `limit_s`, `prepare_s`, `factor_s`, `contact_s`), the solver floor
(`solve_s`, `step_per_solve`, `setup_per_factor`: `scale.floor`), `peak_MiB` (this
process's peak RSS, reset before the set-up) and `growth_MiB` (peak - the RSS at that
reset: what the set-up and the run added). In one process the heap of the earlier ids
may be reused, so `growth_MiB` can be below the fresh-process figure of
benchmarks/scale.py, which publishes the exponents (results/scale.md).
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import scale  # noqa: E402 - benchmarks/scale.py, the configurations and the measures


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    if "cfg" in metafunc.fixturenames:
        limit = metafunc.config.getoption("scale_max_dofs", default=None)
        chosen = scale.configs(float("inf") if limit is None else float(limit))
        metafunc.parametrize("cfg", chosen, ids=[c["id"] for c in chosen])


def test_step(benchmark, cfg: dict) -> None:
    try:
        scale.warm_up(cfg)  # JIT compilation, on the smallest mesh the scheme runs
    except Exception as exc:  # noqa: BLE001 - a size a scheme cannot run: skipped with why
        pytest.skip(f"{cfg['id']}: {type(exc).__name__}: {exc}")
    scale.forget()
    base = scale.reset_peak()
    split: dict = {}
    start = time.perf_counter()
    try:
        stepper, dofs, dt = scale.build(cfg, split=split)
    except Exception as exc:  # noqa: BLE001
        pytest.skip(f"{cfg['id']}: {type(exc).__name__}: {exc}")
    setup = time.perf_counter() - start
    steps = int(cfg["steps"])
    benchmark.pedantic(stepper.run, args=(steps, steps), rounds=3, iterations=1,
                       warmup_rounds=1)
    peak = scale.rss_mib("VmHWM")
    step = statistics.median(benchmark.stats.stats.data) / steps
    benchmark.extra_info.update(
        dofs=dofs, steps=steps, dt=dt, setup_s=setup, **split, peak_MiB=peak,
        growth_MiB=peak - base, step_s=step,
        **scale.floor(stepper, step, setup, split["factor_s"]))
