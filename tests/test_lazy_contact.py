"""Lazy contact operators (`contact_bench.kernels.contact.contact_lcp`): the LCP solved on
the rows whose column of W is known, a row outside them that the solution pushes below
the obstacle given its column and the LCP solved again: the complete W's solution,
checked against an LCP on W computed by a dense inverse."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from contact_bench.core import pardiso
from contact_bench.kernels import contact
from contact_bench.kernels.contact import contact_lcp, contact_ops, near_rows
from contact_bench.kernels.linalg import Factor
from contact_bench.kernels.solvers import lcp_solve


def _problem(seed: int = 1, n: int = 40, nc: int = 12):
    """An SPD S that is not an M-matrix (W has negative entries: pushing one row can
    pull another down) and a selection G of its first nc dofs."""
    rng = np.random.default_rng(seed)
    B = sp.random(n, n, density=0.15, random_state=rng) - sp.random(
        n, n, density=0.15, random_state=rng)
    S = sp.csc_matrix(B @ B.T + 0.5 * sp.identity(n))
    G = sp.csr_matrix((np.ones(nc), (np.arange(nc), np.arange(nc))), shape=(nc, n))
    return S, G


@pytest.mark.parametrize("use_pardiso", [False, True])
def test_lazy_lcp_is_the_complete_lcp(monkeypatch, use_pardiso):
    """SuperLU's factor, and PARDISO's (the columns on demand through its
    multi-right-hand-side solve)."""
    if use_pardiso and pardiso.MKL is None:
        pytest.skip("MKL PARDISO not loaded")
    monkeypatch.setattr(contact, "KEEP_Z_ENTRIES", 0)
    monkeypatch.setattr(contact, "patch_rows", lambda n, nc, entries: 3)
    S, G = _problem()
    nc = G.shape[0]
    W = G.toarray() @ np.linalg.inv(S.toarray()) @ G.toarray().T  # independent
    W = 0.5 * (W + W.T)
    rng = np.random.default_rng(7)
    grown = 0
    for _ in range(20):
        q = rng.standard_normal(nc)
        first = np.zeros(nc, np.bool_)
        first[int(np.argmin(q))] = True
        fac = Factor.of(S, pardiso=use_pardiso)
        assert (fac.kind == "pardiso") == use_pardiso
        ct = contact_ops(fac, G, np.zeros(nc), first=first)
        assert ct.known.sum() == 1 and not ct.keep_z
        mu, active = np.zeros(nc), np.zeros(nc, np.bool_)
        assert contact_lcp(ct, fac.arrays, q, mu, active, 1e-13, False) >= 0
        ref, ra = np.zeros(nc), np.zeros(nc, np.bool_)
        lcp_solve(W, q, ref, ra, 1e-13, False)
        assert np.allclose(mu, ref, rtol=1e-10, atol=1e-12)
        g = q + W @ mu
        assert np.all(g >= -1e-10) and np.all(mu >= 0) and abs(g @ mu) < 1e-10
        # the rows that push have their columns; the known ones W's entries
        assert np.all(ct.known[mu > 0])
        kn = ct.known
        assert np.allclose(ct.W[np.ix_(kn, kn)], W[np.ix_(kn, kn)], rtol=1e-12, atol=1e-14)
        assert np.count_nonzero(ct.zcol >= 0) == min(3, int(kn.sum()))
        # a row with q >= 0 that the others' pushes bring below: its column came on demand
        grown += int(np.any(kn & (q >= 0) & (mu > 0)))
    assert grown > 0  # the re-solve path ran


def test_near_rows():
    G = sp.identity(4, format="csr")
    gap0 = np.array([0.0, 1e-3, 0.02, 1.0])
    z = np.zeros(4)
    assert near_rows(G, gap0, z, z, z, 0.01).tolist() == [True, False, False, False]
    # falling at speed 1 for 10 steps of 0.01: a reach of 0.1
    v = -np.ones(4)
    assert near_rows(G, gap0, z, v, z, 0.01).tolist() == [True, True, True, False]
    # at rest, accelerating at 10: 0.5 x 10 x 0.1^2 = 0.05
    assert near_rows(G, gap0, z, z, -10 * np.ones(4), 0.01).tolist() == [
        True, True, True, False]
