"""Memory of a run and cost of the error norms.

- The error norms keep to blocks of elements x samples: their memory does not grow like
  the mesh times the samples (tracemalloc peak against a bound the former whole-mesh
  blocks exceeded six-fold); a run's peak does not grow with the number of steps.
- Their quadrature is a scikit-fem Basis's, bit for bit. They equal a direct
  scikit-fem quadrature of the same errors (written here the obvious way), with and
  without a clamped node, on a graded mesh, for a reference with and without `fields`;
  `CharacteristicsSolution.fields` is `u`, `ux`, `ut` exactly.
- The reference values kept for the next scheme on the same grid give the same numbers
  and are not evaluated again; a table builds each reference once.
- A table keeps one run's samples at a time when asked, rebuilds semi-discrete problems
  it did not keep with the same results, and pandas is not loaded while runs step.
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from skfem import Basis, ElementLineP1, MeshLine

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.plugin import Trajectory
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case
from contact_bench.exact.characteristics import CharacteristicsSolution
from contact_bench.harness import metrics
from contact_bench.harness import runner as harness
from contact_bench.harness.metrics import ERROR_COLUMNS, error_metrics
from contact_bench.harness.runner import TIMING_COLUMNS, run_one, run_table

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def _fresh_caches(monkeypatch):
    """Each test starts without kept reference values or references."""
    metrics.clear_cache()
    harness.REFERENCES.clear()
    yield
    metrics.clear_cache()


def _trajectory(semi, t: np.ndarray, seed: int = 0) -> Trajectory:
    """Samples near the initial data (so that the errors are neither 0 nor huge)."""
    rng = np.random.default_rng(seed)
    K = t.size
    U = semi.U0 + 0.01 * rng.standard_normal((K, semi.nfree))
    V = semi.V0 + 0.01 * rng.standard_normal((K, semi.nfree))
    return Trajectory(t=t, U=U, V=V, contact_u=U[:, 0], stress=-0.1 * rng.random(K),
                      energy=np.ones(K), min_contact_u=0.0, steps_done=K - 1)


# ------------------------------------------------------------------------------ memory
def test_norm_memory_is_bounded_by_blocks_not_by_the_mesh(monkeypatch):
    """n = 20000 elements, 3 samples, nothing kept: the peak of a metrics pass stays
    under 40 arrays of n doubles (measured 27; the former single whole-mesh block of
    samples x elements x 4 points took 170)."""
    monkeypatch.setattr(metrics, "EXACT_CACHE_BYTES", 0)
    case = make_case("clamped_bar")
    n = 20_000
    semi = discretise(case, mesh_nodes(case.L, n))
    traj = _trajectory(semi, np.array([0.0, 0.5, 1.3]))
    exact = case.exact(2.0)
    metrics.warm_up()
    tracemalloc.start()
    try:
        error_metrics(semi, traj, exact, case.provides)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak <= 40 * 8 * n, f"norm pass peak {peak / 2**20:.1f} MB"
    assert metrics._cache == []


def test_kept_values_respect_their_budget(monkeypatch):
    monkeypatch.setattr(metrics, "EXACT_CACHE_BYTES", 2 * 2**20)
    monkeypatch.setattr(metrics, "KEEP_VALUES_NS", 0.0)  # values kept whenever they fit
    case = make_case("clamped_bar")
    semi = discretise(case, mesh_nodes(case.L, 4000))
    exact = case.exact(2.0)
    error_metrics(semi, _trajectory(semi, np.linspace(0, 2, 11)), exact, case.provides)
    # 11 x 4000 x 4 x 3 doubles: over 2 MB, not kept; the quadrature (320 kB) and norms are
    (entry,) = metrics._cache
    assert entry.values is None and entry.nbytes == 80 * 4000
    error_metrics(semi, _trajectory(semi, np.linspace(0, 2, 3)), exact, case.provides)
    assert len(metrics._cache) == 2 and metrics._cache[0].values is not None
    assert sum(e.nbytes for e in metrics._cache) <= 2 * 2**20
    monkeypatch.setattr(metrics, "EXACT_CACHE_BYTES", 80 * 4000 - 1)  # not even those
    metrics.clear_cache()
    error_metrics(semi, _trajectory(semi, np.linspace(0, 2, 3)), exact, case.provides)
    assert metrics._cache == []


def test_run_peak_does_not_grow_with_the_number_of_steps():
    """Same samples (11), 4x the steps: the traced peak of a run stays the same."""
    peaks = []
    for dt, stride in ((1e-3, 20), (2.5e-4, 80)):
        run_one("clamped_bar", "standard", nx=2000, dt=dt, T=0.2, stride=stride)  # warm
        tracemalloc.start()
        try:
            run = run_one("clamped_bar", "standard", nx=2000, dt=dt, T=0.2, stride=stride)
            peaks.append(tracemalloc.get_traced_memory()[1])
        finally:
            tracemalloc.stop()
        assert run.trajectory.t.size == 11 and run.row["status"] == "ok"
    assert peaks[1] <= 1.1 * peaks[0], peaks


def test_table_keeps_one_runs_samples_when_asked():
    full, light = [], []
    a = run_table(["clamped_bar"], ["standard", "redistributed"], [20], T=0.5, keep=full)
    b = run_table(["clamped_bar"], ["standard", "redistributed"], [20], T=0.5, keep=light,
                  keep_samples=False)
    cols = [c for c in a.columns if c not in TIMING_COLUMNS]
    assert a[cols].equals(b[cols])
    for f, g in zip(full, light, strict=True):
        assert g.semi is None and g.trajectory.U.shape == (f.trajectory.t.size, 0)
        assert g.trajectory.V.shape == (f.trajectory.t.size, 0)
        for name in ("t", "contact_u", "stress", "energy"):
            assert np.array_equal(getattr(f.trajectory, name), getattr(g.trajectory, name))
        assert f.trajectory.U.shape[1] == f.semi.nfree


def test_semi_not_kept_from_the_checks_is_rebuilt_identically(monkeypatch):
    calls = []
    real = harness.discretise

    def counting(*args, **kw):
        calls.append(1)
        return real(*args, **kw)

    monkeypatch.setattr(harness, "discretise", counting)
    kept = run_table(["dropped_bar"], ["standard"], [20, 30], T=0.5)
    assert len(calls) == 2
    monkeypatch.setattr(harness, "KEEP_SEMI_BYTES", 0)  # only the first plan's is kept
    monkeypatch.setattr(harness.PROBLEMS, "max_bytes", 0)  # and the process keeps none
    harness.PROBLEMS.clear()
    rebuilt = run_table(["dropped_bar"], ["standard"], [20, 30], T=0.5)
    assert len(calls) == 2 + 3
    cols = [c for c in kept.columns if c not in TIMING_COLUMNS]
    assert kept[cols].equals(rebuilt[cols])


def test_runs_step_without_pandas_loaded():
    """pandas (60 MB) is imported for the table, after the runs: not in a run's peak."""
    code = ("import sys; from contact_bench.harness.runner import run_one; "
            "run_one('clamped_bar', 'standard', nx=10, T=0.1); "
            "print('pandas' in sys.modules)")
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, cwd=ROOT, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


