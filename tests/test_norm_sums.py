"""The compiled error-norm kernels of `contact_bench.harness.metrics` (explicit SIMD,
`contact_bench.core.simd`).

- Both kernels equal an independent computation: numpy terms of the same expressions,
  summed exactly (math.fsum) sample by sample, to 1e-14 relative (the kernels' partial
  sums run over at most 64 terms per lane: about 70 roundings at worst), on small
  random blocks: odd element counts, fewer than one vector of elements, counts off the
  vector width, a clamped last node (u_fixed != 0) or the last three, all nodes free,
  with and without velocities, samples and nodes off the block's start (row0, lo > 0).
- They follow their documented summation order bit for bit (per point over a leaf of
  64 elements, leaf sums added in order), and the cold kernel's errors are the warm
  kernel's, bit for bit (what the kept reference values rely on).
- Their vector loads refuse arrays that are not C-contiguous (a typing error, not
  wrong addresses).
- The time norms (one compiled call) are numpy's np.max / np.trapezoid of the same
  series, bit for bit (numpy's pairwise summation walked the same way), and fill the
  columns of what the reference provides only.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba.core.errors import TypingError

from contact_bench.api.plugin import Fields
from contact_bench.api.registry import make_case
from contact_bench.harness import metrics
from contact_bench.harness.metrics import (
    _LEAF,
    Nodal,
    Quadrature,
    SampleSums,
    _error_and_exact_sums,
    _error_sums,
)
from contact_bench.harness.runner import reference, run_one

K = 7  # rows of the trajectory
ROW0 = 2  # first sample of the block
KB = 3  # samples in the block
LO = 5  # first node of the block
U_FIXED = 0.7


def _block(ne: int, nodes: str, seed: int) -> dict:
    """Random block of ne elements on nodes LO .. LO + ne; nodes >= nfree are clamped."""
    rng = np.random.default_rng(seed)
    nfree = {"clamped": LO + ne, "clamped3": LO + ne - 2, "free": LO + ne + 3}[nodes]
    nfree = max(nfree, 1)
    return {
        "U": rng.standard_normal((K, nfree)), "V": rng.standard_normal((K, nfree)),
        "nfree": nfree,
        "p0": rng.random(4), "p1": rng.random(4),
        "g0": rng.standard_normal(ne), "g1": rng.standard_normal(ne),
        "w": rng.random((ne, 4)) + 0.1,
        "u": rng.standard_normal((KB, ne, 4)), "ux": rng.standard_normal((KB, ne, 4)),
        "v": rng.standard_normal((KB, ne, 4)),
        "start": rng.random((6, K)),  # the accumulators' values before the call
    }


def _terms(b: dict, k: int, use_v: bool) -> dict[str, np.ndarray]:
    """(elements, 4) terms of sample ROW0 + k, by numpy, in the kernels' expressions."""
    ne = b["w"].shape[0]
    row = ROW0 + k
    j = LO + np.arange(ne)

    def nodal(X, fixed):
        full = np.concatenate([X[row], np.full(LO + ne + 1, fixed)])  # >= nfree: clamped
        return full[j], full[j + 1]

    w, p0, p1 = b["w"], b["p0"], b["p1"]
    a, c = nodal(b["U"], U_FIXED)
    d = (a[:, None] * p0 + c[:, None] * p1) - b["u"][k]
    gx = a * b["g0"] + c * b["g1"]
    dx = gx[:, None] - b["ux"][k]
    out = {"eu": w * (d * d), "eux": w * (dx * dx),
           "nu": w * (b["u"][k] * b["u"][k]), "nux": w * (b["ux"][k] * b["ux"][k])}
    if use_v:
        a, c = nodal(b["V"], 0.0)
        d = (a[:, None] * p0 + c[:, None] * p1) - b["v"][k]
        out["ev"] = w * (d * d)
        out["nv"] = w * (b["v"][k] * b["v"][k])
    return out


NAMES = ("eu", "eux", "ev", "nu", "nux", "nv")


def _sums(n: dict) -> tuple[SampleSums, SampleSums]:
    """The error and exact `SampleSums` of the per-sample norms n."""
    return SampleSums(n["eu"], n["eux"], n["ev"]), SampleSums(n["nu"], n["nux"], n["nv"])


def _run(b: dict, use_v: bool, cold: bool) -> dict[str, np.ndarray]:
    acc = {n: b["start"][i].copy() for i, n in enumerate(NAMES)}
    V, v = (b["V"], b["v"]) if use_v else (b["U"], b["u"])
    args = (Nodal(b["U"], V, use_v, ROW0, LO, b["nfree"], U_FIXED),
            Quadrature(b["p0"], b["p1"], b["g0"], b["g1"], b["w"]), Fields(b["u"], b["ux"], v),
            SampleSums(acc["eu"], acc["eux"], acc["ev"]))
    if cold:
        _error_and_exact_sums(*args, SampleSums(acc["nu"], acc["nux"], acc["nv"]))
    else:
        _error_sums(*args)
    return acc


