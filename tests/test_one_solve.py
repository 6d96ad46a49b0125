"""One solve a step in contact: the implicit Newmark step corrects its contact-free
solution with the kept response of the contact patch (`contact_bench.kernels.contact`),
not with a second solve, when Z = S^-1 G^T is too large to keep whole. The factor counts
the compiled loops' solves (`LU.solves`)."""

from __future__ import annotations

import numpy as np
import pytest

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.kernels import contact

CASE = "disc_drop[degree=2,lift=1e-6]"  # resting on the plane: every step in contact
NX, DT, NSTEPS = 4, 0.01, 300


@pytest.fixture(scope="module")
def problem():
    return make_case(CASE).sparse_problem(NX, 1.0, make_scheme("redistributed").mass_kind())


def _run(p):
    """(trajectory, loop solves, steps in contact, the contact ops) of one run."""
    stepper = make_scheme("redistributed").prepare(p, DT)
    fac = stepper.ops.fac
    before = int(fac.solves[0])
    tr = stepper.run(NSTEPS, 1)
    in_contact = int(np.count_nonzero(tr.stress[1:]))
    return tr, int(fac.solves[0]) - before, in_contact, stepper.ops.ct


@pytest.fixture(scope="module")
def whole(problem):
    return _run(problem)


def test_whole_response_one_solve_a_step(problem, whole):
    tr, solves, in_contact, ct = whole
    assert ct.keep_z and ct.Z.shape == (problem.nfree, problem.contact.size)
    assert in_contact == NSTEPS  # the disc rests on the plane
    assert solves == NSTEPS


def test_patch_one_solve_a_step_same_numbers(problem, whole, monkeypatch):
    monkeypatch.setattr(contact, "KEEP_Z_ENTRIES", 0)
    monkeypatch.setattr(contact, "patch_rows", lambda n, nc, entries: 6)
    tr, solves, in_contact, ct = _run(problem)
    assert not ct.keep_z and ct.Z.shape == (problem.nfree, 6)
    assert np.count_nonzero(ct.zcol >= 0) == 6
    # the patch is the rows of smallest initial gap
    g0 = np.asarray(problem.contact.gap0)
    assert np.max(g0[ct.zcol >= 0]) <= np.min(g0[ct.zcol < 0])
    assert in_contact == NSTEPS and solves == NSTEPS
    # the same columns of Z times the same mu: the whole response's numbers to the bit
    assert np.array_equal(tr.U, whole[0].U) and np.array_equal(tr.stress, whole[0].stress)


@pytest.mark.parametrize("rows", [0, 1])
def test_outside_the_patch_a_second_solve(problem, whole, monkeypatch, rows):
    """No patch (0 rows), or one too small for the active set (1 row): a step pushing
    outside it makes one more solve with G^T mu; the trajectory agrees to round-off."""
    monkeypatch.setattr(contact, "KEEP_Z_ENTRIES", 0)
    monkeypatch.setattr(contact, "patch_rows", lambda n, nc, entries: rows)
    tr, solves, in_contact, ct = _run(problem)
    assert not ct.keep_z and ct.Z.shape == ((problem.nfree, 1) if rows else (1, 1))
    assert in_contact == NSTEPS
    if rows == 0:
        assert solves == 2 * NSTEPS
    else:
        assert NSTEPS < solves < 2 * NSTEPS  # the steps with one active row need no second
    ref = whole[0]
    assert np.max(np.abs(tr.U - ref.U)) <= 1e-10 * np.max(np.abs(ref.U))
    assert np.max(np.abs(tr.stress - ref.stress)) <= 1e-9 * np.max(np.abs(ref.stress))


def test_patch_rows_bound(monkeypatch):
    monkeypatch.setattr(contact, "KEEP_Z_ENTRIES", 1000)
    monkeypatch.setattr(contact, "PATCH_SHARE", 1.5)
    assert contact.patch_rows(100, 50, 0) == 10  # KEEP_Z_ENTRIES // n
    assert contact.patch_rows(100, 50, 2000) == 30  # 1.5 x 2000 values / n
    assert contact.patch_rows(100, 50, 10**6) == 50  # at most n_c
