"""MKL PARDISO's Cholesky behind `Factor` (`contact_bench.core.pardiso`): its solve against
SuperLU's on a small SPD system, the implicit loop's trajectory with it against SuperLU's,
the one-line refusal of a matrix that is not positive definite (SuperLU then factors it),
and SuperLU when MKL is not loaded. Skipped where MKL cannot load, except the fallback."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core import ordering
from contact_bench.core import pardiso as mkl
from contact_bench.kernels import linalg
from contact_bench.kernels.linalg import Factor, lu, lu_solve_many

needs_mkl = pytest.mark.skipif(mkl.MKL is None, reason=f"MKL not loaded: {mkl.UNAVAILABLE}")
CASE = "disc_drop[degree=2,lift=1e-6]"  # resting on the plane: every step in contact
NX, DT, NSTEPS = 4, 0.01, 200


@pytest.fixture(autouse=True)
def _superlu_keeps_l_and_u(monkeypatch):
    """SuperLU's factor is L and U here, whatever another test or CONTACT_BENCH_LDLT set."""
    monkeypatch.setattr(linalg, "USE_LDLT", False)


def _laplacian(m: int, shift: float) -> sp.csr_matrix:
    """The 5-point Laplacian on an m x m grid plus shift I (SPD for shift > -min eig)."""
    T = sp.diags([-np.ones(m - 1), 2 * np.ones(m), -np.ones(m - 1)], [-1, 0, 1])
    eye = sp.identity(m)
    return sp.csr_matrix(sp.kron(T, eye) + sp.kron(eye, T) + shift * sp.identity(m * m))


@needs_mkl
def test_solve_equals_superlu_to_round_off():
    S = _laplacian(30, 0.1)
    n = S.shape[0]
    fp, fs = Factor.of(S, pardiso=True), Factor.of(S, pardiso=False)
    assert fp.kind == "pardiso" and fs.kind == "lu" and fp.fallback == ""
    assert 0 < fp.entries < fs.entries  # L only, against L and U
    b = np.random.default_rng(0).standard_normal(n)
    x, out, work = fs.solve(b), np.empty(n), np.empty(n)
    lu(fp.arrays, b, out, work)  # the compiled loops' call
    assert int(fp.arrays.solves[0]) == 1
    assert np.max(np.abs(out - x)) <= 1e-12 * np.max(np.abs(x))
    assert np.max(np.abs(S @ out - b)) <= 1e-12 * np.max(np.abs(b))
    B = np.random.default_rng(1).standard_normal((n, 5))
    X, W = np.empty((n, 5)), np.empty((n, 5))
    lu_solve_many(fp.arrays, B, X, W)
    assert np.array_equal(X, fp.solve_many(B))  # the set-up's block solve, one call
    assert np.max(np.abs(X - fs.solve_many(B))) <= 1e-12 * np.max(np.abs(X))


@needs_mkl
def test_solves_repeat_bit_for_bit():
    """CNR mode and a fixed thread count: two factorisations, the same bits."""
    S = _laplacian(40, 0.05)
    b = np.random.default_rng(2).standard_normal(S.shape[0])
    x1 = Factor.of(S, pardiso=True).solve(b)
    x2 = Factor.of(S, pardiso=True).solve(b)
    assert np.array_equal(x1, x2)


@needs_mkl
def test_not_positive_definite_is_refused_in_one_line():
    S = _laplacian(20, -1.0)  # the Laplacian's smallest eigenvalues are below 1
    fac = Factor.of(S, pardiso=True)
    assert fac.kind == "lu" and fac.pardiso is None  # SuperLU factored it
    assert "not positive definite" in fac.fallback and "\n" not in fac.fallback
    assert "PARDISO error -4" in fac.fallback
    b = np.ones(S.shape[0])
    assert np.max(np.abs(S @ fac.solve(b) - b)) <= 1e-10
    assert mkl.is_spd(S) is False and mkl.is_spd(_laplacian(20, 0.1)) is True
    assert not ordering.is_spd(S)  # the same answer by SuperLU below PARDISO_MIN_DOFS


def test_banded_stays_with_superlu_at_any_size(monkeypatch):
    """The default choice reads S's structure: a tridiagonal S (the 1D bar's) stays with
    SuperLU from `PARDISO_MIN_DOFS` rows on, a 2D grid's Laplacian goes to PARDISO."""
    monkeypatch.setattr(linalg, "PARDISO_MIN_DOFS", 100)
    m = 400
    bar = sp.diags([-np.ones(m - 1), 2.1 * np.ones(m), -np.ones(m - 1)], [-1, 0, 1])
    grid = _laplacian(20, 0.1)  # half-bandwidth 20
    assert linalg.banded(bar) and linalg.banded(bar.tocsr()[::-1, ::-1]) is True
    assert not linalg.banded(grid) and linalg.banded(grid, width=20)
    assert not linalg.banded(sp.csr_matrix(([1.0, 1.0], ([0, m - 1], [m - 1, 0])), (m, m)))
    assert Factor.of(bar).kind == "lu" and Factor.of(bar).fallback == ""
    if mkl.MKL is not None:
        assert Factor.of(grid).kind == "pardiso"