def test_a_tables_last_run_on_a_grid_keeps_nothing_for_later_runs():
    """The norms keep a grid's quadrature and exact norms only for a later run of the
    table on the same grid: a lone run (`contact-bench run --scheme X`) keeps nothing
    (at n = 1e6 they are 80 bytes per element: docs/performance.md). The errors are the
    same either way."""
    cols = list(ERROR_COLUMNS)
    lone = run_table(["clamped_bar"], ["standard"], [200], T=0.5)
    assert metrics._cache == []
    run_table(["clamped_bar"], ["standard"], [100, 200], T=0.5)  # two grids, one run each
    assert metrics._cache == []
    pair = run_table(["clamped_bar"], ["standard", "redistributed"], [200], T=0.5)
    (entry,) = metrics._cache  # made by the first run, used by the second
    assert entry.x.size == 201 and entry.t.size == pair["steps"].iloc[0] + 1
    assert lone[cols].iloc[0].equals(pair[cols].iloc[0])
    assert lone["err_u_linf_l2"].iloc[0] > 0


@pytest.mark.parametrize("scheme", ["standard", "restitution"])
def test_lone_run_peak_is_its_samples_plus_a_few_arrays_of_n(scheme):
    """A lone run (`contact-bench run` with one scheme and one case) at n = 1e5 over 100
    steps: the traced peak is at most the 2 S arrays of n doubles of its S stored
    samples (U and V) plus 24 (measured 21.1-21.6: the semi-discrete problem, the
    kernel's state, the set-up's temporaries; the norms keep nothing). Keeping the
    quadrature in a lone run made it 26.2. Twice the samples add 2 arrays per sample."""
    n = 100_000
    peaks = {}
    for stride in (10, 5):
        kw = dict(T=1e-5, stride=stride)
        run_table(["clamped_bar"], [scheme], [n], [1e-7], **kw)  # compiled, warmed up
        metrics.clear_cache()  # as in a new process
        tracemalloc.start()
        try:
            table = run_table(["clamped_bar"], [scheme], [n], [1e-7], **kw)
            peak = tracemalloc.get_traced_memory()[1] / (8 * n)
        finally:
            tracemalloc.stop()
        assert table["status"].iloc[0] == "ok" and table["steps"].iloc[0] == 100
        samples = 100 // stride + 1
        assert peak <= 2 * samples + 24, (stride, peak)
        peaks[samples] = peak
    assert abs((peaks[21] - peaks[11]) - 20) < 1, peaks