def _expected(b: dict, use_v: bool, cold: bool, exact: bool) -> dict[str, np.ndarray]:
    """The accumulators after the call: sums by math.fsum (exact) or in the documented
    order (per point over leaves of _LEAF elements, (s0 + s1) + (s2 + s3), leaves in
    order, then added to the start value)."""
    out = {n: b["start"][i].copy() for i, n in enumerate(NAMES)}
    for k in range(KB):
        for name, t in _terms(b, k, use_v).items():
            if name.startswith("n") and not cold:
                continue
            row = ROW0 + k
            if exact:
                out[name][row] = math.fsum([out[name][row], *t.ravel()])
                continue
            total = 0.0
            for c0 in range(0, t.shape[0], _LEAF):
                s = np.zeros(4)
                for e in range(c0, min(t.shape[0], c0 + _LEAF)):
                    s = s + t[e]
                total += (s[0] + s[1]) + (s[2] + s[3])
            out[name][row] += total
    return out


NES = [1, 2, 3, 5, 7, 8, 9, 13, 64, 65, 131]


@pytest.mark.parametrize("use_v", [False, True])
@pytest.mark.parametrize("nodes", ["clamped", "clamped3", "free"])
@pytest.mark.parametrize("ne", NES)
def test_kernels_equal_exact_sums(ne, nodes, use_v):
    if nodes == "clamped3" and ne < 3:
        pytest.skip("three clamped nodes need three elements")
    b = _block(ne, nodes, seed=ne)
    warm = _run(b, use_v, cold=False)
    cold = _run(b, use_v, cold=True)
    want = _expected(b, use_v, cold=True, exact=True)
    for name in NAMES:
        touched = name in ("eu", "eux") or (name == "ev" and use_v)
        if name.startswith("n"):
            touched = name in ("nu", "nux") or (name == "nv" and use_v)
            assert np.array_equal(warm[name], b["start"][NAMES.index(name)]), name
        got = cold[name]
        if not touched:  # ev, nv without velocities: not written
            assert np.array_equal(got, b["start"][NAMES.index(name)]), name
            continue
        rows = slice(ROW0, ROW0 + KB)
        np.testing.assert_allclose(got[rows], want[name][rows], rtol=1e-14, atol=0,
                                   err_msg=name)
        # the other samples are not touched
        assert np.array_equal(np.delete(got, np.r_[rows]),
                              np.delete(b["start"][NAMES.index(name)], np.r_[rows])), name
        if not name.startswith("n"):  # the warm path's errors: the cold path's bits
            assert np.array_equal(warm[name], got), name


@pytest.mark.parametrize("use_v", [False, True])
@pytest.mark.parametrize("ne", [3, 9, 65, 131])
def test_kernels_follow_their_documented_order_bit_for_bit(ne, use_v):
    b = _block(ne, "clamped", seed=100 + ne)
    for cold in (False, True):
        got = _run(b, use_v, cold)
        want = _expected(b, use_v, cold, exact=False)
        for name in NAMES:
            assert np.array_equal(got[name], want[name]), (cold, name)


def test_sums_of_a_long_block_stay_accurate():
    """8191 elements in one block (terms of widely varying size): the leaf partial sums
    keep the error near the exact sum (a single running sum per point would drift)."""
    b = _block(8191, "clamped", seed=7)
    rng = np.random.default_rng(8)
    b["w"] *= 10.0 ** rng.uniform(-6, 6, b["w"].shape)
    got = _run(b, True, cold=True)
    want = _expected(b, True, cold=True, exact=True)
    rows = slice(ROW0, ROW0 + KB)
    for name in NAMES:
        np.testing.assert_allclose(got[name][rows], want[name][rows], rtol=1e-13, atol=0,
                                   err_msg=name)


def test_vector_loads_refuse_non_contiguous_arrays():
    b = _block(9, "clamped", seed=3)
    wide = np.zeros((KB, 18, 4))
    wide[:, ::2] = b["u"]
    strided = wide[:, ::2]  # the same values, not C-contiguous
    assert not strided.flags.c_contiguous
    acc = [np.zeros(K) for _ in range(3)]
    with pytest.raises(TypingError, match="C-contiguous"):
        _error_sums(Nodal(b["U"], b["V"], True, ROW0, LO, b["nfree"], U_FIXED),
                    Quadrature(b["p0"], b["p1"], b["g0"], b["g1"], b["w"]),
                    Fields(strided, b["ux"], b["v"]), SampleSums(*acc))