@pytest.mark.parametrize("use", [True, False, None])
def test_factor_of_a_sum_is_the_factor_of_the_sum(use, monkeypatch):
    """`Factor.of_sum(A, B, c)` (S not held whole while PARDISO factors) solves to the bit
    as `Factor.of(A + c B)`, by PARDISO, by SuperLU, and by the default rule (banded: a
    banded A beside a 2D Laplacian B is not banded)."""
    if use and mkl.MKL is None:
        pytest.skip(f"MKL not loaded: {mkl.UNAVAILABLE}")
    monkeypatch.setattr(linalg, "PARDISO_MIN_DOFS", 100)
    B = _laplacian(20, 0.0)
    A = sp.diags(np.linspace(1.0, 2.0, B.shape[0])).tocsr()
    c = 0.37
    f1, f2 = Factor.of_sum(A, B, c, pardiso=use), Factor.of(A + c * B, pardiso=use)
    assert f1.kind == f2.kind == ("pardiso" if (use is not False and mkl.MKL is not None)
                                  else "lu")
    b = np.random.default_rng(4).standard_normal(B.shape[0])
    assert np.array_equal(f1.solve(b), f2.solve(b))


@needs_mkl
def test_factor_of_a_sum_not_positive_definite_falls_back_in_one_line():
    B = _laplacian(20, 0.0)
    fac = Factor.of_sum(sp.identity(B.shape[0], format="csr"), B, -1.0, pardiso=True)
    assert fac.kind == "lu" and "not positive definite" in fac.fallback
    assert "\n" not in fac.fallback


def test_not_symmetric_keeps_superlu():
    S = _laplacian(10, 0.1).tolil()
    S[0, 1] = -0.5
    fac = Factor.of(sp.csr_matrix(S), pardiso=True)
    assert fac.kind == "lu" and "not symmetric" in fac.fallback


def test_mkl_absent_superlu(monkeypatch):
    monkeypatch.setattr(mkl, "MKL", None)
    S = _laplacian(10, 0.1)
    fac = Factor.of(S, pardiso=True)
    assert fac.kind == "lu" and "not available" in fac.fallback
    monkeypatch.setattr(linalg, "PARDISO_MIN_DOFS", 0)
    assert Factor.of(S).kind == "lu" and Factor.of(S).fallback == ""  # default: quietly


def test_forced_off_process_runs_on_superlu():
    """CONTACT_BENCH_PARDISO=0: MKL is not loaded, the stub stands in for the compiled
    code, and a factor above the size threshold is SuperLU's."""
    code = ("import numpy as np, scipy.sparse as sp\n"
            "from contact_bench.core import pardiso as mkl\n"
            "from contact_bench.kernels.linalg import Factor, lu\n"
            "S = sp.identity(30, format='csr') * 2.0\n"
            "f = Factor.of(S)\n"
            "out = np.empty(30); lu(f.arrays, np.ones(30), out, np.empty(30))\n"
            "print(mkl.MKL is None, f.kind, out[0])\n")
    env = dict(os.environ, CONTACT_BENCH_PARDISO="0", CONTACT_BENCH_PARDISO_MIN_DOFS="1")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["True", "lu", "0.5"]


@needs_mkl
def test_loop_trajectory_equals_superlu_to_round_off(monkeypatch):
    p = make_case(CASE).sparse_problem(NX, 1.0, make_scheme("redistributed").mass_kind())
    runs = {}
    for floor in (0, 10**9):  # every factor PARDISO's; none
        monkeypatch.setattr(linalg, "PARDISO_MIN_DOFS", floor)
        stepper = make_scheme("redistributed").prepare(p, DT)
        assert stepper.factor.kind == ("pardiso" if floor == 0 else "lu")
        before = int(stepper.ops.fac.solves[0])
        tr = stepper.run(NSTEPS, 1)
        runs[floor] = tr, int(stepper.ops.fac.solves[0]) - before
    (tp, sp_), (tl, sl) = runs[0], runs[10**9]
    assert sp_ == sl == NSTEPS  # one solve a step either way
    assert np.count_nonzero(tl.stress[1:]) == NSTEPS  # every step in contact
    assert np.max(np.abs(tp.U - tl.U)) <= 1e-10 * np.max(np.abs(tl.U))
    assert np.max(np.abs(tp.stress - tl.stress)) <= 1e-9 * np.max(np.abs(tl.stress))


@needs_mkl
def test_factor_released_when_collected():
    """The finaliser calls PARDISO's phase -1 when the factor's arrays go: the handle's
    words (held by the finaliser, not by the factor) are cleared."""
    import gc

    fac = Factor.of(_laplacian(20, 0.1), pardiso=True)
    handle = fac.arrays.ph.base
    assert handle[:64].any()  # PARDISO's internal pointers
    del fac
    gc.collect()
    assert not handle[:64].any()
