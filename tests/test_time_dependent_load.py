"""A time-dependent load (SparseProblem.load) is added by the sparse Newmark stepper (every
scheme's stepper adds it: tests/test_time_load_levels.py) and refused by a stepper that
does not declare it; the redistributed scheme converges on the manufactured solution
with a moving contact zone (cases/manufactured.py) at P1 in 2D."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.sparse.linalg import spsolve

from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.api.sparse import ContactSet
from contact_bench.harness.runner import run_one
from contact_bench.kernels.sparse import CentralStepper, prepare_newmark


def test_the_newmark_stepper_adds_the_load_at_each_step() -> None:
    """Without contact (the obstacle moved away), the compiled stepper's first steps equal
    plain Newmark written out with scipy: M A_{n+1} + K U_{n+1} = F(t_{n+1})."""
    p = make_case("manufactured").sparse_problem(2, 1.0, "consistent")
    far = ContactSet(dofs=p.contact.dofs, gap0=np.full(p.contact.size, 10.0),
                     weights=p.contact.weights)
    p = replace(p, contact=far)
    dt, beta, gamma, steps = 0.05, 0.25, 0.5, 3
    run = prepare_newmark(p, dt, beta, gamma).run(steps, 1)
    M, K = p.M.tocsc(), p.K.tocsc()
    U, V = p.U0.copy(), p.V0.copy()
    A = spsolve(M, p.load.at(0.0) - K @ U)
    S = (M + beta * dt * dt * K).tocsc()
    for n in range(1, steps + 1):
        P = U + dt * V + (0.5 - beta) * dt * dt * A
        U = spsolve(S, M @ P + beta * dt * dt * p.load.at(n * dt))
        A1 = (U - P) / (beta * dt * dt)
        V = V + dt * ((1 - gamma) * A + gamma * A1)
        A = A1
        assert np.allclose(run.U[n], U, rtol=0, atol=1e-12 * np.abs(U).max())
    # and the load matters: a constant load F(0) gives another answer
    frozen = replace(p, load=None, F=p.load.at(0.0))
    other = prepare_newmark(frozen, dt, beta, gamma).run(steps, 1)
    assert np.abs(other.U[-1] - U).max() > 1e-6


def test_a_stepper_without_the_load_refuses_it() -> None:
    """A stepper (a plugin's) that does not declare `adds_time_load` refuses a problem
    with a time load; the same stepper declaring it takes it."""

    class Quiet(CentralStepper):
        adds_time_load = False

    p = make_case("manufactured").sparse_problem(2, 1.0, "lumped")
    with pytest.raises(ValueError, match="time-dependent load"):
        Quiet(p, 0.001)
    assert CentralStepper(p, 0.001).run(2, 1).U.shape[0] == 3


def test_a_scheme_that_does_not_add_the_load_is_not_applicable() -> None:
    """The scene refuses a scheme (a plugin's) whose `adds_time_load` is False; none of
    the registered schemes is refused."""
    case = make_case("manufactured")
    assert all(case.cannot_run(make_scheme(name)) is None for name in schemes().names())

    class Without(type(make_scheme("standard"))):
        def adds_time_load(self) -> bool:
            return False

    assert "time-dependent load" in case.cannot_run(Without())


def test_redistributed_converges_on_the_manufactured_solution() -> None:
    """Space-time refinement at fixed CFL 0.5 on P1 triangles (2D), T = 1/2: the
    displacement error's pairwise orders over nx = 8, 16, 32 are at least 1.5 (the
    issue's target; results/manufactured_orders.md: benchmarks/manufactured_orders.py, to
    nx = 64). A redistribution spread over the whole body gives 1.39 and 1.25 here."""
    nxs = (8, 16, 32)
    errs = []
    for nx in nxs:
        row = run_one("manufactured", "redistributed", nx=nx,
                      dt=0.5 / (nx * math.sqrt(3.0)), T=0.5).row
        assert row["status"] == "ok"
        errs.append(row["err_u_l2_l2"])
    orders = -np.diff(np.log(errs)) / np.log(2.0)
    assert np.all(orders >= 1.5), (errs, orders)


def test_manufactured_fills_the_standard_columns_of_u_and_v() -> None:
    """One column per quantity: the closed form's u and v errors are in the columns every
    exact scene fills (no `err_u` of its own), recomputed here from the samples with
    scikit-fem's own mass and Laplacian forms on the body."""
    from skfem.models import laplace, mass

    run = run_one("manufactured", "redistributed", nx=4, T=0.2)
    row = run.row
    assert row["status"] == "ok" and "no reference solution" not in row["notes"]
    assert "err_u" not in row or row["err_u"] is None
    case = make_case("manufactured")
    body = case.body(4)
    basis = body.full_basis()
    Ms, Ls = mass.assemble(basis), laplace.assemble(basis)
    P, t, traj = body.dof_coordinates, np.asarray(run.trajectory.t), run.trajectory
    err2, ref2, verr2, vref2 = [], [], [], []
    for k, tk in enumerate(t):
        ue, ve = case.solution.u(P, tk), case.solution.ut(P, tk)  # (dim, nodes)
        eu = traj.U[k].reshape(-1, 2).T - ue
        ev = traj.V[k].reshape(-1, 2).T - ve
        err2.append(sum(c @ Ms @ c + c @ Ls @ c for c in eu))
        ref2.append(sum(c @ Ms @ c + c @ Ls @ c for c in ue))
        verr2.append(sum(c @ Ms @ c for c in ev))
        vref2.append(sum(c @ Ms @ c for c in ve))
    assert row["err_u_linf_h1"] == pytest.approx(math.sqrt(max(err2) / max(ref2)), rel=1e-10)
    assert row["err_v_l2_l2"] == pytest.approx(
        math.sqrt(np.trapezoid(verr2, t) / np.trapezoid(vref2, t)), rel=1e-10)
    for col in ("err_u_linf_l2", "err_u_l2_l2", "err_u_l2_h1", "err_v_linf_l2"):
        assert 0 < row[col] < 1, col
