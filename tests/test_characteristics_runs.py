"""`fields_into` by runs of points per cell, and the coarse grids of the scenes.

contact_bench.exact.characteristics evaluates sorted points dense in the cells by runs (module
docstring, "Evaluation on a grid"): the cells must be those of the pointwise search
(`_grid_kernel`, the kernel `fields_into` used before, and `fields`), and the values may
differ from the pointwise ones by round-off only. Checked here on many solutions, with
points on nodes, at x = 0 and x = L, duplicated, at block boundaries in time, t = 0 and
t = T. The scenes whose data make any grid exact use a coarse grid (`coarse_solution`):
checked against the default grid and against closed forms derived here.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from contact_bench.api.plugin import Fields
from contact_bench.api.registry import make_case
from contact_bench.exact.characteristics import (
    CharacteristicsSolution,
    _grid_kernel,
    _run_kernel,
    coarse_solution,
)

#: |by runs - pointwise| <= TOL * data scale (u: max |u| + L max |u_x|; u_x: max |u_x| +
#: gam L; u_t: max |u_t| + c gam L). Measured at most 4e-16 (a couple of eps).
TOL = 2e-15


def _args(sol, x, t):
    """The arguments of the compiled grid kernels before their outputs (as `fields_into`
    passes them)."""
    return (x, sol.c * t, sol._stored(), sol._table())


def _pointwise(sol, x, t):
    """u, u_x, u_t by the pointwise kernel, checked equal to `fields` (bitwise)."""
    out = [np.full((t.size, x.size), np.nan) for _ in range(3)]
    _grid_kernel(*_args(sol, x, t), Fields(*out))
    X, T = np.broadcast_arrays(x[None, :], t[:, None])
    for got, want in zip(out, sol.fields(X, T), strict=True):
        np.testing.assert_array_equal(got, want)
    return out


def _assert_close(sol, got, want):
    mx = [float(np.max(np.abs(w))) for w in want]
    scale = (mx[0] + sol.L * mx[1], mx[1] + sol.gam * sol.L, mx[2] + sol.c * sol.gam * sol.L)
    for name, g, w, s in zip(("u", "u_x", "u_t"), got, want, scale, strict=True):
        assert not np.any(np.isnan(g)), name
        err = float(np.max(np.abs(g - w)))
        assert err <= TOL * s, (name, err / s)


def _clamped_bar(T, n):
    return CharacteristicsSolution(L=1.0, E=1.0, rho=1.0, far_end="clamped", u_L=0.0,
                                   u0=lambda x: 0.5 - 0.5 * x, v0=0.0, T=T,
                                   cells_per_length=n)


def _random_tuple_data(seed, far_end, g):
    """Piecewise linear u0, piecewise constant v0 with kinks and jumps on a 200-cell grid
    (impacts at many places: inserted nodes)."""
    rng = np.random.default_rng(seed)
    n, L = 200, float(rng.uniform(0.5, 2.0))
    E, rho = float(rng.uniform(0.5, 3.0)), float(rng.uniform(0.5, 2.0))
    xk = np.concatenate(([0.0], np.sort(rng.choice(np.arange(1, n), 6, replace=False)) * L / n,
                        [L]))
    uk = rng.uniform(0.0, 0.2, xk.size) * L
    uk[0] = 0.05 * L * (seed % 2)
    c = math.sqrt(E / rho)
    vals = rng.uniform(-1.0, 0.2, xk.size - 1) * 0.3 * c
    return CharacteristicsSolution(L=L, E=E, rho=rho, g=g, far_end=far_end, u_L=float(uk[-1]),
                                   u0=(xk, uk), v0=(np.repeat(xk, 2)[1:-1], np.repeat(vals, 2)),
                                   T=6.0 * L / c, cells_per_length=n)


def _solutions():
    """name -> (solution, x range as fractions of L or None for [0, L], points)."""
    out = {
        "clamped, g = 0, coarse": (_clamped_bar(12.0, 40), None, 400),
        "clamped, g = 0, one cell": (_clamped_bar(12.0, 1), None, 50),
        "free, gravity, inserted nodes": (CharacteristicsSolution(
            L=1.0, E=1.0, rho=1.0, g=9.81, far_end="free", u0=0.05, v0=0.0, T=3.0,
            cells_per_length=50), None, 600),
        "clamped, gravity, u_L, fine": (CharacteristicsSolution(
            L=2.0, E=9.0, rho=1.0, g=3.0, far_end="clamped", u_L=0.2,
            u0=lambda x: 0.2 + 0.25 * (2.0 - x), v0=-0.3, T=4.0, cells_per_length=400),
            None, 3000),
        "tuple data with kinks": (CharacteristicsSolution(
            L=1.0, E=4.0, rho=1.0, far_end="free", u0=((0.0, 0.3, 1.0), (0.1, 0.0, 0.0)),
            v0=((0.0, 0.5, 0.5, 1.0), (0.0, 0.0, -1.0, -1.0)), T=2.0, cells_per_length=28),
            None, 300),
        "dropped bar, default grid, a slice of x": (CharacteristicsSolution(
            L=10.0, E=900.0, rho=1.0, g=10.0, far_end="free", u0=5.0, v0=0.0, T=6.5),
            (0.3, 0.305), 1200),
    }
    for seed in (0, 1):
        for far_end in ("clamped", "free"):
            for g in (0.0, 2.0):
                out[f"random data {seed}, {far_end}, g = {g}"] = (
                    _random_tuple_data(seed, far_end, g), None, 3000)
    for spec, span in (("dropped_bar", None), ("fast_impact[mach=0.5]", None),
                       ("steel_bar", None), ("rough_data", None), ("grazing", (0.6, 0.61)),
                       ("pulse", (0.2, 0.21))):
        case = make_case(spec)
        sol = case.exact(case.T)
        if not isinstance(sol, CharacteristicsSolution):
            # the scene's reference is its closed form (or d'Alembert's): its data here
            sol = CharacteristicsSolution(L=case.L, E=case.E, rho=case.rho,
                                          far_end=case.far_end, u0=case.u0, v0=case.v0,
                                          T=case.T)
        out[f"scene {spec}"] = (sol, span, 500 if span is None else 1500)
    return out


SOLUTIONS = _solutions()


def _points(sol, span, size, seed=0):
    """Sorted x with duplicates, nodes of the base grid and (without a span) 0 and L;
    t with 0, T, the block boundaries tau = k L and the doubles just below them."""
    rng = np.random.default_rng(seed)
    L, T = sol.L, sol.T
    a, b = (0.0, L) if span is None else (span[0] * L, span[1] * L)
    nodes = np.arange(math.ceil(a / sol.ds), math.floor(b / sol.ds) + 1) * sol.ds
    x = np.sort(np.concatenate((rng.uniform(a, b, size), nodes[:size], np.repeat(
        rng.uniform(a, b, 3), 3), [a, a, b] if span is None else [])))
    blocks = np.arange(0.0, sol.c * T, L)[:60] / sol.c
    t = np.concatenate(([0.0, T], rng.uniform(0.0, T, 120), blocks,
                        np.nextafter(blocks[1:], 0.0)))
    return np.clip(x, 0.0, L), np.clip(t, 0.0, T)


@pytest.mark.parametrize("name", list(SOLUTIONS))
def test_runs_agree_with_the_pointwise_evaluation(name):
    sol, span, size = SOLUTIONS[name]
    x, t = _points(sol, span, size)
    want = _pointwise(sol, x, t)
    got = [np.full_like(want[0], np.nan) for _ in range(3)]
    assert _run_kernel(*_args(sol, x, t), Fields(*got)) == 0  # no sample time point by point
    _assert_close(sol, got, want)
    # `fields_into` takes the runs here (the points are dense in the cells)
    assert sol._by_runs(x.size, True, float(x[-1] - x[0]))
    into = [np.full_like(want[0], np.nan) for _ in range(3)]
    sol.fields_into(x, t, *into)
    for a, b in zip(into, got, strict=True):
        np.testing.assert_array_equal(a, b)
    # without u_t: the same u and u_x
    u2, ux2 = np.full_like(got[0], np.nan), np.full_like(got[0], np.nan)
    sol.fields_into(x, t, u2, ux2)
    np.testing.assert_array_equal(u2, got[0])
    np.testing.assert_array_equal(ux2, got[1])
    # unsorted x: point by point, the values of `fields` exactly
    perm = np.random.default_rng(1).permutation(x.size)
    out = [np.full_like(want[0], np.nan) for _ in range(3)]
    sol.fields_into(x[perm], t, *out)
    for a, b in zip(out, want, strict=True):
        np.testing.assert_array_equal(a, b[:, perm])


def test_runs_at_points_within_ulps_of_the_cell_ends():
    """Points on the nodes of both families and a few doubles either side, at kinks of
    the data at every node (a point given the neighbouring cell gets another u_x), and
    empty cells between them: the runs end where the points' own coordinates say, not
    where x estimates."""
    rng = np.random.default_rng(8)
    n = 8
    xk = np.linspace(0.0, 1.0, n + 1)
    uk = rng.uniform(0.0, 0.1, n + 1)
    uk[0] = 0.02
    vals = rng.uniform(-0.5, 0.2, n)
    sol = CharacteristicsSolution(L=1.0, E=1.0, rho=1.0, g=0.7, far_end="free", u0=(xk, uk),
                                  v0=(np.repeat(xk, 2)[1:-1], np.repeat(vals, 2)), T=5.0,
                                  cells_per_length=n)
    assert sol.inserted_nodes > 0
    nodes = np.unique(sol._r)
    times = np.concatenate((rng.uniform(0.0, 5.0, 25), np.arange(0.0, 5.0, 0.5),
                            np.arange(1, 40) / n, np.nextafter(np.arange(1, 40) / n, 0.0)))
    for tn in times:
        tau = sol.c * tn
        rho = tau - math.floor(tau / sol.L) * sol.L
        p_ends = np.concatenate((nodes - rho, nodes + sol.L - rho))
        q_ends = np.concatenate((rho - nodes, sol.L + rho - nodes))
        ends = np.concatenate((p_ends, q_ends))
        ends = ends[(ends >= 0.0) & (ends <= sol.L)]
        x = [ends]
        for _ in range(3):
            x.append(np.nextafter(x[-1], np.inf))
        below = [ends]
        for _ in range(3):
            below.append(np.nextafter(below[-1], -np.inf))
        x = np.concatenate(x + below[1:] + [ends[::2]])
        # and only every other node of one family: empty cells between the points
        for xs in (x, np.sort(p_ends)[::2], np.sort(q_ends)[::2]):
            xs = np.clip(np.sort(xs[(xs >= 0.0) & (xs <= sol.L)]), 0.0, sol.L)
            if xs.size < 2:
                continue
            t = np.array([tn])
            want = _pointwise(sol, xs, t)
            got = [np.full_like(want[0], np.nan) for _ in range(3)]
            assert _run_kernel(*_args(sol, xs, t), Fields(*got)) == 0
            _assert_close(sol, got, want)


def test_a_coordinate_rounded_onto_the_block_end_is_the_node():
    """x + tau just below a block boundary, where the local coordinate r + L rounds to L:
    the point is the node k L (block k, r = 0), not r = L in block k - 1, which no cell
    holds (the pointwise search used to extrapolate a cell of block k by 8 cells there:
    u = -0.24 instead of -0.011)."""
    rng = np.random.default_rng(8)
    xk = np.linspace(0.0, 1.0, 9)
    uk = rng.uniform(0.0, 0.1, 9)
    uk[0] = 0.02
    vals = rng.uniform(-0.5, 0.2, 8)
    sol = CharacteristicsSolution(L=1.0, E=1.0, rho=1.0, g=0.7, far_end="free", u0=(xk, uk),
                                  v0=(np.repeat(xk, 2)[1:-1], np.repeat(vals, 2)), T=5.0,
                                  cells_per_length=8)
    t = np.nextafter(0.125, 0.0)
    assert 0.875 + t == 1.0 and (0.875 - 1.0) + t < 0.0  # high branch, r < 0, r + L = L
    x = np.array([np.nextafter(0.875, 0.0), 0.875, np.nextafter(0.875, 1.0)])
    u, ux, ut = sol.fields(x, t)
    u1, ux1, ut1 = sol.fields(x, 0.125)
    assert np.max(np.abs(u - u1)) < 1e-15  # u is continuous
    # at the node: the derivatives of the node convention (those at t = 0.125)
    assert ux[1] == pytest.approx(ux1[1], abs=1e-15) and ut[1] == pytest.approx(ut1[1],
                                                                                abs=1e-15)


def test_sparse_points_are_evaluated_point_by_point():
    """Fewer points than cells: `fields_into` keeps the pointwise kernel (bitwise)."""
    sol = CharacteristicsSolution(L=10.0, E=900.0, rho=1.0, g=10.0, far_end="free", u0=5.0,
                                  v0=0.0, T=6.5)
    x = np.sort(np.random.default_rng(2).uniform(0.0, 10.0, 400))
    t = np.linspace(0.0, 6.5, 53)
    assert not sol._by_runs(x.size, True, float(x[-1] - x[0]))
    out = [np.empty((t.size, x.size)) for _ in range(3)]
    sol.fields_into(x, t, *out)
    for a, b in zip(out, _pointwise(sol, x, t), strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("size", [1, 2, 3, 7, 8, 9, 17])
@pytest.mark.parametrize("rows", [1, 2, 5])
def test_runs_write_exactly_their_points(size, rows):
    """The last vector of a run may write into the next run or the next sample time, never
    past the outputs: here rows of a larger array whose guard rows must stay NaN (also
    for fewer than 8 points, all equal, or one point)."""
    sol = _clamped_bar(3.0, 1)
    x = np.sort(np.random.default_rng(size).uniform(0.0, 1.0, size))
    if size == 9:
        x[:] = 0.25  # no span: one run
    t = np.linspace(0.0, 3.0, rows)
    want = _pointwise(sol, x, t)
    bufs = [np.full((rows + 2, size), np.nan) for _ in range(3)]
    views = [b[1:-1] for b in bufs]
    assert all(v.flags.c_contiguous for v in views)
    if size >= 2:
        assert _run_kernel(*_args(sol, x, t), Fields(*views)) == 0
    else:
        sol.fields_into(x, t, *views)
    _assert_close(sol, views, want)
    for b in bufs:
        assert np.all(np.isnan(b[0])) and np.all(np.isnan(b[-1]))


def test_sample_times_without_a_cell_fall_back_to_the_pointwise_kernel():
    """Past the stored blocks a point has no cell: that sample time is evaluated by the
    pointwise kernel (the very same values), the others by runs."""
    sol = _clamped_bar(3.0, 10)
    x = np.linspace(0.0, 1.0, 101)
    tau_end = (sol._K + 0.5) * sol.L  # p beyond the last block for x > L / 2
    t = np.array([0.5, tau_end / sol.c, 1.0, 2.9])
    want = [np.full((t.size, x.size), np.nan) for _ in range(3)]
    _grid_kernel(*_args(sol, x, t), Fields(*want))
    got = [np.full((t.size, x.size), np.nan) for _ in range(3)]
    assert _run_kernel(*_args(sol, x, t), Fields(*got)) == 1
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g[1], w[1])
    _assert_close(sol, [g[[0, 2, 3]] for g in got], [w[[0, 2, 3]] for w in want])


def test_fields_into_checks_and_clips_as_the_pointwise_evaluation():
    sol = _clamped_bar(3.0, 4)
    x = np.linspace(0.0, 1.0, 200)
    good = np.empty((3, 200))
    with pytest.raises(ValueError, match="outside the bar"):
        sol.fields_into(np.where(x > 0.5, np.nan, x), [0.0, 1.0, 2.0], good, good.copy())
    with pytest.raises(ValueError, match="outside the stored interval"):
        sol.fields_into(x, [0.0, 1.0, 3.5], good, good.copy())
    # within the slack: clipped to [0, L] and [0, T], as `fields` does
    xs = x.copy()
    xs[0], xs[-1] = -1e-13, 1.0 + 1e-13
    out = [np.empty((3, 200)) for _ in range(3)]
    sol.fields_into(xs, [-1e-13, 1.0, 3.0 + 1e-13], *out)
    X, T = np.broadcast_arrays(xs[None, :], np.array([-1e-13, 1.0, 3.0 + 1e-13])[:, None])
    _assert_close(sol, out, sol.fields(X, T))
    empty = np.empty((3, 0))
    sol.fields_into(np.empty(0), [0.0, 1.0, 2.0], empty, empty.copy())


# --------------------------------------------------------------------------------------
# The coarse grids of the scenes (exact for their data): against the default grid and
# closed forms


def _rebuilt(sol, **kw):
    """The same problem on the default grid (or the grid in kw)."""
    return CharacteristicsSolution(L=sol.L, E=sol.E, rho=sol.rho, g=sol.g, far_end=sol.far_end,
                                   u_L=sol.u_L, T=sol.T, **kw)


def _compare_grids(coarse, fine, tol_u, tol_d):
    rng = np.random.default_rng(4)
    x, t = rng.uniform(0.0, coarse.L, 4000), rng.uniform(0.0, coarse.T, 4000)
    a, b = coarse.fields(x, t), fine.fields(x, t)
    assert np.max(np.abs(a[0] - b[0])) <= tol_u
    assert np.max(np.abs(a[1] - b[1])) <= tol_d
    assert np.max(np.abs(a[2] - b[2])) <= coarse.c * tol_d
    ints, ref = np.array(coarse.contact_intervals()), np.array(fine.contact_intervals())
    assert ints.shape == ref.shape and np.max(np.abs(ints - ref)) < 1e-11
    te = np.linspace(0.0, coarse.T, 9)
    np.testing.assert_allclose(coarse.energy(te), fine.energy(te), rtol=1e-12)


def test_dropped_bar_reference_on_one_cell_per_length():
    from contact_bench.cases.dropped_bar import DroppedBar
    from contact_bench.exact.dropped_series import SERIES_TRUNCATION, series_u

    case = DroppedBar()
    ex = case.exact(6.5)
    assert ex.cells_per_length == 1 and ex.inserted_nodes == 0 and ex.capped_nodes == 0
    fine = _rebuilt(ex, u0=5.0, v0=0.0)
    assert fine.cells_per_length == 20000
    _compare_grids(ex, fine, 1e-12, 1e-13)  # measured 4e-14, 2e-16
    # the closed forms: free fall for t < 1 (u = 5 - 5 t^2 everywhere, no strain)
    x = np.linspace(0.0, 10.0, 41)[:, None]
    tf = np.linspace(0.0, 1.0, 51)[None, :-1]
    assert np.max(np.abs(ex.u(x, tf) - (5.0 - 5.0 * tf**2))) < 1e-13
    assert np.max(np.abs(ex.ut(x, tf) + 10.0 * tf)) < 1e-12
    assert np.all(ex.stress(tf) == 0.0)
    # first contact: sigma = -rho c (10 + g (t - 1)) from -300 (at t = 1, the limit from
    # the future) towards -500; 0 at the take-off t = 5/3 (limit from the future)
    tc = np.linspace(1.0, 5.0 / 3.0, 41)[:-1]
    assert np.max(np.abs(ex.stress(tc) + 30.0 * (10.0 + 10.0 * (tc - 1.0)))) < 1e-10
    assert ex.stress(1.0) == pytest.approx(-300.0, abs=1e-10)
    assert ex.stress(np.nextafter(5.0 / 3.0, 0.0)) == pytest.approx(-500.0, abs=1e-8)
    assert abs(ex.stress(5.0 / 3.0)) < 1e-10
    ints = np.array(ex.contact_intervals())
    assert np.max(np.abs(ints - [(1.0, 5 / 3), (11 / 3, 13 / 3), (19 / 3, 6.5)])) < 1e-13
    assert np.max(np.abs(ex.energy(np.linspace(0.0, 6.5, 27)) / 500.0 - 1.0)) < 1e-13
    # the corrected series of the seed (4000 modes)
    rng = np.random.default_rng(5)
    xs, ts = rng.uniform(0.0, 10.0, 200), rng.uniform(0.0, 6.5, 200)
    assert np.max(np.abs(ex.u(xs, ts) - series_u(xs, ts))) < SERIES_TRUNCATION
    # the harness's grid (nx = 100, 4 Gauss points per element, dt = 0.002) by runs
    gauss = np.polynomial.legendre.leggauss(4)[0]
    xg = (0.1 * (np.arange(100)[:, None] + 0.5 * (1.0 + gauss))).ravel()
    tg = np.arange(3251) * 0.002
    assert ex._by_runs(xg.size, True, float(xg[-1] - xg[0]))
    got = [np.empty((tg.size, xg.size)) for _ in range(3)]
    ex.fields_into(xg, tg, *got)
    _assert_close(ex, got, _pointwise(ex, xg, tg))
    # two periods and beyond: the default grid past 32 L / c
    assert case.exact(32.0 / 3.0).cells_per_length == 1
    assert case.exact(11.0).cells_per_length == 20000


@pytest.mark.parametrize("mach", [1e-3, 0.01, 0.0123, 0.3, 0.5])
def test_fast_impact_reference_on_one_cell_per_length(mach):
    case = make_case(f"fast_impact[mach={mach}]")
    ex = case.exact(case.T)
    assert ex.cells_per_length == 1 and ex.capped_nodes == 0
    # the default grid is off by up to 1.2e-13 in u (round-off of its 20000 cells)
    _compare_grids(ex, _rebuilt(ex, u0=case.gap, v0=-case.speed), 5e-13, 1e-15)
    # closed form: rigid flight, contact for 2 L / c at stress -E mach, rigid flight back
    t1, v = case.gap / case.speed, case.speed
    (a, b), = ex.contact_intervals()
    assert a == pytest.approx(t1, abs=1e-14) and b == pytest.approx(t1 + 2.0, abs=1e-14)
    rng = np.random.default_rng(6)
    x = rng.uniform(0.0, 1.0, 500)
    t = rng.uniform(0.0, t1, 500)
    assert np.max(np.abs(ex.u(x, t) - (case.gap - v * t))) < 1e-16
    t = rng.uniform(t1 + 2.0, case.T, 500)
    assert np.max(np.abs(ex.u(x, t) - v * (t - t1 - 2.0))) < 1e-15
    assert np.max(np.abs(ex.ut(x, t) - v)) < 1e-15
    tc = rng.uniform(t1, t1 + 2.0, 200)
    assert np.max(np.abs(ex.stress(tc) + mach)) < 1e-15
    assert ex.energy(case.T) == pytest.approx(case.exact_energy, rel=1e-13)


def test_steel_bar_and_rough_data_references_on_one_cell_per_length():
    from contact_bench.cases.rough_data import U0_DATA, V0_DATA
    from contact_bench.cases.steel_bar import GAP, SPEED

    steel = make_case("steel_bar")
    ex = steel.exact(steel.T)
    assert ex.cells_per_length == 1 and ex.capped_nodes == 0
    _compare_grids(ex, _rebuilt(ex, u0=GAP, v0=-SPEED), 1e-16, 1e-16)  # measured 2.4e-17, 0
    t = np.linspace(0.0, 5e-4, 51)
    assert np.max(np.abs(ex.u(0.3, t) - (GAP - SPEED * t))) < 1e-19
    rough = make_case("rough_data")
    ex = rough.exact(rough.T)
    assert ex.cells_per_length == 1 and ex.capped_nodes == 0
    _compare_grids(ex, _rebuilt(ex, u0=U0_DATA, v0=V0_DATA), 1e-14, 1e-14)
    assert np.max(np.abs(ex.energy(np.linspace(0.0, 6.0, 13)) / rough.exact_energy - 1.0)
                  ) < 1e-13
    # the initial data are read exactly
    x = np.linspace(0.0, 1.0, 101)
    assert np.max(np.abs(ex.u(x, 0.0) - np.interp(x, *U0_DATA))) < 1e-15


def test_coarse_solution_falls_back_to_the_default_grid_at_the_node_cap():
    """A smooth pulse on two cells per length: crossings left out at the node cap (a
    coarse grid would smear them over a cell): the default grid instead."""
    from contact_bench.cases.pulse import Pulse

    case = Pulse()
    kw = {"L": 1.0, "E": 1.0, "rho": 1.0, "far_end": "clamped", "u0": case.u0,
          "v0": case.v0, "T": 8.0}
    assert CharacteristicsSolution(cells_per_length=2, **kw).capped_nodes > 0
    sol = coarse_solution(2, **kw)
    assert sol.cells_per_length == 20000 and sol.capped_nodes == 0
    # rough data over a long time: crossings accumulate up to the cap, then the default
    rough = make_case("rough_data")
    assert rough.exact(30.0).cells_per_length == 1
    assert rough.exact(60.0).cells_per_length == 20000
    with pytest.raises(ValueError, match="coarse_solution"):
        coarse_solution(2, ds=0.25, **kw)