_ALLOCATOR = """
import resource
import numpy as np
from contact_bench.harness.environment import MMAP_THRESHOLD, return_freed_memory

def faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt

def resident():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096

assert return_freed_memory()
n = MMAP_THRESHOLD // 2 // 8  # under the threshold: kept by the heap for the next one
a = np.ones(n)
del a
f0 = faults()
b = np.ones(n)
small = faults() - f0
del b
big = 4 * MMAP_THRESHOLD // 8  # over it: mapped, given back when freed (twice, after
for _ in range(2):  # glibc would have raised its own threshold to this size)
    c = np.ones(big)
    r0 = resident()
    del c
    freed = r0 - resident()
print(small, n * 8 // 4096, freed, big * 8)
"""


def test_allocator_keeps_small_freed_arrays_and_gives_back_large_ones():
    """`contact-bench` sets glibc up so that a freed array under MMAP_THRESHOLD is
    reused by the next one without page faults (a run's sample buffers, run after run)
    and one over it goes back to the system at once (n-sized arrays at n = 1e6, the
    peak-memory bound). Without the set-up the reused array faults its pages in again
    (glibc's default trim threshold) and the second large one stays on the heap."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, "-c", _ALLOCATOR], capture_output=True, text=True,
                         env=env, cwd=ROOT, timeout=300)
    assert out.returncode == 0, out.stderr
    small, pages, freed, size = map(int, out.stdout.split())
    assert small < pages // 10, (small, pages)
    assert freed >= 0.9 * size, (freed, size)


# ------------------------------------------------------------------------------- norms
def _direct(semi, traj, exact) -> dict:
    """The error columns by one scikit-fem basis on the whole mesh, sample by sample."""
    basis = Basis(MeshLine(semi.x), ElementLineP1(), intorder=7)
    X = basis.global_coordinates().value[0]
    w = basis.dx
    d0, d1 = basis.element_dofs
    p0, p1 = (basis.basis[j][0].value for j in range(2))
    g0, g1 = (basis.basis[j][0].grad[0] for j in range(2))
    U = semi.full(traj.U)
    V = semi.full(traj.V, fill_velocity=True)
    n = {k: [] for k in ("eu", "nu", "eux", "nux", "ev", "nv")}
    for k, t in enumerate(traj.t):
        uh = U[k, d0][:, None] * p0 + U[k, d1][:, None] * p1
        uxh = U[k, d0][:, None] * g0 + U[k, d1][:, None] * g1
        vh = V[k, d0][:, None] * p0 + V[k, d1][:, None] * p1
        u, ux, v = exact.u(X, t), exact.ux(X, t), exact.ut(X, t)
        for key, a in (("eu", uh - u), ("nu", u), ("eux", uxh - ux), ("nux", ux),
                       ("ev", vh - v), ("nv", v)):
            n[key].append(np.sum(w * a**2))
    n = {k: np.array(v) for k, v in n.items()}
    t = traj.t

    def linf(e, m):
        return np.sqrt(e.max() / m.max())

    def l2(e, m):
        return np.sqrt(np.trapezoid(e, t) / np.trapezoid(m, t))

    s = exact.stress(t)
    return {"err_u_linf_l2": linf(n["eu"], n["nu"]),
           "err_u_linf_h1": linf(n["eu"] + n["eux"], n["nu"] + n["nux"]),
           "err_v_linf_l2": linf(n["ev"], n["nv"]),
           "err_u_l2_l2": l2(n["eu"], n["nu"]),
           "err_u_l2_h1": l2(n["eu"] + n["eux"], n["nu"] + n["nux"]),
           "err_v_l2_l2": l2(n["ev"], n["nv"]),
           "err_stress_l2": l2((traj.stress - s) ** 2, s**2)}


class _Smooth:
    """A smooth field (not a solution of anything): u = cos(x + t) + x t / 2 (no
    `fields`), for the generic path."""

    def __init__(self) -> None:
        self.calls = 0

    def u(self, x, t):
        self.calls += 1
        return np.cos(x + t) + 0.5 * x * t

    def ux(self, x, t):
        return -np.sin(x + t) + 0.5 * t

    def ut(self, x, t):
        return -np.sin(x + t) + 0.5 * x

    def stress(self, t):
        return -np.abs(np.sin(np.asarray(t, float))) - 0.1


PROVIDES = frozenset({"u", "v", "stress"})


@pytest.mark.parametrize("nodes", [
    np.linspace(0.0, 1.0, 81),  # a default grid
    mesh_nodes(10.0, 37, grading=1.6),  # graded
    np.cumsum(np.r_[0.3, np.random.default_rng(4).random(50) + 0.01]),  # irregular
])
@pytest.mark.parametrize("e0,e1", [(0, None), (7, 19), (1, 2)])  # whole mesh, blocks
def test_geometry_is_scikit_fems_basis_bit_for_bit(nodes, e0, e1):
    """The norms' quadrature (scikit-fem's mapping and reference basis called one by
    one) equals what a scikit-fem Basis of the block's nodes computes, bit for bit."""
    e1 = nodes.size - 1 if e1 is None else e1
    g = metrics._Geometry.of(nodes, e0, e1)
    basis = Basis(MeshLine(nodes[e0 : e1 + 1]), ElementLineP1(), intorder=7)
    assert basis.X.shape[1] == 4  # 4 Gauss points per element
    np.testing.assert_array_equal(basis.element_dofs, [np.arange(e1 - e0),
                                                       np.arange(1, e1 - e0 + 1)])
    assert g.lo == e0
    np.testing.assert_array_equal(g.X, basis.global_coordinates().value[0], strict=True)
    np.testing.assert_array_equal(g.w, basis.dx, strict=True)
    for j, (p, slope) in enumerate([(g.p0, g.g0), (g.p1, g.g1)]):
        value, grad = basis.basis[j][0].value, basis.basis[j][0].grad[0]
        np.testing.assert_array_equal(np.broadcast_to(p, value.shape), value)
        np.testing.assert_array_equal(np.broadcast_to(slope[:, None], grad.shape), grad)
    for a in (g.X, g.w, g.p0, g.p1, g.g0, g.g1):
        assert a.flags.c_contiguous and a.dtype == np.float64


