"""The d'Alembert solution (`contact_bench.exact.dalembert`, pulse's reference) against independent
computations: the characteristics solution of the same data (which converges to it:
O(ds^2) on u, O(ds) on the slopes), the energy of the data (conserved by the exact
solution), the Signorini conditions, and its own compiled paths (the same bits)."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from contact_bench.cases.pulse import _V, _u0
from contact_bench.core.simd import vload, vrows4, vstore
from contact_bench.exact.characteristics import CharacteristicsSolution
from contact_bench.exact.dalembert import DalembertSolution

SHIFT = 0.05  # a clamped variant with u_L != 0: the data shifted by a constant


def _shifted(x):
    u, du = _u0(x)
    return u + SHIFT, du


# far end, u_L, T, u0 (closed form) for the three variants
VARIANTS = {
    "clamped": ("clamped", 0.0, 8.0, _u0),
    "free": ("free", 0.0, 6.0, _u0),
    "clamped, u_L": ("clamped", SHIFT, 8.0, _shifted),
}


def _dalembert(name, **kw):
    far_end, u_L, T, u0 = VARIANTS[name]
    return DalembertSolution(L=1.0, E=1.0, rho=1.0, far_end=far_end, u_L=u_L, u0=u0, V=_V,
                             T=T, **kw)


def _characteristics(name, cells):
    far_end, u_L, T, u0 = VARIANTS[name]
    return CharacteristicsSolution(L=1.0, E=1.0, rho=1.0, far_end=far_end, u_L=u_L,
                                   u0=lambda x: u0(x)[0], v0=lambda x: _V(x)[1], T=T,
                                   cells_per_length=cells)


def _random_points(T, size=20000, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(0.0, 1.0, size), rng.uniform(0.0, T, size)


@pytest.mark.parametrize("name", list(VARIANTS))
def test_the_characteristics_solution_converges_to_it(name):
    """On 1000 and 4000 cells per length the characteristics solution's distance to the
    d'Alembert solution falls like ds^2 on u and on the first impact (found from values),
    like ds on the take-offs (found from chord slopes) and the later impacts that follow
    from them, and like ds on u_x and u_t away from the kinks (its chord slopes)."""
    sol = _dalembert(name)
    x, t = _random_points(sol.T)
    runs = np.array(sol.contact_intervals())
    assert runs.shape[0] >= 1
    dist = {}
    for cells in (1000, 4000):
        ref = _characteristics(name, cells)
        other = np.array(ref.contact_intervals())
        assert other.shape == runs.shape
        a, b = sol.fields(x, t), ref.fields(x, t)
        ds = 1.0 / cells
        y, z = x + t, x - t  # off the kinks by 2 cells (where the chords straddle them)
        kinks = np.concatenate((sol._p[0], sol._q[0]))
        away = np.min(np.abs(np.concatenate((y, z))[:, None] - kinks[None, :]), axis=1)
        away = (away[: x.size] > 2 * ds) & (away[x.size:] > 2 * ds)
        dist[cells] = (np.abs(a[0] - b[0]).max(), abs(runs[0, 0] - other[0, 0]),
                       np.abs(runs - other).max(),
                       np.abs(a[1] - b[1])[away].max(), np.abs(a[2] - b[2])[away].max())
    coarse, fine = dist[1000], dist[4000]
    assert fine[0] < 2e-6 and 8.0 < coarse[0] / fine[0] < 32.0, (coarse, fine)  # u: 16
    assert fine[1] < 1e-7 and coarse[1] / fine[1] > 8.0, (coarse, fine)  # first impact
    assert fine[2] <= 1.01 / 4000, (coarse, fine)  # within a cell
    for k in (3, 4):  # slopes: ds
        assert fine[k] < 0.05 and 2.0 < coarse[k] / fine[k] < 8.0, (k, coarse, fine)


@pytest.mark.parametrize("name", list(VARIANTS))
def test_the_fields_conserve_the_energy_of_the_data(name):
    """1/2 int (u_t^2 + u_x^2) dx of the fields (Gauss quadrature, 8 points on 2000
    cells) at times before, during and between contacts equals that of the data (u0',
    v0 by the same quadrature): the exact solution of the elastic impact loses none."""
    sol = _dalembert(name)
    g, w = np.polynomial.legendre.leggauss(8)
    nodes = np.linspace(0.0, 1.0, 2001)
    half = 0.5 * np.diff(nodes)
    xq = ((nodes[:-1] + half)[:, None] + half[:, None] * g).ravel()
    wq = (half[:, None] * w).ravel()
    data = 0.5 * np.sum(wq * (sol._u0(xq)[1] ** 2 + _V(xq)[1] ** 2))
    assert sol.energy(0.0) == pytest.approx(data, rel=1e-12)
    (a, b), *_ = sol.contact_intervals()
    for t in (0.0, 0.3, a, 0.5 * (a + b), b, 1.7, 3.3, sol.T):
        _, ux, ut = sol.fields(xq, t)
        assert 0.5 * np.sum(wq * (ux**2 + ut**2)) == pytest.approx(data, rel=1e-10), t


@pytest.mark.parametrize("name", list(VARIANTS))
def test_signorini_holds_at_the_end(name):
    """u(0, t) >= 0, E u_x(0, t) <= 0 and their product is 0; in contact u(0, t) = 0, off
    it the stress is 0; at an impact the stress is that of the contact (limit t -> t+:
    the impacts at the image of a take-off start with zero stress, to the table's 2e-8
    on slopes), at a take-off 0."""
    sol = _dalembert(name)
    t = np.linspace(0.0, sol.T, 20001)
    u, s = sol.contact_displacement(t), sol.stress(t)
    assert u.min() > -1e-14 and s.max() < 1e-12
    assert np.abs(u * s).max() < 1e-14
    inside = np.zeros(t.size, bool)
    for a, b in sol.contact_intervals():
        inside |= (t > a) & (t < b)
        assert sol.stress(a) < 1e-7 and sol.stress(a) == pytest.approx(
            float(sol.stress(a + 1e-9)), abs=1e-6)
        if b < sol.T:
            assert abs(float(sol.stress(b))) < 1e-6 and sol.contact_displacement(b) < 1e-14
    assert np.abs(u[inside]).max() < 1e-14 and s[inside].max() < 0.0
    assert np.abs(s[~inside]).max() < 1e-6  # O(dt) from the end of a contact


def test_the_table_error_is_that_of_the_cubic():
    """Against the closed forms of B and B': 1e-12 and 1e-7 on the default table, and
    O(h^4), O(h^3) when its cells are halved."""
    v, d = _dalembert("clamped").table_error()
    assert v < 1e-12 and d < 1e-7
    v2, d2 = _dalembert("clamped", cells_per_length=5000).table_error()
    assert 10.0 < v2 / v < 22.0 and 6.0 < d2 / d < 10.0, (v, v2, d, d2)


def test_every_path_gives_the_same_bits():
    """`fields` (point by point) and `fields_into` (sorted x: by runs, 8 lanes at a time;
    unsorted: point by point; without u_t) give the same bits, also at points on the
    kinks and at the contact instants."""
    sol = _dalembert("clamped")
    rng = np.random.default_rng(3)
    kinks = sol._p[0][(sol._p[0] > 0.0) & (sol._p[0] < 1.0 + sol.T)]
    t = np.concatenate((np.ravel(sol.contact_intervals()), rng.uniform(0.0, sol.T, 37)))
    t = t[t <= sol.T]
    x = np.sort(np.concatenate((rng.uniform(0.0, 1.0, 301), [0.0, 0.0, 0.5, 1.0],
                                np.clip(kinks - t[0], 0.0, 1.0))))
    for xs in (x, rng.permutation(x), x[3:8]):
        want = sol.fields(xs[None, :], t[:, None])
        u, ux, ut = (np.empty((t.size, xs.size)) for _ in range(3))
        sol.fields_into(xs, t, u, ux, ut)
        for got, expected in zip((u, ux, ut), want, strict=True):
            np.testing.assert_array_equal(got, expected)
        u2, ux2 = np.empty_like(u), np.empty_like(u)
        sol.fields_into(xs, t, u2, ux2)  # without u_t
        np.testing.assert_array_equal(u2, want[0])
        np.testing.assert_array_equal(ux2, want[1])
    np.testing.assert_array_equal(sol.u(x[None, :], t[:, None]), sol.fields(x, t[:, None])[0])
    np.testing.assert_array_equal(sol.ut(x, t[:, None]), sol.fields(x, t[:, None])[2])


@pytest.mark.parametrize(("kw", "message"), [
    ({"L": 0.0}, "L must be positive and finite, got 0.0"),
    ({"T": -1.0}, "T must be positive and finite, got -1.0"),
    ({"far_end": "fixed"}, "far_end must be 'clamped' or 'free', got 'fixed'"),
    ({"cells_per_length": 0}, "cells_per_length must be a positive integer, got 0"),
    ({"u_L": 0.3}, "clamped end: u0(L) = 0.0 must equal u_L = 0.3"),
    ({"u0": lambda x: (_u0(x)[0] - 0.2, _u0(x)[1]), "far_end": "free"},
     "u0(0) must be >= 0 (obstacle constraint), got -0.1"),
    ({"V": lambda x: (_V(x)[0] + 1.0, _V(x)[1])}, "V(0) must be 0 (V = int_0^x v0), got 1.0"),
])
def test_bad_input_is_refused_in_one_line_naming_the_value(kw, message):
    args = {"L": 1.0, "E": 1.0, "rho": 1.0, "u0": _u0, "V": _V, "T": 1.0, **kw}
    with pytest.raises(ValueError) as err:
        DalembertSolution(**args)
    assert str(err.value) == message


def test_points_outside_are_refused_in_one_line_naming_the_value():
    sol = _dalembert("clamped")
    with pytest.raises(ValueError, match=r"^t = 8.5 outside the stored interval \[0, T=8.0\]$"):
        sol.u(0.5, [1.0, 8.5])
    with pytest.raises(ValueError, match=r"^x = -0.5 outside the bar \[0, L=1.0\]$"):
        sol.fields_into(np.array([-0.5, 0.5]), np.array([1.0]), np.empty((1, 2)),
                        np.empty((1, 2)))


@njit(cache=True)
def _columns(tab, f, out):  # pragma: no cover - compiled
    c0, c1, c2, c3 = vrows4(tab, vload(f, 0))
    vstore(out[0], 0, c0)
    vstore(out[1], 0, c1)
    vstore(out[2], 0, c2)
    vstore(out[3], 0, c3)


def test_the_rows_of_8_lanes_are_transposed_into_4_columns():
    """`vrows4` (the kernel's table lookup): column c lane k is tab[f[k], c], against
    numpy's indexing, with repeated, first and last rows; the table is 32-byte aligned."""
    tab = np.arange(400.0).reshape(100, 4) * 1.5 - 7.0
    f = np.array([3.0, 99.0, 0.0, 50.0, 12.0, 12.0, 1.0, 98.0])
    out = np.empty((4, 8))
    _columns(tab, f, out)
    np.testing.assert_array_equal(out, tab[f.astype(int)].T)
    assert _dalembert("clamped")._table.ctypes.data % 32 == 0
