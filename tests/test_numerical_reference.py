"""contact_bench.cases.heterogeneous_bar's `NumericalReference`: the compiled `fields` and
`fields_into`
(what the error norms use) against an independent interpolation (to round-off) and
against the class's numpy `u`, `ux`, `ut` (bitwise), on a small random trajectory."""

from __future__ import annotations

import bisect

import numpy as np
import pytest

from contact_bench.cases.heterogeneous_bar import NumericalReference


def _random_reference(seed: int = 0, nodes: int = 13, samples: int = 9) -> NumericalReference:
    """Non-uniform increasing nodes (not starting at 0), increasing sample times from 0."""
    rng = np.random.default_rng(seed)
    x = 0.3 + np.concatenate([[0.0], np.cumsum(rng.uniform(0.02, 0.3, nodes - 1))])
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.01, 0.5, samples - 1))])
    U = rng.standard_normal((samples, nodes))
    V = rng.standard_normal((samples, nodes))
    S = -rng.uniform(0.0, 1.0, samples)
    return NumericalReference(x, t, U, V, S, "random test trajectory")


def _independent(ref: NumericalReference, xp: float, tp: float) -> tuple[float, float, float]:
    """(u, u_x, u_t) at one point, written out plainly: np.interp in space on the two
    samples around tp (bisect for the sample interval), the slope of the cell (bisect,
    the end cells outside the nodes) linear in time."""
    x, t = ref.x, ref.t
    k = min(max(bisect.bisect_right(list(t), tp) - 1, 0), t.size - 2)
    b = min(max((tp - t[k]) / (t[k + 1] - t[k]), 0.0), 1.0)
    e = min(max(bisect.bisect_right(list(x), xp) - 1, 0), x.size - 2)
    xc = min(max(xp, x[0]), x[-1])  # np.interp holds the end values outside

    def in_time(F: np.ndarray) -> float:
        return (1 - b) * np.interp(xc, x, F[k]) + b * np.interp(xc, x, F[k + 1])

    slope = [(ref.U[j, e + 1] - ref.U[j, e]) / (x[e + 1] - x[e]) for j in (k, k + 1)]
    return in_time(ref.U), (1 - b) * slope[0] + b * slope[1], in_time(ref.V)


def _assert_bitwise(got: np.ndarray, expected: np.ndarray) -> None:
    """Same shape and the same bits (NaN where NaN)."""
    got, expected = np.asarray(got, float), np.asarray(expected, float)
    assert got.shape == expected.shape
    nan = np.isnan(expected)
    np.testing.assert_array_equal(np.isnan(got), nan)
    differ = got[~nan].view(np.int64) != expected[~nan].view(np.int64)
    assert not differ.any(), (f"{differ.sum()} of {differ.size} values differ, by up to "
                              f"{np.abs(got - expected)[~nan].max():.3g}")


