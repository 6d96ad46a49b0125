"""The compiled error-norm kernels of `bench.metrics` (explicit SIMD, `schemes._simd`).

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
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba.core.errors import TypingError

from bench import metrics
from bench.metrics import _LEAF, _error_and_exact_sums, _error_sums

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


def _run(b: dict, use_v: bool, cold: bool) -> dict[str, np.ndarray]:
    acc = {n: b["start"][i].copy() for i, n in enumerate(NAMES)}
    V, v = (b["V"], b["v"]) if use_v else (b["U"], b["u"])
    args = (b["U"], V, use_v, ROW0, LO, b["nfree"], U_FIXED, b["p0"], b["p1"], b["g0"],
            b["g1"], b["w"], b["u"], b["ux"], v, acc["eu"], acc["eux"], acc["ev"])
    if cold:
        _error_and_exact_sums(*args, acc["nu"], acc["nux"], acc["nv"])
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
        _error_sums(b["U"], b["V"], True, ROW0, LO, b["nfree"], U_FIXED, b["p0"], b["p1"],
                    b["g0"], b["g1"], b["w"], strided, b["ux"], b["v"], *acc)


def test_warm_up_compiles_the_signature_used():
    metrics.warm_up()
    before = (len(_error_sums.signatures), len(_error_and_exact_sums.signatures))
    b = _block(9, "clamped", seed=4)
    _run(b, True, cold=False)
    _run(b, True, cold=True)
    assert (len(_error_sums.signatures), len(_error_and_exact_sums.signatures)) == before


@pytest.mark.parametrize("K", [1, 2, 3, 17, 129, 2401])
def test_time_norms_from_one_stacked_trapezoid_equal_one_call_each(K):
    """The L2(0,T) columns integrate their series in one np.trapezoid over the stack:
    the same bits as the plain formula, column by column (nan below two samples or for
    a zero norm)."""
    rng = np.random.default_rng(K)
    t = np.cumsum(rng.random(K))
    pairs = {f"c{i}": (rng.random(K) ** 3 * 10.0 ** -i, rng.random(K) * 10.0**i)
             for i in range(4)}
    pairs["zero"] = (rng.random(K), np.zeros(K))
    got = metrics._rel_l2(t, pairs)
    assert list(got) == list(pairs)
    for col, (e, n) in pairs.items():
        if K < 2 or col == "zero":
            assert math.isnan(got[col]), col
        else:
            want = math.sqrt(float(np.trapezoid(e, t))) / math.sqrt(float(np.trapezoid(n, t)))
            assert got[col] == want, col
    assert metrics._rel_l2(t, {}) == {}
