"""armero_petocz (energy-conserving penalty) and semi_explicit (Doyen-Ern-Piperno's
modified mass central difference): every scene form runs, the embedded bar gives the 1D
rows, armero_petocz conserves its discrete energy to round-off, its Newton step solves
the discrete-gradient system (checked against scipy's root finder). semi_explicit's own
checks: tests/test_semi_explicit.py."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize as so

from contact_bench.api.plugin import Family
from contact_bench.api.registry import make_scheme
from contact_bench.harness.runner import run_one
from contact_bench.kernels.energy_penalty import discrete_gradient_solve, secant_force

SCHEMES = ("armero_petocz", "semi_explicit")
#: (scene, nx, T): small grids, each through a first impact
SCENES = [("clamped_bar", 20, 3.0), ("dropped_bar", 20, 2.5), ("disc_drop[degree=1]", 3, 12.0),
          ("sphere_drop[lift=0.1]", 4, 2.0), ("embedded_bar", 8, 3.0)]


@pytest.mark.parametrize("scheme", SCHEMES)
@pytest.mark.parametrize(("case", "nx", "T"), SCENES)
def test_runs_every_scene_form(scheme, case, nx, T):
    run = run_one(case, scheme, nx=nx, T=T, step_repeats=1)
    row = run.row
    assert row["status"] == "ok", row["notes"]
    assert np.isfinite(row["energy_drift_max"])
    assert np.min(run.trajectory.stress) < 0.0  # an impact happened
    if scheme == "semi_explicit":  # exact contact on the massless contact dofs
        assert row["penetration_max"] <= 1e-12
    else:  # the springs give way, and conserve the energy with them
        assert row["penetration_max"] > 0.0
        assert row["energy_drift_max"] < 1e-9


COLUMNS = ("err_u_linf_l2", "err_u_l2_h1", "err_v_l2_l2", "err_stress_l2", "energy_initial",
           "energy_final", "energy_drift_max", "penetration_max")


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("scene", ["clamped_bar", "dropped_bar"])
@pytest.mark.parametrize("scheme", SCHEMES)
def test_embedded_bar_reproduces_the_1d_row(scheme, scene, dim):
    """The bar embedded in a 2D/3D block with sliding sides is the 1D bar: the same row
    to 1e-9 (relative; 1e-10 absolute on the error columns, 1e-9 on the drift)."""
    nx, T, dt = 16, 2.0, 2.1e-3
    run = run_one(scene, scheme, nx=nx, T=T, dt=dt)
    a = run.row
    b = run_one(f"embedded_bar[of={scene},dim={dim}]", scheme, nx=nx, T=T, dt=dt).row
    assert a["status"] == b["status"] == "ok", b["notes"]
    assert np.min(run.trajectory.stress) < 0.0  # a contact happened
    for col in COLUMNS:
        if a[col] is None:
            continue
        tol = ({"abs": 1e-9} if col == "energy_drift_max" else
               {"rel": 1e-9, "abs": 1e-10} if col.startswith("err") else
               {"rel": 1e-9, "abs": 1e-12})
        assert b[col] == pytest.approx(a[col], **tol), (scheme, col)


def test_armero_petocz_conserves_the_energy_to_round_off():
    """clamped_bar, nx 80, T 12 (several impacts): the discrete energy with the springs'
    stays within 1e-9 (relative) of its start, while the springs store a visible share of
    it during contact (the penetration is not round-off)."""
    row = run_one("clamped_bar", "armero_petocz", nx=80, T=12.0).row
    assert row["status"] == "ok", row["notes"]
    assert row["energy_drift_max"] < 1e-9
    assert row["penetration_max"] > 1e-3
    # the same scheme's springs evaluated at t_{n+1} (`penalty`, trapezoidal) drift more
    plain = run_one("clamped_bar", "penalty", nx=80, T=12.0).row
    assert plain["energy_drift_max"] > 1e3 * max(row["energy_drift_max"], 1e-15)


def test_armero_petocz_conserves_the_energy_on_a_body():
    row = run_one("disc_drop[degree=1]", "armero_petocz", nx=3, T=12.0, step_repeats=1).row
    assert row["status"] == "ok" and row["penetration_max"] > 0.0
    assert row["energy_drift_max"] < 1e-9


def test_secant_force_is_the_discrete_gradient():
    """phi (g - gn) = Phi(g) - Phi(gn), Phi = k/2 min(0, .)^2, and dphi its derivative
    (central differences), on every branch."""
    k = 3.0

    def Phi(g):  # noqa: N802 - the energy's name
        return 0.5 * k * min(0.0, g) ** 2

    for g, gn in [(-0.3, -0.1), (-0.2, 0.4), (0.5, -0.25), (0.2, 0.3), (-1e-3, 2.0)]:
        phi, dphi = secant_force(g, gn, k)
        assert phi * (g - gn) == pytest.approx(Phi(g) - Phi(gn), rel=1e-14, abs=1e-16)
        e = 1e-7
        num = (secant_force(g + e, gn, k)[0] - secant_force(g - e, gn, k)[0]) / (2 * e)
        assert dphi == pytest.approx(num, rel=1e-6, abs=1e-9)


def test_newton_step_matches_scipy_root():
    """The n_c gaps of a step against scipy's `root` on the same system, from random
    states across the obstacle; the residual at round-off."""
    rng = np.random.default_rng(3)
    nc = 6
    B = rng.standard_normal((nc, nc))
    W = B @ B.T + nc * np.eye(nc)
    k = rng.uniform(10.0, 1e4, nc)
    a = 0.5 * 0.01**2
    for _ in range(20):
        gf = rng.uniform(-1.0, 1.0, nc)
        gn = rng.uniform(-0.1, 0.5, nc)
        g, phi = np.empty(nc), np.empty(nc)
        assert discrete_gradient_solve(gf, gn, k, W, a, g, phi) >= 0

        def R(x, gf=gf, gn=gn):  # noqa: N802 - the residual's name
            return x - gf + a * W @ np.array([secant_force(x[i], gn[i], k[i])[0]
                                              for i in range(nc)])

        ref = so.root(R, gf, tol=1e-14).x
        assert np.max(np.abs(R(g))) <= 1e-14
        assert g == pytest.approx(ref, abs=1e-11)


def test_declared_classes():
    assert make_scheme("armero_petocz").traits().family == Family.PENALTY
    assert make_scheme("semi_explicit").traits().family == Family.MODIFIED_MASS
    assert make_scheme("semi_explicit").traits().implicit is False
