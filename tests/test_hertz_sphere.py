"""The hertz_sphere scene: axisymmetric mass and stiffness, its exact invariants, and its
answer against Hertz's contact time and peak force."""

from __future__ import annotations

import math

import numpy as np
import pytest
from skfem import Basis, ElementTriP2

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core.errors import BenchError
from contact_bench.harness.runner import run_one


def test_axisymmetric_problem():
    case = make_case("hertz_sphere")
    p = case.sparse_problem(4, 1.0, "consistent")
    p.check()
    # the sphere's mass (P2 geometry of the circle) and its kinetic energy
    assert p.extra["mass"] == pytest.approx(4.0 / 3.0 * math.pi, rel=1e-4)
    assert p.energy(p.U0, p.V0) == pytest.approx(case.exact_energy, rel=1e-4)
    # the contact weights: the lower hemisphere's area 2 pi R^2
    assert p.contact.weights.sum() == pytest.approx(2 * math.pi, rel=1e-3)
    assert p.gaps(p.U0).min() == 0.0  # the pole touches
    # u = (r, z - 1) has eps = identity (hoop strain u_r / r = 1): strain energy
    # 1/2 (9 lambda + 6 mu) times the volume; a vertical translation costs none
    lam, mu = case.lam_mu
    X = Basis(case.mesh(4), ElementTriP2()).doflocs
    on_axis = X[0] < 1e-12
    U = np.stack([X[0], X[1] - 1.0], axis=1).ravel()  # u = (r, z - 1): eps = identity
    keep = np.ones(U.size, bool)
    keep[0::2][on_axis] = False
    U = U[keep]
    strain = 0.5 * U @ (p.K @ U)
    assert strain == pytest.approx(0.5 * (9 * lam + 6 * mu) * 4.0 / 3.0 * math.pi, rel=1e-4)
    Z = p.extra["vertical"]
    assert np.max(np.abs(p.K @ Z)) < 1e-12 * abs(p.K).max()


def test_grading_refused():
    with pytest.raises(BenchError, match="grading = 2.0"):
        run_one("hertz_sphere", "redistributed", nx=2, grading=2.0)


def test_within_ten_percent_of_hertz_and_impulse_balance():
    case = make_case("hertz_sphere")
    scheme = make_scheme("redistributed")
    p = case.sparse_problem(case.nx, 1.0, scheme.mass_kind())
    dt = case.dt
    traj = scheme.integrate_sparse(p, dt, int(round(case.T / dt)), 1)
    h = case.hertz()
    R = -traj.stress * p.contact.weights.sum()
    tc = traj.extra["first_contact_end"] - traj.extra["first_contact_start"] + dt
    assert abs(tc / h.contact_time - 1) < 0.10
    assert abs(R.max() / h.peak_force - 1) < 0.12  # +11.0 % at nx 8 (hertz_gap.py)
    # momentum: no load, so the change of vertical momentum is the contact impulse
    mom = traj.V @ (p.M @ p.extra["vertical"])
    impulse = dt * (np.cumsum(R) - 0.5 * R - 0.5 * R[0])
    assert np.max(np.abs(mom - mom[0] - impulse)) < 1e-8 * p.extra["mass"] * float(case.v)
    assert np.max(np.abs(traj.energy / traj.energy[0] - 1)) < 1e-3


def test_rows_carry_the_gaps_to_hertz():
    row = run_one("hertz_sphere", "redistributed").row
    h = make_case("hertz_sphere").hertz()
    tc = row["first_contact_end"] - row["first_contact_start"] + row["dt"]
    assert row["err_contact_duration"] == pytest.approx(abs(tc / h.contact_time - 1), rel=1e-12)
    assert row["err_contact_duration"] < 0.10
    assert row["err_peak_force"] == pytest.approx(
        abs(row["peak_contact_force"] / h.peak_force - 1), rel=1e-12)
    assert row["err_free_fall"] is None


def test_zone_normal_stress_is_exact_for_uniform_strains():
    case = make_case("hertz_sphere")
    p = case.sparse_problem(4, 1.0, "consistent")
    X = Basis(case.mesh(4), ElementTriP2()).doflocs
    lam, mu = case.lam_mu
    keep = np.ones(2 * X.shape[1], bool)
    keep[0::2][X[0] < 1e-12] = False
    U = np.zeros(2 * X.shape[1])
    U[1::2] = -0.01 * X[1]  # eps_zz = -0.01
    assert np.allclose(p.normal_stress @ U[keep], -(lam + 2 * mu) * 0.01, rtol=1e-10)
    U[:] = 0.0
    U[0::2] = 0.01 * X[0]  # eps_rr = hoop = 0.01: sigma_zz = 2 lambda 0.01
    assert np.allclose(p.normal_stress @ U[keep], 2 * lam * 0.01, rtol=1e-10)
    assert np.allclose(np.asarray(p.contact.face_mass.sum(axis=1)).ravel(), p.contact.weights)