def test_warm_up_compiles_the_signature_used():
    metrics.warm_up()
    before = (len(_error_sums.signatures), len(_error_and_exact_sums.signatures))
    b = _block(9, "clamped", seed=4)
    _run(b, True, cold=False)
    _run(b, True, cold=True)
    assert (len(_error_sums.signatures), len(_error_and_exact_sums.signatures)) == before


@pytest.mark.parametrize("sizes", [range(1, 300), [511, 512, 513, 2400, 3753, 8193, 100_001]])
def test_pairwise_sum_is_numpys_bit_for_bit(sizes):
    """`_pairwise` walks numpy's summation tree: 0.0 + it is np.add.reduce exactly, on
    data spanning six decades (so that a different order shows in the last bits)."""
    rng = np.random.default_rng(len(sizes))
    for n in sizes:
        a = rng.standard_normal(n + 3) * 10.0 ** rng.uniform(-3, 3, n + 3)
        assert 0.0 + metrics._pairwise(a, 0, n) == np.add.reduce(a[:n]), n
        assert 0.0 + metrics._pairwise(a, 3, n) == np.add.reduce(a[3:]), n  # offset


def _numpy_time_norms(t, n, a, s):
    """The seven columns the plain numpy way (np.max, np.trapezoid, elementwise sums)."""
    def linf(e, m):
        den = np.sqrt(np.max(m))
        return float(np.sqrt(np.max(e)) / den) if den > 0 else math.nan

    def l2(e, m):
        if t.size < 2:
            return math.nan
        den = np.sqrt(np.trapezoid(m, t))
        return float(np.sqrt(np.trapezoid(e, t)) / den) if den > 0 else math.nan

    h1e, h1n = n["eu"] + n["eux"], n["nu"] + n["nux"]
    return [linf(n["eu"], n["nu"]), linf(h1e, h1n), linf(n["ev"], n["nv"]),
            l2(n["eu"], n["nu"]), l2(h1e, h1n), l2(n["ev"], n["nv"]),
            l2((a - s) ** 2, s**2)]


@pytest.mark.parametrize("K", [1, 2, 3, 17, 129, 2401])
def test_time_norms_equal_numpy_bit_for_bit(K):
    """The seven time norms of one compiled call are those of numpy's own functions
    (the former code), bit for bit; nan below two samples (L2) or for a zero norm."""
    rng = np.random.default_rng(K)
    t = np.cumsum(rng.random(K))
    n = {k: rng.random(K) ** 3 * 10.0 ** rng.uniform(-4, 4) for k in
         ("eu", "eux", "ev", "nu", "nux", "nv")}
    a, s = -rng.random(K), -rng.random(K) * (rng.random(K) < 0.5)
    got = metrics._time_norms(t, *_sums(n), True, True, a, s, True)
    want = _numpy_time_norms(t, n, a, s)
    for col, g, w in zip(metrics.ERROR_COLUMNS, got, want, strict=True):
        assert (math.isnan(g) and math.isnan(w)) or g == w, col
    assert not math.isnan(got[0]) and (K < 2) == math.isnan(got[3])
    # a zero norm gives nan, a nan in a series gives nan; columns not asked stay nan
    n["nv"] = np.zeros(K)
    n["eu"][K // 2] = math.nan
    got = metrics._time_norms(t, *_sums(n), True, True, a, s, False)
    assert math.isnan(got[2]) and math.isnan(got[5])  # zero norm
    assert math.isnan(got[0]) and math.isnan(got[1])  # nan in the series
    assert math.isnan(got[6])  # stress not asked
    got = metrics._time_norms(t, *_sums(n), False, False, a, s, True)
    assert all(math.isnan(g) for g in got[:6])
    assert (math.isnan(got[6]) and math.isnan(want[6])) or got[6] == want[6]


def test_error_metrics_fill_the_columns_the_reference_provides():
    """None for a column whose quantity the reference does not provide."""
    run = run_one("clamped_bar", "redistributed", nx=10, T=1.5)  # impact at t = 1
    exact = reference(make_case("clamped_bar"), 1.5)
    for provides, want in [({"u"}, {"err_u_linf_l2", "err_u_linf_h1", "err_u_l2_l2",
                                    "err_u_l2_h1"}),
                           ({"u", "v"}, set(metrics.ERROR_COLUMNS) - {"err_stress_l2"}),
                           ({"stress"}, {"err_stress_l2"}),
                           ({"u", "v", "stress"}, set(metrics.ERROR_COLUMNS))]:
        metrics.clear_cache()
        row = metrics.error_metrics(run.semi, run.trajectory, exact, frozenset(provides))
        assert {c for c, v in row.items() if v is not None} == want, provides
        for c in want:  # the harness's values (u, v and stress provided), none nan
            assert row[c] == run.row[c] and not math.isnan(row[c]), c
