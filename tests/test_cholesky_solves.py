"""The direct solves behind the implicit schemes (`contact_bench.kernels.linalg.Factor`):
CHOLMOD's multi-right-hand-side solve for SPD matrices, SuperLU for the rest, and a
trajectory that does not depend on which one set it up beyond round-off."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core import ordering
from contact_bench.kernels import linalg
from contact_bench.kernels.linalg import Factor

needs_cholespy = pytest.mark.skipif(linalg.cholespy is None, reason="cholespy not installed")


@pytest.fixture(autouse=True)
def _cholmod_asked(monkeypatch):
    """CHOLMOD is opt-in (CONTACT_BENCH_CHOLMOD=1): these tests ask for it."""
    monkeypatch.setattr(linalg, "USE_CHOLMOD", True)


def _laplacian(n: int, shift: float) -> sp.csr_matrix:
    return sp.csr_matrix(sp.diags([-1.0, 2.0 + shift, -1.0], [-1, 0, 1], shape=(n, n)))


@needs_cholespy
def test_spd_matrix_takes_cholmod_and_solves_many_right_hand_sides():
    S = _laplacian(300, 0.1)
    fac = Factor.of(S)
    assert fac.many_backend == "cholmod"
    B = np.random.default_rng(1).standard_normal((300, 7))
    X = fac.solve_many(B)
    assert fac.chol is not None
    assert np.abs(S @ X - B).max() < 1e-10 * np.abs(B).max() * 300
    ref = np.column_stack([fac.solve(B[:, j]) for j in range(7)])  # SuperLU's solves
    assert np.abs(X - ref).max() < 1e-10 * np.abs(ref).max()


@pytest.mark.parametrize("kind", ["unsymmetric", "indefinite"])
def test_a_matrix_that_is_not_spd_goes_to_superlu(kind):
    S = _laplacian(200, 0.1)
    if kind == "unsymmetric":
        S = sp.csr_matrix(S + sp.diags([0.3], [2], shape=S.shape))
    else:
        S = _laplacian(200, -1.5)  # symmetric, eigenvalues of both signs
    fac = Factor.of(S)
    assert fac.many_backend == "superlu"
    B = sp.csc_matrix(sp.random(200, 5, density=0.05, random_state=2))
    X = fac.solve_many(B)
    assert fac.chol is None
    assert np.abs(S @ X - B.toarray()).max() < 1e-9


def test_superlu_block_solve_is_column_solves_to_the_bit():
    S = sp.csr_matrix(_laplacian(250, 0.2) + sp.diags([0.4], [3], shape=(250, 250)))
    fac = Factor.of(S)  # unsymmetric: the SuperLU block solve
    B = np.random.default_rng(3).standard_normal((250, 6))
    X = fac.solve_many(B)
    assert np.array_equal(X, np.column_stack([fac.solve(B[:, j]) for j in range(6)]))


def _trajectory(monkeypatch, cholmod: bool):
    if not cholmod:
        monkeypatch.setattr(linalg, "cholespy", None)
    calls = []
    real = linalg.cholmod_factor
    monkeypatch.setattr(linalg, "cholmod_factor", lambda S: calls.append(1) or real(S))
    case, scheme = make_case("disc_drop[degree=1,lift=0.5]"), make_scheme("redistributed")
    p = case.sparse_problem(3, 1.0, scheme.mass_kind())
    tr = scheme.prepare(p, 0.05).run(200, 5)  # the impact at t = 3.16
    monkeypatch.undo()
    return tr, len(calls)


@needs_cholespy
def test_cholmod_set_up_and_superlu_fallback_step_alike(monkeypatch):
    a, n_chol = _trajectory(monkeypatch, cholmod=True)
    b, _ = _trajectory(monkeypatch, cholmod=False)
    assert n_chol >= 1  # the Delassus matrix came from CHOLMOD
    assert np.count_nonzero(a.stress) > 3  # the disc hit the plane: contact steps
    for f in ("U", "V", "energy", "stress"):
        x, y = getattr(a, f), getattr(b, f)
        assert np.abs(x - y).max() <= 1e-9 * max(np.abs(y).max(), 1e-300), f


def _plane_elasticity():
    """S = M + dt^2/4 K of the P2 disc at nx 6 (a 2D mesh's matrix, 1,000-odd dofs)."""
    case = make_case("disc_drop[degree=2]")
    p = case.sparse_problem(6, 1.0, make_scheme("redistributed").mass_kind())
    return sp.csr_matrix(p.M + 0.25 * case.dt ** 2 * p.K)


@pytest.mark.skipif(ordering.pymetis is None, reason="pymetis not installed")
@pytest.mark.parametrize("symmetric", [True, False])
def test_nested_dissection_factor_solves_and_keeps_the_spd_reading(monkeypatch, symmetric):
    """Above `NESTED_DISSECTION_DOFS` the factor is of S[q][:, q] with q METIS's ordering;
    its permutations must carry q back: one solve and a block of solves equal S^-1 b, and
    an SPD S is still read as SPD (the CHOLMOD block solve), a nonsymmetric one not."""
    S = _plane_elasticity()
    if not symmetric:
        S = sp.csr_matrix(S + sp.diags([0.1 * S.diagonal().min()], [5], shape=S.shape))
    n = S.shape[0]
    monkeypatch.setattr(ordering, "NESTED_DISSECTION_DOFS", 0)
    fac = Factor.of(S)
    q = ordering.nested_dissection(S)
    assert sorted(q) == list(range(n)) and not np.array_equal(q, np.arange(n))
    b = np.random.default_rng(4).standard_normal(n)
    x = fac.solve(b)
    assert np.abs(S @ x - b).max() < 1e-12 * np.abs(b).max() * n
    B = np.random.default_rng(5).standard_normal((n, 4))
    X = fac.solve_many(B)
    assert np.abs(S @ X - B).max() < 1e-12 * np.abs(B).max() * n
    assert fac.many_backend == ("cholmod" if symmetric and linalg.cholespy else "superlu")


@pytest.mark.skipif(ordering.pymetis is None, reason="pymetis not installed")
def test_nested_dissection_is_used_from_its_size_on(monkeypatch):
    """`Factor.of` orders by nested dissection from `NESTED_DISSECTION_DOFS` dofs on and
    by minimum degree below (the factor's size tells which: the two orderings fill
    differently on a 2D mesh), and the two solve alike to round-off."""
    S = _plane_elasticity()
    b = np.random.default_rng(6).standard_normal(S.shape[0])
    monkeypatch.setattr(ordering, "NESTED_DISSECTION_DOFS", S.shape[0] + 1)
    mmd = Factor.of(S)
    monkeypatch.setattr(ordering, "NESTED_DISSECTION_DOFS", S.shape[0])
    nd = Factor.of(S)
    assert mmd.arrays[2].size != nd.arrays[2].size
    with ordering.forced_ordering(nested=True):  # whatever the size, restored after the block
        assert Factor.of(S).arrays[2].size == nd.arrays[2].size
    with ordering.forced_ordering(nested=False):
        assert Factor.of(S).arrays[2].size == mmd.arrays[2].size
    assert ordering.NESTED_DISSECTION_DOFS == S.shape[0]
    x, y = mmd.solve(b), nd.solve(b)
    assert not np.array_equal(x, y)
    assert np.abs(x - y).max() < 1e-12 * np.abs(x).max()