@pytest.mark.parametrize("case_name", ["clamped_bar", "dropped_bar"])  # clamped / free end
def test_norms_equal_direct_quadrature_on_a_graded_mesh(case_name):
    case = make_case(case_name)
    semi = discretise(case, mesh_nodes(case.L, 37, grading=1.6))
    if semi.u_fixed is not None:  # a clamped node off zero
        semi = dataclasses.replace(semi, u_fixed=0.3)
    traj = _trajectory(semi, np.linspace(0.0, 0.9, 23))
    got = error_metrics(semi, traj, _Smooth(), PROVIDES)
    want = _direct(semi, traj, _Smooth())
    for col in ERROR_COLUMNS:
        assert got[col] == pytest.approx(want[col], rel=1e-13, abs=0), col


def test_norms_with_a_characteristics_reference_equal_direct_quadrature():
    case = make_case("dropped_bar")
    run = run_one(case, "redistributed", nx=25, T=1.5)
    exact = case.exact(run.row["T"])
    assert isinstance(exact, CharacteristicsSolution)
    want = _direct(run.semi, run.trajectory, exact)
    for col in ERROR_COLUMNS:
        assert run.row[col] == pytest.approx(want[col], rel=1e-13, abs=0), col
    assert run.norm_s is not None and run.norm_s >= 0.0


