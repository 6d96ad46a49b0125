"""`fields_into` on sorted points sparse in the cells (`_sparse_kernel`).

contact_bench.exact.characteristics evaluates the Gauss points of a mesh against the sample times
on a
fine grid (one or two points per cell: the smooth scenes pulse and grazing) 8 points at
a time, guessing each point's cell from its block's nodes off the base grid and checking
the guess (module docstring, "Evaluation on a grid"). The values must be those of the
pointwise kernel (`_grid_kernel`, itself checked equal to `fields`) bit for bit, on
pulse-like and grazing-like solutions (smooth data, clamped and free far ends, contact
periods), with gravity, at nodes, at x = 0 and x = L, at t = 0, t = T, at impact times
and block boundaries, for any number of points and times.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from contact_bench.api.plugin import Fields
from contact_bench.cases.pulse import Pulse
from contact_bench.exact.characteristics import (
    CharacteristicsSolution,
    SparseGuess,
    _exact_cell,
    _first_guess,
    _grid_kernel,
    _locate,
    _sparse_kernel,
)

_GAUSS = np.polynomial.legendre.leggauss(4)[0]


def _head(sol, x, t):
    return (x, sol.c * t, sol._stored())


def _pointwise(sol, x, t):
    """u, u_x, u_t by the pointwise kernel, checked equal to `fields` (bitwise)."""
    out = [np.full((t.size, x.size), np.nan) for _ in range(3)]
    _grid_kernel(*_head(sol, x, t), sol._table(), Fields(*out))
    X, T = np.broadcast_arrays(x[None, :], t[:, None])
    for got, want in zip(out, sol.fields(X, T), strict=True):
        np.testing.assert_array_equal(got, want)
    return out


def _sparse(sol, x, t, guess=None, velocity=True):
    """u, u_x, u_t (None without velocity) by `_sparse_kernel`, and its count of
    (8 points, sample time) whose cells were not all guessed."""
    out = [np.full((t.size, x.size), np.nan) for _ in range(3)]
    ut = out[2] if velocity else np.empty((0, 0))
    guessed = _sparse_kernel(*_head(sol, x, t), guess or sol._sparse_guess(),
                             Fields(out[0], out[1], ut))
    return out[:2] + [out[2] if velocity else None], guessed


def _assert_same(got, want):
    names = ("u", "u_x", "u_t")[:len(want)]
    for name, g, w in zip(names, got, want, strict=True):
        np.testing.assert_array_equal(g, w, err_msg=name)


def _pulse_like(cells, far_end="clamped", T=8.0):
    """The scene pulse (smooth compact pulse, 4 impacts) on a coarser fine grid."""
    case = Pulse()
    return CharacteristicsSolution(L=1.0, E=1.0, rho=1.0, far_end=far_end, u_L=0.0,
                                   u0=case.u0, v0=case.v0, T=T, cells_per_length=cells)


def _grazing_like(cells, far_end="free", T=4.0):
    """The scene grazing (first free-free mode touching the obstacle) on a fine grid."""
    return CharacteristicsSolution(L=1.0, E=1.0, rho=1.0, far_end=far_end, u_L=0.0,
                                   u0=lambda x: 0.1 * (1.0 + np.cos(np.pi * x)), v0=0.0,
                                   T=T, cells_per_length=cells)


def _solutions():
    return {
        "pulse, clamped": _pulse_like(2000),
        "pulse, free": _pulse_like(2000, far_end="free", T=6.0),
        "grazing, free": _grazing_like(2000),
        "grazing, clamped end data": CharacteristicsSolution(
            L=2.0, E=4.0, rho=1.0, far_end="clamped", u_L=0.0,
            u0=lambda x: 0.05 * (1.0 + np.cos(np.pi * x / 4.0)) * (2.0 - x),
            v0=lambda x: -0.3 * np.sin(np.pi * x / 2.0), T=5.0, cells_per_length=1500),
        "gravity, free, inserted nodes": CharacteristicsSolution(
            L=1.0, E=1.0, rho=1.0, g=9.81, far_end="free", u0=0.05, v0=0.0, T=3.0,
            cells_per_length=700),
        "gravity, clamped, u_L": CharacteristicsSolution(
            L=2.0, E=9.0, rho=1.0, g=3.0, far_end="clamped", u_L=0.2,
            u0=lambda x: 0.2 + 0.25 * (2.0 - x), v0=-0.3, T=4.0, cells_per_length=900),
        "tuple data, kinks off the grid": CharacteristicsSolution(
            L=1.0, E=4.0, rho=1.0, far_end="free",
            u0=((0.0, 0.30037, 1.0), (0.1, 0.0, 0.0)),
            v0=((0.0, 0.50071, 0.50071, 1.0), (0.0, 0.0, -1.0, -1.0)), T=2.0,
            cells_per_length=1000),
    }


SOLUTIONS = _solutions()


def _gauss_points(L, nel):
    """The 4 Gauss points of nel equal elements (sorted), as the error norms pass them."""
    h = L / nel
    return (h * (np.arange(nel)[:, None] + 0.5 * (1.0 + _GAUSS))).ravel()


def _times(sol, size, seed=0):
    """Sample times (not sorted): a grid, t = 0, T, the contact periods' ends, the block
    boundaries tau = k L (and the doubles below), multiples of ds / c, random times."""
    rng = np.random.default_rng(seed)
    T = sol.T
    ends = np.array([t for ab in sol.contact_intervals() for t in ab])
    blocks = np.arange(0.0, sol.c * T, sol.L) / sol.c
    nodes = np.arange(0, 40) * 37.0 * sol.ds / sol.c
    t = np.concatenate((np.linspace(0.0, T, size), [0.0, T], ends, blocks,
                        np.nextafter(blocks[1:], 0.0), nodes, rng.uniform(0.0, T, 30)))
    return np.clip(t, 0.0, T)


@pytest.mark.parametrize("name", list(SOLUTIONS))
def test_sparse_kernel_is_the_pointwise_kernel_bit_for_bit(name):
    sol = SOLUTIONS[name]
    L = sol.L
    assert sol._sparse_table() is not None
    # the norms' grid: the guesses hold (all but round-off at nodes)
    x = _gauss_points(L, 30)
    t = np.linspace(0.0, sol.T, 200)
    got, guessed = _sparse(sol, x, t)
    _assert_same(got, _pointwise(sol, x, t))
    assert guessed <= 0.002 * t.size * math.ceil(x.size / 8)
    # and x = 0, x = L, nodes of the base grid, a duplicate; t at contacts, nodes, ...
    x = np.sort(np.concatenate((x, [0.0, L, x[7]], np.arange(1, 6) * 97 * sol.ds)))
    t = _times(sol, 150)
    want = _pointwise(sol, x, t)
    got, _ = _sparse(sol, x, t)
    _assert_same(got, want)
    # the same through `fields_into` (which takes this kernel), also without u_t
    assert sol._evaluation(x.size, True, L) == "sparse"
    out = [np.full((t.size, x.size), np.nan) for _ in range(3)]
    sol.fields_into(x, t, *out)
    _assert_same(out, want)
    u, ux = np.zeros_like(out[0]), np.zeros_like(out[0])
    sol.fields_into(x, t, u, ux)
    _assert_same((u, ux), want[:2])


def test_the_pulse_grid_has_nodes_off_the_base_grid_and_the_grazing_grid_none():
    """The table of the guesses: per block the inserted nodes (pulse: its impacts), their
    count that of the block's extra nodes; none on a uniform grid."""
    pulse, grazing = SOLUTIONS["pulse, clamped"], SOLUTIONS["grazing, free"]
    xz, xs, cend = pulse._sparse_table()
    assert not pulse._uniform and pulse.inserted_nodes > 0
    np.testing.assert_array_equal(np.diff(xs), pulse._sizes - pulse.cells_per_length - 1)
    assert xz.size > 0 and np.all((xz > 0.0) & (xz < pulse.L))
    np.testing.assert_array_equal(cend + 1, np.append(pulse._cell0[1:], pulse._ncells))
    xz, xs, _ = grazing._sparse_table()
    assert grazing._uniform and xz.size == 0 and np.all(xs == 0)
    kinks = SOLUTIONS["tuple data, kinks off the grid"]._sparse_table()
    assert kinks[1][1] >= 2  # the kinks (and L - kinks) in block 0, every block


