"""Stepping cost of every registered scheme, in ns per dof-step, and the speedup over scipy.

Each benchmark times `scheme.integrate(semi, dt, nsteps, stride)` on the clamped bar
(prepare + run; a bar's prepare makes little, its bands are factored inside the run):
assembly (`contact_bench.api.problem.discretise`) and JIT compilation (a one-step
`scheme.integrate` call) happen before the timing, the stride is the whole run (two
samples).

Every benchmark does a fixed unit of work, named in its id: the scene, n and the number
of steps (`steps_for`: STEPS[n], scaled down for the few schemes listed in SLOW), e.g.
`test_stepping[standard-clamped_bar-n1e3-steps50000]`. So two saved runs compared with
`pytest-benchmark compare` (or `--benchmark-compare-fail=median:10%`) time the same work
under the same name (docs/benchmarks.md). `extra_info` holds `n` (free dofs), `steps`,
`ns_per_dof_step` (median round / (n * steps)) and the run's error `err_u_linf_l2`
against the exact solution (`nfree`, `nsteps`: the same, for benchmarks/summary.py).

Before every round (`_new_heap_state`) a block of random size is allocated (the last 64
kept), so that the arrays a run allocates land elsewhere on the heap: at n = 1e3 their
placement alone moves a Newmark kernel from 0.62 to up to 1.4 ns per dof-step, the same
from round to round while the heap is unchanged (40 calls: 0.62-0.66 unchanged, 0.62-1.38
with the heap changed between calls). Without it every round of a benchmark repeated one
draw and its median was that draw's (the speedup over scipy at n = 1e3 moved from 36x to
56x between runs); with it the median is over heap states. New schemes are picked up from the
registry; a scheme that cannot run the clamped bar is skipped with its reason.

`test_sizes` covers the grids the study plots (n = 20, 40, 160, 640) and 1e3, 1e5, for
every scheme, with the stepping (`step`: stride = steps, samples at the first and last
step only) and the recording the error norms need (`rec1`: stride 1) as separate ids.
Each id is a fixed unit of work: n and steps are in the id (`SIZE_STEPS`, about 4e6
dof-steps per round; a hundredth for the adaptive integrator, `SLOW`), and
`extra_info` holds n, steps, stride and ns_per_dof_step (median round / (nfree * steps
done): a run that blows up stops early).
"""

from __future__ import annotations

import statistics
import time
from typing import Any

import numpy as np
import pytest

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.plugin import Scheme, Semidiscrete
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.harness.metrics import error_metrics
from contact_bench.harness.scipy_reference import reference_for

CASE = "clamped_bar"
MAIN = ["standard", "redistributed", "redistributed[beta=0]"]
EXTRA = ["taylor_flanagan[mass=lumped]"]  # non-default variants timed at 1e3 and 1e5 only
#: steps per round at each n: 5e7 dof-steps at 1e3 and 1e5 (0.03-0.3 s a round at
#: 0.6-5 ns per dof-step), 1e8 at 1e6 (the set-up, ~0.1 s, must not weigh in the median)
STEPS = {1_000: 50_000, 100_000: 500, 1_000_000: 100}
#: schemes two orders of magnitude slower per dof-step get a fixed fraction of STEPS
SLOW = {"ode_adaptive": 0.01}
N_ID = {1_000: "n1e3", 100_000: "n1e5", 1_000_000: "n1e6"}


def steps_for(spec: str, n: int) -> int:
    """The fixed number of steps of a benchmark (module docstring)."""
    return max(5, int(STEPS[n] * SLOW.get(spec.split("[")[0], 1.0)))


def _params(specs: list[str], ns: list[int]) -> list:
    """(spec, n, steps) with the id `spec-scene-nNeK-stepsS`: the work is in the name."""
    return [pytest.param(spec, n, steps_for(spec, n),
                         id=f"{spec}-{CASE}-{N_ID[n]}-steps{steps_for(spec, n)}")
            for spec in specs for n in ns]


def _specs() -> list[str]:
    names = list(schemes().plugins)
    return names + [s for s in MAIN + EXTRA if s not in names]


_HEAP: list[np.ndarray] = []
_HEAP_RNG = np.random.default_rng(2026)


def _new_heap_state() -> None:
    """Allocate a block of 8 B to 32 kB (the last 64 kept, older ones freed): the next
    run's arrays are placed elsewhere (module docstring)."""
    _HEAP.append(np.empty(int(_HEAP_RNG.integers(1, 4097))))
    del _HEAP[:-64]


def _rounds(semi: Semidiscrete, dt: float, nsteps: int
            ) -> tuple[tuple[Any, ...], dict[str, Any]]:
    """pytest-benchmark's per-round setup: a new heap state, then the run's arguments."""
    _new_heap_state()
    return (semi, dt, nsteps, nsteps), {}


def _setup(spec: str, n: int, steps: int) -> tuple[Scheme, Semidiscrete, float, int]:
    case = make_case(CASE)
    scheme = make_scheme(spec)
    reason = scheme.cannot_run(case) or case.cannot_run(scheme)
    if reason:
        pytest.skip(f"{spec} cannot run {CASE}: {reason}")
    semi = discretise(case, mesh_nodes(case.L, n), scheme.mass_kind())
    dt = 0.5 * semi.hmin / semi.c_max  # CFL 0.5
    limit = scheme.stability_limit(semi)
    if limit is not None:
        dt = min(dt, 0.9 * limit)
    # compile (or load the numba cache) outside the timing
    scheme.integrate(semi, 1e-3 * semi.hmin / semi.c_max, 1, 1)
    return scheme, semi, dt, steps