def _points(ref: NumericalReference, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Points x: random interior, every node, the ends (x[0], x[-1]) and a little outside;
    times t: random, every sample time (t[0] and t[-1] among them), t[-1] up to the
    tolerated round-off."""
    x = np.concatenate([rng.uniform(ref.x[0], ref.x[-1], 40), ref.x,
                        [ref.x[0], ref.x[-1], ref.x[0] - 0.1, ref.x[-1] + 0.2]])
    x = np.concatenate([x, np.nextafter(ref.x, np.inf), np.nextafter(ref.x, -np.inf)])
    t = np.concatenate([rng.uniform(ref.t[0], ref.t[-1], 7), ref.t,
                        [ref.t[-1] * (1 + 1e-13), np.nextafter(ref.t[1], 0.0)]])
    return x, t


def _fields_into(ref: NumericalReference, x: np.ndarray, t: np.ndarray, velocity: bool = True
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    u, ux = np.full((t.size, x.size), np.nan), np.full((t.size, x.size), np.nan)
    ut = np.full((t.size, x.size), np.nan) if velocity else None
    ref.fields_into(x, t, u, ux, ut)
    return u, ux, ut


@pytest.mark.parametrize("order", ["sorted", "shuffled", "reversed"])
def test_fields_into_equals_the_numpy_evaluation_bitwise(order):
    ref = _random_reference()
    rng = np.random.default_rng(1)
    x, t = _points(ref, rng)
    x = {"sorted": np.sort(x), "shuffled": rng.permutation(x), "reversed": np.sort(x)[::-1]
         }[order]
    u, ux, ut = _fields_into(ref, x, t)
    X, T = x[None, :], t[:, None]
    _assert_bitwise(u, ref.u(X, T))
    _assert_bitwise(ux, ref.ux(X, T))
    _assert_bitwise(ut, ref.ut(X, T))


def test_fields_into_matches_an_independent_interpolation():
    ref = _random_reference(seed=2)
    x, t = _points(ref, np.random.default_rng(3))
    u, ux, ut = _fields_into(ref, x, t)
    expected = np.array([[_independent(ref, xp, tp) for xp in x] for tp in t])
    scale = max(np.abs(ref.U).max(), np.abs(ref.V).max())
    slope_scale = 2 * scale / np.diff(ref.x).min()
    np.testing.assert_allclose(u, expected[..., 0], rtol=0, atol=4e-16 * scale)
    np.testing.assert_allclose(ux, expected[..., 1], rtol=0, atol=4e-16 * slope_scale)
    np.testing.assert_allclose(ut, expected[..., 2], rtol=0, atol=4e-16 * scale)
    # at the nodes and sample times: the stored values themselves
    _assert_bitwise(_fields_into(ref, ref.x, ref.t)[0], ref.U)
    _assert_bitwise(_fields_into(ref, ref.x, ref.t)[2], ref.V)


def test_fields_into_without_velocity_and_odd_points():
    """ut=None leaves the velocity out (u, ux unchanged); infinite and NaN points give
    what the numpy path gives (its clipping: the end cells); empty grids are fine."""
    ref = _random_reference(seed=4)
    x = np.array([-np.inf, np.inf, np.nan, ref.x[3], -0.0, 1e300])
    t = np.array([ref.t[2], -0.0, 0.5 * (ref.t[0] + ref.t[1]), np.nan])
    u, ux, ut = _fields_into(ref, x, t)
    u2, ux2, ut2 = _fields_into(ref, x, t, velocity=False)
    assert ut2 is None
    _assert_bitwise(u2, u)
    _assert_bitwise(ux2, ux)
    X, T = x[None, :], t[:, None]
    for got, f in ((u, ref.u), (ux, ref.ux), (ut, ref.ut)):
        _assert_bitwise(got, f(X, T))
    empty = np.empty((0, x.size))
    ref.fields_into(x, np.empty(0), empty, empty.copy())
    ref.fields_into(np.empty(0), t, np.empty((t.size, 0)), np.empty((t.size, 0)), None)


def test_fields_broadcasts_like_the_numpy_evaluation():
    """`fields` at broadcast points, as the norms call it without `fields_into`: the
    quadrature points (elements, 4) against the times (kb, 1, 1), and scalars."""
    ref = _random_reference(seed=5)
    rng = np.random.default_rng(6)
    X = np.sort(rng.uniform(ref.x[0], ref.x[-1], 24)).reshape(6, 4)
    T = np.concatenate([ref.t[:3], rng.uniform(ref.t[0], ref.t[-1], 4)])[:, None, None]
    u, ux, ut = ref.fields(X, T)
    assert u.shape == ux.shape == ut.shape == (T.shape[0], 6, 4)
    _assert_bitwise(u, ref.u(X, T))
    _assert_bitwise(ux, ref.ux(X, T))
    _assert_bitwise(ut, ref.ut(X, T))
    u2, ux2, none = ref.fields(X, T, velocity=False)
    assert none is None
    _assert_bitwise(u2, u)
    _assert_bitwise(ux2, ux)
    # the same times in a different order along the points (the time lookup is reused)
    xs = rng.uniform(ref.x[0], ref.x[-1], 30)
    ts = np.concatenate([np.repeat(rng.choice(ref.t, 5), 3), rng.uniform(0, ref.t[-1], 15)])
    for got, f in zip(ref.fields(xs, ts), (ref.u, ref.ux, ref.ut), strict=True):
        _assert_bitwise(got, f(xs, ts))
    s = ref.fields(float(ref.x[2]), float(ref.t[1]))
    assert s[0].shape == () and s[0] == ref.U[1, 2] and s[2] == ref.V[1, 2]


def test_times_outside_the_stored_interval_raise_before_writing():
    ref = _random_reference(seed=7)
    x = ref.x[:5]
    for bad in (-1e-9 * ref.t[-1], ref.t[-1] * (1 + 1e-9), np.inf):
        t = np.array([ref.t[1], bad])
        u, ux, ut = (np.full((2, x.size), 7.0) for _ in range(3))
        with pytest.raises(ValueError, match="outside the stored interval") as info:
            ref.fields_into(x, t, u, ux, ut)
        assert repr(bad) in str(info.value) and "\n" not in str(info.value)
        assert (u == 7.0).all() and (ux == 7.0).all() and (ut == 7.0).all()
        for f in (ref.fields, ref.u, ref.ux, ref.ut):
            with pytest.raises(ValueError, match="outside the stored interval"):
                f(x[:, None], t)


def test_fields_into_checks_its_outputs():
    ref = _random_reference(seed=8)
    x, t = ref.x[:5], ref.t[:3]
    good = np.empty((3, 5))
    read_only = np.empty((3, 5))
    read_only.flags.writeable = False
    for bad in (np.empty((3, 4)), np.empty((5, 3)), np.empty((3, 5), np.float32),
                np.empty((3, 5), order="F"), np.empty((3, 10))[:, ::2], read_only,
                [[0.0] * 5] * 3):
        with pytest.raises(ValueError, match="fields_into"):
            ref.fields_into(x, t, bad, good.copy())
        with pytest.raises(ValueError, match="fields_into"):
            ref.fields_into(x, t, good.copy(), good.copy(), bad)
    with pytest.raises(ValueError, match="fields_into"):
        ref.fields_into(x[:, None], t, good, good.copy())


def test_inconsistent_trajectories_are_refused():
    """The kernels index without bounds checks: shapes are checked when it is made."""
    x, t, U = np.linspace(0.0, 1.0, 4), np.linspace(0.0, 1.0, 3), np.zeros((3, 4))
    for args in ((x, t, U[:, :3], U), (x, t, U, U[:2]), (x[:1], t, U[:, :1], U[:, :1]),
                 (x, t[:1], U[:1], U[:1])):
        with pytest.raises(ValueError, match="NumericalReference"):
            NumericalReference(*args, np.zeros(t.size), "bad")


def test_heterogeneous_bar_reference_fields_into_at_quadrature_points():
    """The real reference (a fine run, about half a second) at the default mesh's Gauss
    points, a few sample times of the default run: bitwise the numpy evaluation."""
    from contact_bench.api.fem import mesh_nodes
    from contact_bench.api.registry import make_case

    case = make_case("heterogeneous_bar")
    ref = case.exact(case.T)
    nodes = mesh_nodes(case.L, case.nx)
    gauss = 0.5 + 0.5 * np.polynomial.legendre.leggauss(4)[0]
    x = (nodes[:-1, None] + np.diff(nodes)[:, None] * gauss).ravel()
    t = np.linspace(0.0, case.T, int(round(case.T / case.dt)) + 1)[::40]
    u, ux, ut = _fields_into(ref, x, t)
    X, T = x[None, :], t[:, None]
    _assert_bitwise(u, ref.u(X, T))
    _assert_bitwise(ux, ref.ux(X, T))
    _assert_bitwise(ut, ref.ut(X, T))