@pytest.mark.parametrize("points", [1, 2, 7, 8, 9, 17, 63])
@pytest.mark.parametrize("times", [1, 2, 65, 130])
def test_any_number_of_points_and_times(points, times):
    """Points in chunks of 8 and sample times in groups: every (point, time) written,
    nothing past the last point (the arrays are views of a larger one)."""
    sol = SOLUTIONS["pulse, clamped"]
    rng = np.random.default_rng(points * 1000 + times)
    x = np.sort(rng.uniform(0.0, sol.L, points))
    t = np.sort(rng.uniform(0.0, sol.T, times))
    want = _pointwise(sol, x, t)
    flat = np.full(3 * times * points + 11, -7.0)  # consecutive outputs: no overlap
    outs = [flat[k * times * points:(k + 1) * times * points].reshape(times, points)
            for k in range(3)]
    _sparse_kernel(*_head(sol, x, t), sol._sparse_guess(), Fields(*outs))
    _assert_same(outs, want)
    assert np.all(flat[3 * times * points:] == -7.0)


def test_single_point_single_time_and_the_ends_of_the_bar():
    sol = SOLUTIONS["grazing, free"]
    for x in ([0.0], [sol.L], [0.0, sol.L], [0.37]):
        x = np.array(x)
        for t in ([0.0], [sol.T], [1.0], [0.0, 1.0, sol.T]):
            t = np.array(t)
            got, _ = _sparse(sol, x, t)
            _assert_same(got, _pointwise(sol, x, t))
            got, _ = _sparse(sol, x, t, velocity=False)
            _assert_same(got[:2], _pointwise(sol, x, t)[:2])


