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
    """Lazy operators (Z not kept whole): W's and Z's columns of the rows near contact
    at set-up, the others computed in the loop when their row is needed (one solve
    counted per column); the rest of the steps one solve each, the whole response's
    numbers to the bit."""
    monkeypatch.setattr(contact, "KEEP_Z_ENTRIES", 0)
    monkeypatch.setattr(contact, "patch_rows", lambda n, nc, entries: 6)
    tr, solves, in_contact, ct = _run(problem)
    assert not ct.keep_z and ct.Z.shape == (6, problem.nfree)  # columns as rows
    known = int(np.count_nonzero(ct.known))
    assert 0 < known < problem.contact.size  # not every column computed
    assert np.count_nonzero(ct.zcol >= 0) == min(6, known) == int(ct.nz[0])
    # the columns computed at set-up: `near_rows`, the rows of smallest initial gap first
    st = make_scheme("redistributed").prepare(problem, DT)
    first = int(np.count_nonzero(st.ops.ct.known))
    g0 = np.asarray(problem.contact.gap0)
    assert np.max(g0[st.ops.ct.known]) <= np.min(g0[~st.ops.ct.known])
    assert in_contact == NSTEPS and solves == NSTEPS + (known - first)
    # the same columns of Z times the same mu: the whole response's numbers to the bit
    assert np.array_equal(tr.U, whole[0].U) and np.array_equal(tr.stress, whole[0].stress)
    # W's known columns are the complete W's (symmetrised among the known rows)
    Wf = whole[3].W
    kn = ct.known
    assert np.array_equal(ct.W[np.ix_(kn, kn)], Wf[np.ix_(kn, kn)])
    assert np.max(np.abs(ct.W[np.ix_(~kn, kn)] - Wf[np.ix_(~kn, kn)])) <= 1e-14 * np.max(Wf)


@pytest.mark.parametrize("rows", [0, 1])
def test_outside_the_patch_a_second_solve(problem, whole, monkeypatch, rows):
    """No patch (0 rows), or one too small for the active set (1 row): a step pushing
    outside it makes one more solve with G^T mu; the trajectory agrees to round-off."""
    monkeypatch.setattr(contact, "KEEP_Z_ENTRIES", 0)
    monkeypatch.setattr(contact, "patch_rows", lambda n, nc, entries: rows)
    tr, solves, in_contact, ct = _run(problem)
    assert not ct.keep_z and ct.Z.shape == ((1, problem.nfree) if rows else (1, 1))
    assert in_contact == NSTEPS
    added = int(np.count_nonzero(ct.known)) - int(np.count_nonzero(
        make_scheme("redistributed").prepare(problem, DT).ops.ct.known))
    if rows == 0:
        assert solves == 2 * NSTEPS + added
    else:  # the steps with one active row need no second
        assert NSTEPS + added < solves < 2 * NSTEPS + added
    ref = whole[0]
    assert np.max(np.abs(tr.U - ref.U)) <= 1e-10 * np.max(np.abs(ref.U))
    assert np.max(np.abs(tr.stress - ref.stress)) <= 1e-9 * np.max(np.abs(ref.stress))


def test_patch_rows_bound(monkeypatch):
    monkeypatch.setattr(contact, "KEEP_Z_ENTRIES", 1000)
    monkeypatch.setattr(contact, "PATCH_SHARE", 3.0)
    assert contact.patch_rows(100, 50, 0) == 10  # KEEP_Z_ENTRIES // n
    assert contact.patch_rows(100, 50, 1000) == 30  # 3 x 1000 values / n
    assert contact.patch_rows(100, 50, 10**6) == 50  # at most n_c


def _solver_floor():
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "solver_floor.py"
    spec = importlib.util.spec_from_file_location("_bench_solver_floor", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_solver_floor_script_rows(capsys):
    """benchmarks/solver_floor.py: a row per kind (one solve a step, the factor's size:
    L and D about half of L and U), and the active rows of a short run."""
    sf = _solver_floor()
    cfg = f"{CASE}:{NX}"
    lu, ldl = sf.measure(cfg, "lu", 3), sf.measure(cfg, "ldlt", 3)
    assert (lu["kind"], ldl["kind"]) == ("lu", "ldlt")
    assert lu["solves / step"] == ldl["solves / step"] == 1.0 and lu["patch"] == "whole"
    assert 0.4 < ldl["factor entries"] / lu["factor entries"] < 0.6
    sf.main([cfg, "--active", "100"])
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("| config | steps | n_c | most at once | ever | largest rank")
    cells = [c.strip() for c in out[2].split("|")[1:-1]]
    assert cells[:3] == [cfg, "100", "25"] and 1 <= int(cells[3]) <= int(cells[4]) <= 25