def _run(benchmark, spec: str, n: int, steps: int) -> None:
    scheme, semi, dt, nsteps = _setup(spec, n, steps)
    traj = benchmark.pedantic(scheme.integrate, setup=lambda: _rounds(semi, dt, nsteps),
                              rounds=5, iterations=1, warmup_rounds=1)
    case = make_case(CASE)
    err = error_metrics(semi, traj, case.exact(nsteps * dt), case.provides)["err_u_linf_l2"]
    median = benchmark.stats.stats.median
    benchmark.extra_info.update(
        scheme=scheme.spec, case=CASE, n=semi.nfree, steps=nsteps, nfree=semi.nfree,
        nsteps=nsteps, dt=dt, ns_per_dof_step=median / (semi.nfree * nsteps) * 1e9,
        err_u_linf_l2=err, blowup=traj.blowup_time is not None)


@pytest.mark.parametrize(("spec", "n", "steps"), _params(_specs(), [1_000, 100_000]))
def test_stepping(benchmark, spec: str, n: int, steps: int) -> None:
    _run(benchmark, spec, n, steps)


@pytest.mark.parametrize(("spec", "n", "steps"), _params(MAIN, [1_000_000]))
def test_stepping_1e6(benchmark, spec: str, n: int, steps: int) -> None:
    _run(benchmark, spec, n, steps)


@pytest.mark.parametrize(("spec", "n", "steps"), _params(MAIN, [1_000, 100_000]))
def test_speedup_over_scipy(benchmark, spec: str, n: int, steps: int) -> None:
    """Times the numba kernel (the benchmark, median of 11 rounds) and the scipy reference
    (median of 5), each round on a new heap state (module docstring): more rounds than
    the other benchmarks, as the ratio of two medians on this VM moved by 20% from run
    to run with 5 and 3."""
    scheme, semi, dt, nsteps = _setup(spec, n, steps)
    traj = benchmark.pedantic(scheme.integrate, setup=lambda: _rounds(semi, dt, nsteps),
                              rounds=11, iterations=1, warmup_rounds=1)
    ref_steps = max(5, nsteps // 100)
    times = []
    for _ in range(5):
        _new_heap_state()
        start = time.perf_counter()
        ref = reference_for(scheme, semi, dt, ref_steps, ref_steps)
        times.append(time.perf_counter() - start)
    kernel_ns = benchmark.stats.stats.median / (semi.nfree * nsteps) * 1e9
    ref_ns = statistics.median(times) / (semi.nfree * ref_steps) * 1e9
    short = scheme.integrate(semi, dt, ref_steps, ref_steps)
    benchmark.extra_info.update(
        scheme=scheme.spec, case=CASE, n=semi.nfree, steps=nsteps, nfree=semi.nfree,
        nsteps=nsteps, ref_steps=ref_steps,
        ns_per_dof_step=kernel_ns, scipy_ns_per_dof_step=ref_ns, speedup=ref_ns / kernel_ns,
        ref_rel_diff=float(np.abs(short.U - ref.U).max() / np.abs(ref.U).max()),
        blowup=traj.blowup_time is not None)


#: (n, steps) of `test_sizes`: ~4e6 dof-steps per round (4-40 ms at 1-10 ns per dof-step)
SIZE_STEPS = [(20, 200_000), (40, 100_000), (160, 25_000), (640, 6_250), (1_000, 4_000),
              (100_000, 40)]
#: schemes whose step costs ~100x more (an adaptive integrator): steps / 100 (at least 4)
SIZE_SLOW = {"ode_adaptive": 100}


def size_steps_for(spec: str, n: int) -> int:
    """The fixed number of steps of a `test_sizes` benchmark at n unknowns."""
    return max(4, dict(SIZE_STEPS)[n] // SIZE_SLOW.get(spec.split("[")[0], 1))


def _size_cases() -> list[Any]:
    """(spec, n, steps) with the id `spec-scene-nN-stepsS`: the work is in the name."""
    return [pytest.param(spec, n, size_steps_for(spec, n),
                         id=f"{spec}-{CASE}-n{n}-steps{size_steps_for(spec, n)}")
            for spec in _specs() for n, _ in SIZE_STEPS]


@pytest.mark.parametrize("mode", ["step", "rec1"])
@pytest.mark.parametrize("spec,n,steps", _size_cases())
def test_sizes(benchmark, spec: str, n: int, steps: int, mode: str) -> None:
    case = make_case(CASE)
    scheme = make_scheme(spec)
    reason = scheme.cannot_run(case) or case.cannot_run(scheme)
    if reason:
        pytest.skip(f"{spec} cannot run {CASE}: {reason}")
    semi = discretise(case, mesh_nodes(case.L, n), scheme.mass_kind())
    dt = 0.5 * semi.hmin / semi.c_max  # CFL 0.5
    limit = scheme.stability_limit(semi)
    if limit is not None:
        dt = min(dt, 0.9 * limit)
    scheme.integrate(semi, 1e-3 * semi.hmin / semi.c_max, 1, 1)
    stride = steps if mode == "step" else 1

    def setup() -> tuple[tuple[Any, ...], dict[str, Any]]:
        _new_heap_state()
        return (semi, dt, steps, stride), {}

    traj = benchmark.pedantic(scheme.integrate, setup=setup, rounds=5, iterations=1,
                              warmup_rounds=1)
    benchmark.extra_info.update(
        scheme=scheme.spec, n=n, nfree=semi.nfree, steps=steps, stride=stride, dt=dt,
        steps_done=traj.steps_done,
        ns_per_dof_step=benchmark.stats.stats.median / (semi.nfree * traj.steps_done) * 1e9,
        blowup=traj.blowup_time is not None)