@pytest.mark.parametrize("name", ["pulse, clamped", "gravity, free, inserted nodes",
                                  "tuple data, kinks off the grid"])
def test_lanes_whose_guess_fails_get_the_cells_of_the_pointwise_search(name):
    """With a wrong table (nodes off the grid moved, or dropped) the guesses fail and
    those lanes take `_locate`'s own search: still the pointwise values, bit for bit."""
    sol = SOLUTIONS[name]
    x = _gauss_points(sol.L, 12)
    t = _times(sol, 60, seed=3)
    want = _pointwise(sol, x, t)
    uniform, nlut, s0, xz, xs, cend = sol._sparse_guess()
    for wrong in (np.clip(xz + 3.5 * sol.ds, 0.0, sol.L), np.zeros_like(xz)):
        got, guessed = _sparse(sol, x, t, SparseGuess(uniform, nlut, s0, wrong, xs, cend))
        _assert_same(got, want)
        assert guessed > 0
    # no table at all: every guess of a block with such nodes is off after them
    got, guessed = _sparse(sol, x, t, SparseGuess(uniform, nlut, s0, np.empty(0),
                                                  np.zeros_like(xs), cend))
    _assert_same(got, want)
    assert guessed > 0


def test_exact_cell_is_locate():
    """The fallback's search: the lookup table's guess found without the table, its check,
    `_cell_of`: the cells of `_locate`, at random points, nodes and block ends."""
    for name in ("pulse, clamped", "grazing, free", "gravity, free, inserted nodes"):
        sol = SOLUTIONS[name]
        rng = np.random.default_rng(1)
        K = sol._cell0.size - 1
        k = rng.integers(0, K + 1, 3000).astype(float)
        r = np.concatenate((rng.uniform(0.0, sol.L, 2000),
                            sol._r[rng.integers(0, sol._r.size, 990)],
                            np.zeros(5), np.nextafter(np.full(5, sol.L), 0.0)))
        ii, bb = np.empty(k.size, np.int64), np.empty(k.size, np.int64)
        _locate(k, r, sol._stored(), sol._table(), ii, bb)
        guess = sol._sparse_guess()
        for n in range(k.size):
            assert _exact_cell(k[n], r[n], sol.L, sol.ds, guess, sol._cell0, sol._r,
                               sol._ncells - 1) == (ii[n], bb[n])


def test_first_guess_is_the_lookup_table():
    """The fallback's first guess: the lookup table's entry without the table (the same
    search), the bin itself on a uniform grid."""
    for name in ("pulse, clamped", "grazing, free", "tuple data, kinks off the grid"):
        sol = SOLUTIONS[name]
        uniform, nlut, s0 = sol._sparse_guess()[:3]
        rng = np.random.default_rng(2)
        K = sol._cell0.size - 1
        k = rng.integers(-1, K + 3, 2000).astype(float)
        r = np.concatenate((rng.uniform(0.0, sol.L, 1500), sol._r[rng.integers(
            0, sol._r.size, 490)], np.zeros(5), np.nextafter(np.full(5, sol.L), 0.0)))
        g = np.floor((k * sol.L + r) * (1.0 / sol.ds)).astype(np.int64)
        if uniform:
            want = np.clip(g, 0, sol._ncells - 1)
        else:
            lut = sol._lookup_table()
            assert nlut == lut.size - 1
            want = lut[np.clip(g, 0, nlut)]
        got = [_first_guess(k[n], r[n], sol.L, sol.ds, uniform, nlut, s0, sol._ncells - 1)
               for n in range(k.size)]
        np.testing.assert_array_equal(got, want)