@pytest.mark.parametrize("far_end,g,u_L", [("free", 10.0, 0.0), ("clamped", 3.0, 0.2)])
def test_fields_are_u_ux_ut_exactly(far_end, g, u_L):
    sol = CharacteristicsSolution(L=2.0, E=9.0, rho=1.0, g=g, far_end=far_end, u_L=u_L,
                                  u0=lambda x: u_L + 0.25 * (2.0 - x), v0=-0.3, T=4.0,
                                  cells_per_length=400)
    rng = np.random.default_rng(1)
    x = np.concatenate(([0.0, 2.0, 1.0], rng.uniform(0, 2, 300)))
    t = np.concatenate(([0.0, 4.0], rng.uniform(0, 4, 200), np.arange(1, 13) / 3.0))
    X, T = x[None, :], t[:, None]
    u, ux, ut = sol.fields(X, T)
    assert np.array_equal(u, sol.u(X, T))
    assert np.array_equal(ux, sol.ux(X, T))
    assert np.array_equal(ut, sol.ut(X, T))
    assert sol.fields(X, T, velocity=False)[2] is None


def test_kept_reference_values_give_the_same_errors_without_new_evaluations(monkeypatch):
    monkeypatch.setattr(metrics, "KEEP_VALUES_NS", 0.0)  # values kept whatever their cost
    case = make_case("clamped_bar")
    semi = discretise(case, mesh_nodes(case.L, 30))
    t = np.linspace(0.0, 1.0, 17)
    exact = _Smooth()
    first = error_metrics(semi, _trajectory(semi, t, seed=1), exact, PROVIDES)
    evaluated = exact.calls
    assert evaluated > 0
    second = error_metrics(semi, _trajectory(semi, t, seed=2), exact, PROVIDES)
    assert exact.calls == evaluated  # the second scheme on the grid reuses the values
    metrics.clear_cache()
    fresh = error_metrics(semi, _trajectory(semi, t, seed=2), exact, PROVIDES)
    assert second == fresh and second != first
    calls = exact.calls
    error_metrics(semi, _trajectory(semi, t), exact, PROVIDES)
    assert exact.calls == calls
    error_metrics(semi, _trajectory(semi, t + 0.01), exact, PROVIDES)  # other times
    assert exact.calls > calls
    calls = exact.calls
    error_metrics(semi, _trajectory(semi, t), exact, PROVIDES)  # both grids kept
    assert exact.calls == calls
    other = _Smooth()
    error_metrics(semi, _trajectory(semi, t), other, PROVIDES)  # another reference
    assert other.calls > 0 and exact.calls == calls


