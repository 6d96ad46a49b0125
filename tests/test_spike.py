"""The partitioned tridiagonal solver (`contact_bench.core.spike`) against LAPACK's banded
solver."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sl

from contact_bench.core.spike import LANES, spike_factor, spike_solve


def _system(kind: str, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    if kind == "random":  # diagonally dominant, varying coefficients
        e = rng.uniform(-1.0, 1.0, n - 1)
        d = np.abs(np.r_[e, 0.0]) + np.abs(np.r_[0.0, e]) + rng.uniform(0.1, 2.0, n)
        return d, e
    if kind == "mass":  # P1 consistent mass: spikes decay by 2 - sqrt 3 per node
        return np.full(n, 4.0 / 6.0), np.full(n - 1, 1.0 / 6.0)
    # M + dt^2/4 K at CFL 10: the spikes decay by only ~0.82 per node
    nu2 = 100.0
    return np.full(n, 4.0 / 6.0 + 0.5 * nu2), np.full(n - 1, 1.0 / 6.0 - 0.25 * nu2)


@pytest.mark.parametrize("kind", ["random", "mass", "slow_decay"])
@pytest.mark.parametrize("n", [2, 3, LANES - 1, LANES, LANES + 1, 2 * LANES + 1, 100, 1003])
def test_spike_solve_matches_lapack(kind: str, n: int) -> None:
    rng = np.random.default_rng(n)
    d, e = _system(kind, n, rng)
    f = spike_factor(d, e)
    r = rng.standard_normal(n)
    z = f.to_lanes(r)
    coef = np.zeros(2 * f.lanes + 1)
    spike_solve(f.factors(), z, coef)
    band = np.zeros((2, n))
    band[0, 1:], band[1] = e, d
    expected = sl.solveh_banded(band, r)
    x = f.to_natural(z)
    assert np.abs(x - expected).max() <= 1e-13 * np.abs(expected).max()
    padding = np.ones(z.size, bool)
    padding[f.pos] = False
    assert np.all(z[padding] == 0.0)
    # x[0] from the reduced system, and the response to a unit force on node 0
    assert coef[-1] == pytest.approx(expected[0], rel=1e-12, abs=1e-14)
    e0 = np.zeros(n)
    e0[0] = 1.0
    assert f.w0 == pytest.approx(sl.solveh_banded(band, e0)[0], rel=1e-13)


def test_layout_round_trip_and_truncation() -> None:
    n = 10_000
    d, e = _system("mass", n, np.random.default_rng(0))
    f = spike_factor(d, e)
    x = np.arange(n, dtype=float)
    assert np.array_equal(f.to_natural(f.to_lanes(x)), x)
    # node c m + j sits at row j of lane c
    assert f.to_lanes(x)[1 * f.lanes + 2] == 2 * f.m + 1
    # the mass matrix's spikes decay by 0.268 per node: 1e-20 is reached in ~35 rows
    assert f.ja < 40 and f.jb < 40 < f.m
    # the reduced map is banded: far-apart blocks are dropped
    assert f.Hval.size < 8 * (2 * f.lanes + 1)
