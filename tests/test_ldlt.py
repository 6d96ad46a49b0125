"""The symmetric factor of the loops (`Factor.of(S, ldlt=True)`, `CONTACT_BENCH_LDLT=1`):
SuperLU's L and D only for an SPD S, its solves against SuperLU's L U and against an
independent solver (scipy's spsolve), the fallback to L and U for what is not SPD (one
line saying why), one factorisation for the SPD test, and an implicit run through it."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core import ordering
from contact_bench.kernels import linalg
from contact_bench.kernels.linalg import Factor


def _laplacian(m: int) -> sp.csr_matrix:
    """The 2D five-point Laplacian on an m x m grid (SPD)."""
    T = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(m, m))
    return sp.csr_matrix(sp.kron(T, sp.eye(m)) + sp.kron(sp.eye(m), T))


@pytest.mark.parametrize("m", [12, 75])  # 75^2 = 5625 dofs: nested dissection's ordering
def test_ldlt_solves_agree_with_lu_and_spsolve(m):
    S = _laplacian(m) + 0.1 * sp.eye(m * m)
    ldl, lu = Factor.of(S, ldlt=True), Factor.of(S, ldlt=False)
    assert (ldl.kind, lu.kind, ldl.fallback) == ("ldlt", "lu", "")
    assert ldl.arrays.Up.size == 0 and ldl.arrays.Ux.size == m * m  # D only
    assert lu.arrays.Ux.size > ldl.arrays.Lx.size // 2  # U was as large as L
    b = np.random.default_rng(1).standard_normal(m * m)
    x, y, z = ldl.solve(b), lu.solve(b), spsolve(sp.csc_matrix(S), b)
    assert np.max(np.abs(x - y)) <= 1e-12 * np.max(np.abs(y))
    assert np.max(np.abs(x - z)) <= 1e-12 * np.max(np.abs(z))
    B = np.random.default_rng(2).standard_normal((m * m, 5))
    X = ldl.solve_many(B)
    for j in range(5):  # the block solve makes each column's numbers of `lu_solve`
        assert np.array_equal(X[:, j], ldl.solve(B[:, j]))


def test_not_spd_falls_back_to_lu_with_the_reason():
    A = _laplacian(10)
    indefinite = Factor.of(A - 1.0 * sp.eye(100), ldlt=True)
    assert indefinite.kind == "lu" and indefinite.arrays.Up.size == 101
    assert indefinite.fallback.startswith("S is not positive definite (pivot ")
    unsym = Factor.of(A + sp.diags([0.5], [1], shape=(100, 100)), ldlt=True)
    assert unsym.kind == "lu" and unsym.fallback.startswith("S is not symmetric")
    for f in (indefinite, unsym):
        assert "\n" not in f.fallback
        b = np.arange(100.0)
        S = A - 1.0 * sp.eye(100) if f is indefinite else A + sp.diags([0.5], [1],
                                                                        shape=(100, 100))
        assert np.allclose(S @ f.solve(b), b, rtol=0, atol=1e-10 * np.max(np.abs(b)))


def test_the_spd_test_factors_once(monkeypatch):
    calls = []
    real = linalg.symmetric_lu

    def counted(A):
        calls.append(A.shape)
        return real(A)

    monkeypatch.setattr(linalg, "symmetric_lu", counted)
    assert Factor.of(_laplacian(20), ldlt=True).kind == "ldlt"
    assert Factor.of(_laplacian(20) - 9.0 * sp.eye(400), ldlt=True).kind == "lu"
    assert len(calls) == 2
    assert ordering.is_spd(_laplacian(20))  # the same reading of one factor


def test_implicit_run_through_ldlt(monkeypatch):
    """redistributed on the disc at rest on the plane: the L D L^T run equals the L U
    run to round-off, one solve a step in both."""
    sch = make_scheme("redistributed")
    p = make_case("disc_drop[degree=2,lift=1e-6]").sparse_problem(4, 1.0, sch.mass_kind())
    runs = []
    for flag in (False, True):
        monkeypatch.setattr(linalg, "USE_LDLT", flag)
        st = sch.prepare(p, 0.01)
        assert st.factor.kind == ("ldlt" if flag else "lu")
        tr = st.run(200, 1)
        runs.append((tr, int(st.ops.fac.solves[0])))
    (a, na), (b, nb) = runs
    assert na == nb == 200
    assert np.max(np.abs(a.U - b.U)) <= 1e-10 * np.max(np.abs(a.U))
    assert np.max(np.abs(a.stress - b.stress)) <= 1e-9 * np.max(np.abs(a.stress))
