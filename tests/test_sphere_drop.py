"""The sphere_drop scene (3D tetrahedra) on a small ball: problem data, refusals, free
fall, E0 and the impulse balance through the impact."""

from __future__ import annotations

import numpy as np
import pytest

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core.errors import BenchError
from contact_bench.harness.runner import run_one


def test_problem_and_refusals():
    case = make_case("sphere_drop")
    p = case.sparse_problem(2, 1.0, "consistent")
    p.check()
    assert p.dim == 3 and np.all(p.contact.dofs % 3 == 2)
    m = p.body_mass
    assert -p.F[2::3].sum() == pytest.approx(m * case.g, rel=1e-12)
    assert p.energy(p.U0, p.V0) == pytest.approx(m * case.g * float(case.lift), rel=1e-12)
    assert 0.6 * 4 / 3 * np.pi * case.R**3 < m < 4 / 3 * np.pi * case.R**3  # flat faces
    with pytest.raises(BenchError, match="nx = 3"):
        run_one("sphere_drop", "standard", nx=3, T=0.1)
    with pytest.raises(BenchError, match="grading = 2.0"):
        run_one("sphere_drop", "standard", nx=2, T=0.1, grading=2.0)


def test_free_fall_and_impulse_balance():
    case = make_case("sphere_drop")
    scheme = make_scheme("standard")
    p = case.sparse_problem(2, 1.0, scheme.mass_kind())
    dt = case.dt
    traj = scheme.integrate(p, dt, int(round(10.6 / dt)), 1)
    before = traj.t < case.impact_time - 1.5 * dt
    err = np.max(np.abs(traj.U[before][:, 2::3] - case.free_fall(traj.t[before])[:, None]))
    assert err / float(case.lift) < 1e-10
    R = -traj.stress * p.contact.weights.sum()
    assert R.max() > 0
    mom = traj.V @ (p.M @ p.vertical)
    impulse = dt * (np.cumsum(R) - 0.5 * R - 0.5 * R[0])
    residual = mom - mom[0] + p.body_mass * case.g * traj.t - impulse
    assert np.max(np.abs(residual)) < 1e-8 * p.body_mass * case.g * case.impact_time