def test_table_builds_each_reference_once(monkeypatch):
    case_cls = type(make_case("dropped_bar"))
    built = []
    real = case_cls.exact

    def counting(self, T):
        built.append(T)
        return real(self, T)

    monkeypatch.setattr(case_cls, "exact", counting)
    runs = []
    run_table(["dropped_bar"], ["standard", "redistributed", "hht"], [12], T=1.0, keep=runs)
    assert len(built) == 1
    assert all(r.norm_s is not None and r.norm_s >= 0 for r in runs)
    harness.REFERENCES.clear()
    monkeypatch.setattr(harness.REFERENCES, "max_bytes", 0)  # over budget: not kept
    again = run_table(["dropped_bar"], ["standard", "redistributed", "hht"], [12], T=1.0)
    assert len(built) == 1 + 3 and len(harness.REFERENCES) == 0
    assert again["err_u_l2_l2"].tolist() == [r.row["err_u_l2_l2"] for r in runs]


class _Pointwise:
    """A reference's `fields`, `u`, `ux`, `ut` and `stress` only (no `fields_into`): the
    generic path of the norms."""

    def __init__(self, exact) -> None:
        self.exact = exact

    def fields(self, x, t, velocity=True):
        return self.exact.fields(x, t, velocity=velocity)

    def u(self, x, t):
        return self.exact.u(x, t)

    def ux(self, x, t):
        return self.exact.ux(x, t)

    def ut(self, x, t):
        return self.exact.ut(x, t)

    def stress(self, t):
        return self.exact.stress(t)


def _root(a: np.ndarray) -> np.ndarray:
    while a.base is not None:
        a = a.base
    return a


@pytest.mark.parametrize("case_name", ["clamped_bar", "dropped_bar"])
@pytest.mark.parametrize("chunk", [120, 740])  # blocks of 30 + 7 elements / of 5 samples
@pytest.mark.parametrize("keep", ["values", "quadrature", "nothing"])
def test_norms_through_fields_into_equal_direct_quadrature(monkeypatch, case_name, chunk,
                                                           keep):
    """References with `fields_into` write their values in place: into one allocation
    carved into the blocks when kept, into one block's arrays reused when not. Same
    errors as the direct scikit-fem quadrature, over uneven blocks of elements and of
    samples, and the same numbers as through `fields`; the next call on the grid (kept
    values, or evaluated again with the kept quadrature and norms) gives the same bits."""
    monkeypatch.setattr(metrics, "_CHUNK_POINTS", chunk)
    monkeypatch.setattr(metrics, "KEEP_VALUES_NS", 0.0 if keep == "values" else np.inf)
    if keep == "nothing":
        monkeypatch.setattr(metrics, "EXACT_CACHE_BYTES", 0)
    case = make_case(case_name)
    semi = discretise(case, mesh_nodes(case.L, 37, grading=1.6))
    if semi.u_fixed is not None:
        semi = dataclasses.replace(semi, u_fixed=0.3)
    exact = case.exact(2.0)
    assert hasattr(exact, "fields_into")
    traj = _trajectory(semi, np.linspace(0.0, 1.9, 23))  # contact from t = 1
    got = error_metrics(semi, traj, exact, case.provides)
    want = _direct(semi, traj, exact)
    for col in ERROR_COLUMNS:
        assert got[col] == pytest.approx(want[col], rel=1e-13, abs=0), col
    if keep == "values":
        (entry,) = metrics._cache
        arrays = [a for vals in entry.values for a in vals if a is not None]
        assert len(arrays) == 3 * len(entry.values) and len({id(_root(a)) for a in arrays}) == 1
    elif keep == "quadrature":
        (entry,) = metrics._cache
        assert entry.values is None and len(entry.geometry) == (1 if chunk == 740 else 2)
    else:
        assert metrics._cache == []
    assert error_metrics(semi, traj, exact, case.provides) == got  # warm: the same bits
    metrics.clear_cache()
    pointwise = error_metrics(semi, traj, _Pointwise(exact), case.provides)
    # the characteristics solution's `fields_into` evaluates sorted points dense in its
    # cells by runs: equal to `fields` up to round-off only (contact_bench.exact.characteristics,
    # "Evaluation on a grid"); a closed form (the clamped bar's) is bitwise the same
    if not isinstance(exact, CharacteristicsSolution):
        assert pointwise == got
    for col in ERROR_COLUMNS:
        assert pointwise[col] == pytest.approx(got[col], rel=1e-13, abs=0), col