def test_coordinates_rounded_across_the_block_end():
    """Points whose local coordinate rounds to L (q: (L - x) + rho with x just above rho)
    or below 0 (p: (x - L) + rho with x + rho >= L): `_normal`'s cases, lane by lane."""
    for name in ("pulse, clamped", "gravity, clamped, u_L"):
        sol = SOLUTIONS[name]
        L = sol.L
        rng = np.random.default_rng(4)
        # (p's case needs rho's last bits: times in the first block have them)
        t = np.sort(np.concatenate((rng.uniform(0.0, sol.T, 60),
                                    rng.uniform(0.0, L / sol.c, 60))))
        xs, cases = [], [0, 0]
        for tn in sol.c * t:  # rho as the kernels round it
            k = math.floor(tn / L)
            rho = tn - k * L
            for x0, d in ((rho, 1), (L - rho, -3), (L - rho, -1), (L - rho, 1), (L - rho, 3)):
                x = x0
                for _ in range(abs(d)):
                    x = float(np.nextafter(x, np.inf if d > 0 else -np.inf))
                q_case = rho - x < 0.0 and (L - x) + rho >= L
                p_case = x + rho >= L and (x - L) + rho < 0.0
                if 0.0 <= x <= L and (q_case or p_case):
                    xs.append(x)
                    cases[int(p_case)] += 1
        assert min(cases) >= 5
        x = np.sort(np.array(xs))
        got, _ = _sparse(sol, x, t)
        _assert_same(got, _pointwise(sol, x, t))


def test_points_on_nodes_off_the_base_grid_are_guessed():
    """Points whose r is exactly a node off the base grid (a kink of the data): the count
    of such nodes at or below r includes the node itself. At t = 0, x on the kinks (p and
    q in block 0); at x = 0, tau = c t on a kink (q in block 1: r = rho - 0)."""
    sol = SOLUTIONS["tuple data, kinks off the grid"]
    assert sol.c == 2.0  # t = z / c exactly
    xz, xs, _ = sol._sparse_table()
    x = np.sort(xz[xs[0]:xs[1]])
    t = np.array([0.0])
    got, guessed = _sparse(sol, x, t)
    _assert_same(got, _pointwise(sol, x, t))
    assert guessed == 0
    x = np.array([0.0])
    t = xz[xs[1]:xs[2]] / sol.c
    got, guessed = _sparse(sol, x, t)
    _assert_same(got, _pointwise(sol, x, t))
    assert guessed == 0


def test_dispatch_sparse_for_sorted_sparse_points_only(monkeypatch):
    """`_evaluation`: sorted points sparse in the cells -> the sparse kernel; unsorted ->
    the pointwise kernel; dense -> runs; and `fields_into` calls what it says. The sparse
    and the pointwise ways give the same bits."""
    import contact_bench.exact.characteristics as ch

    sol = SOLUTIONS["pulse, clamped"]
    x = _gauss_points(sol.L, 20)
    t = np.linspace(0.0, sol.T, 40)
    want = _pointwise(sol, x, t)
    span = float(x[-1] - x[0])
    assert sol._evaluation(x.size, True, span) == "sparse"
    assert sol._evaluation(x.size, False, span) == "points"
    assert sol._evaluation(1, True, 0.0) == "sparse"
    assert sol._evaluation(8 * sol.cells_per_length, True, sol.L) == "runs"
    assert _pulse_like(10)._evaluation(x.size, True, span) == "runs"  # coarse: dense
    calls = []
    real = ch._fields_grid
    monkeypatch.setattr(ch, "_fields_grid", lambda how, *a: (calls.append(how),
                                                              real(how, *a))[1])
    for xs, cols, how in ((x, slice(None), "sparse"), (x[::-1], slice(None, None, -1),
                                                       "points")):
        calls.clear()
        out = [np.full((t.size, x.size), np.nan) for _ in range(3)]
        sol.fields_into(xs, t, *out)
        assert calls == [ch._HOW[how]]
        _assert_same([o[:, cols] for o in out], want)


def test_grids_with_many_nodes_off_the_base_grid_stay_pointwise():
    """More nodes off the base grid per block than the guess counts (_SPARSE_EXTRA): no
    table, the pointwise kernel."""
    xk = np.linspace(0.0, 1.0, 40) + 0.3 / 500.0
    xk[0], xk[-1] = 0.0, 1.0
    sol = CharacteristicsSolution(L=1.0, E=1.0, rho=1.0, far_end="free",
                                  u0=(xk, 0.01 * np.sin(7.0 * xk) + 0.02), v0=0.0, T=1.0,
                                  cells_per_length=500)
    assert sol._sparse_table() is None
    x = _gauss_points(1.0, 10)
    assert sol._evaluation(x.size, True, 1.0) == "points"
    out = [np.full((3, x.size), np.nan) for _ in range(3)]
    t = np.array([0.0, 0.4, 1.0])
    sol.fields_into(x, t, *out)
    _assert_same(out, _pointwise(sol, x, t))