class _Clock:
    """A stand-in for `metrics._clock` that the references below advance."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class _Timed:
    """The clamped bar's closed form, each of whose evaluations takes ns[0], ns[1], ...
    (the last one repeated) nanoseconds per point on `clock`: a fast or a slow reference,
    or one interrupted once, without depending on this machine's speed."""

    def __init__(self, clock: _Clock, ns: list[float]) -> None:
        self.exact, self.clock, self.ns, self.calls = make_case("clamped_bar").exact(2.0), \
            clock, list(ns), 0
        self.times: list[int] = []  # sample times of each call

    def fields_into(self, x, t, u, ux, ut=None):
        ns = self.ns[min(self.calls, len(self.ns) - 1)]
        self.calls += 1
        self.times.append(t.size)
        self.clock.now += ns * 1e-9 * x.size * t.size
        self.exact.fields_into(x, t, u, ux, ut)

    def stress(self, t):
        return self.exact.stress(t)


@pytest.mark.parametrize("ns,kept,calls", [
    ([1.0], False, 10), ([4.9], False, 10), ([5.1], True, 11), ([300.0], True, 11),
    ([300.0, 1.0], False, 11)])  # interrupted once: timed again, fast
def test_values_are_kept_for_slow_references_only(monkeypatch, ns, kept, calls):
    """The values are kept when the reference's first block took longer than
    KEEP_VALUES_NS per point, twice (a slow one is timed again: one interruption does
    not make a fast reference slow); otherwise the next call on the grid evaluates it
    again, with the kept quadrature and norms. Either way, the same bits."""
    clock = _Clock()
    monkeypatch.setattr(metrics, "_clock", clock)
    monkeypatch.setattr(metrics, "KEEP_VALUES_NS", 5.0)
    monkeypatch.setattr(metrics, "_CHUNK_POINTS", 480)  # 30 elements x 4 samples: 10 blocks
    case = make_case("clamped_bar")
    semi = discretise(case, mesh_nodes(case.L, 30))
    t = np.linspace(0.0, 1.9, 40)
    ref = _Timed(clock, ns)
    error_metrics(semi, _trajectory(semi, t), ref, case.provides)
    (entry,) = metrics._cache
    assert (entry.values is not None) == kept and len(entry.geometry) == 1
    assert ref.calls == calls
    second = error_metrics(semi, _trajectory(semi, t, seed=1), ref, case.provides)
    assert ref.calls == calls + (0 if kept else 10)
    metrics.clear_cache()
    plain = error_metrics(semi, _trajectory(semi, t, seed=1), case.exact(2.0), case.provides)
    assert second == plain


def test_a_slow_first_block_is_timed_again_on_its_first_sample_times_only(monkeypatch):
    """A slow first block is timed once more on at most _PROBE_POINTS points (its first
    sample times), not the whole block again (which doubled a slow reference's first
    call); the values kept are those of the whole first evaluation, bit for bit."""
    clock = _Clock()
    monkeypatch.setattr(metrics, "_clock", clock)
    monkeypatch.setattr(metrics, "KEEP_VALUES_NS", 5.0)
    monkeypatch.setattr(metrics, "_PROBE_POINTS", 250)  # 30 elements x 4: 2 sample times
    case = make_case("clamped_bar")
    semi = discretise(case, mesh_nodes(case.L, 30))
    t = np.linspace(0.0, 1.9, 40)
    ref = _Timed(clock, [300.0])
    first = error_metrics(semi, _trajectory(semi, t), ref, case.provides)
    assert ref.times[:2] == [40, 2] and len(ref.times) == 2
    (entry,) = metrics._cache
    assert entry.values is not None
    again = error_metrics(semi, _trajectory(semi, t), ref, case.provides)
    assert len(ref.times) == 2 and again == first
    metrics.clear_cache()
    assert first == error_metrics(semi, _trajectory(semi, t), case.exact(2.0), case.provides)


class _Recording:
    """Records how the norms call a reference: `fields_into` (arguments' shapes, times)
    and `stress`; the values are those of `_Smooth`."""

    def __init__(self, with_fields_into: bool = True) -> None:
        self.log: list[tuple] = []
        if not with_fields_into:
            self.fields_into = None

    def fields_into(self, x, t, u, ux, ut=None):
        self.log.append(("fields_into", x.shape, tuple(t), u.shape, ut is None))
        X, Tt = np.meshgrid(x, t)
        u[:], ux[:] = np.cos(X + Tt), -np.sin(X + Tt)
        if ut is not None:
            ut[:] = -np.sin(X + Tt)

    def u(self, x, t):
        self.log.append(("u", np.shape(x), np.shape(t)))
        return np.cos(x + t)

    def ux(self, x, t):
        return -np.sin(x + t)

    def ut(self, x, t):
        return -np.sin(x + t)

    def stress(self, t):
        self.log.append(("stress", tuple(np.asarray(t))))
        return np.zeros(np.shape(t))


@pytest.mark.parametrize("provides", [PROVIDES, frozenset({"u"}), frozenset({"u", "v"}),
                                      frozenset({"stress"})])
def test_warm_up_reference_calls_what_the_norms_call_on_one_point_and_time(provides):
    x = np.linspace(0.0, 2.0, 11)
    t = np.array([0.25, 0.5, 0.75])
    ref = _Recording()
    metrics.warm_up_reference(ref, x, t, provides)
    expected = []
    if "u" in provides:
        expected.append(("fields_into", (40,), (0.25,), (1, 40), "v" not in provides))
    if "stress" in provides:
        expected.append(("stress", (0.25,)))
    assert ref.log == expected
    # the points are the first block's Gauss points, as the norms pass them
    generic = _Recording(with_fields_into=False)
    metrics.warm_up_reference(generic, x, t, frozenset({"u"}))
    assert generic.log == [("u", (10, 4), (1, 1, 1))]


def test_harness_warms_each_reference_type_once_before_timing_the_norms(monkeypatch):
    calls = []
    real = metrics.warm_up_reference

    def spy(exact, x, t, provides):
        calls.append((type(exact).__name__, metrics._cache == []))
        real(exact, x, t, provides)

    monkeypatch.setattr(metrics, "warm_up_reference", spy)
    monkeypatch.setattr(harness, "_warmed",
                        {w for w in harness._warmed if w[0] != "reference"})
    metrics.clear_cache()
    run_table(["clamped_bar", "dropped_bar"], ["standard", "restitution"], [10], T=0.5)
    # once per reference type, before the first norms on it (nothing kept yet)
    assert calls == [("ClampedBarExact", True), ("CharacteristicsSolution", False)], calls
