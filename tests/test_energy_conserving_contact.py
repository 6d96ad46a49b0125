"""The energy-conserving midpoint schemes: Laursen-Chawla (persistency) and Laursen-Love
(exact contact, velocity update), `contact_bench.kernels.energy_conserving`.

What each scheme is defined by, checked on its runs: the scenes it runs (the embedded
bar giving the 1D bar's row), Laursen-Chawla's conserved energy (recomputed here from
the samples with scipy, not read from the kernel) and its persistency on the contact
dof, Laursen-Love's exact contact and restored energy balance on the disc, and both
equal to the plain midpoint rule (standard Newmark 1/4, 1/2, another kernel) before the
first impact.
"""

from __future__ import annotations

import numpy as np
import pytest

from contact_bench.api.problem import as_problem
from contact_bench.api.registry import make_case
from contact_bench.harness.runner import run_one

SCHEMES = ("laursen_chawla", "laursen_love")
#: (scene, nx, T): small grids holding a first impact
SCENES = (("clamped_bar", 20, 2.5), ("dropped_bar", 20, 2.0),
          ("disc_drop[degree=1,lift=0.5]", 2, 5.0), ("sphere_drop[lift=0.1]", 2, 2.0),
          ("embedded_bar[of=clamped_bar,dim=2]", 16, 2.5),
          ("embedded_bar[of=clamped_bar,dim=3]", 16, 2.5))


def _energy(problem, traj) -> np.ndarray:
    """1/2 V.M.V + 1/2 U.K.U - F.U + offset of every sample, with the problem's scipy
    matrices (independent of the kernel's summation)."""
    problem = as_problem(problem)
    U, V = traj.U, traj.V
    return (0.5 * np.einsum("ki,ki->k", V, (problem.M @ V.T).T)
            + 0.5 * np.einsum("ki,ki->k", U, (problem.K @ U.T).T) - U @ problem.F
            + problem.energy_offset)


@pytest.mark.parametrize("scheme", SCHEMES)
@pytest.mark.parametrize("scene,nx,T", SCENES)
def test_runs_every_scene_form(scheme: str, scene: str, nx: int, T: float) -> None:
    run = run_one(scene, scheme, nx=nx, T=T, step_repeats=1)
    row = run.row
    assert row["status"] == "ok", row["notes"]
    assert np.isfinite(run.trajectory.extra["first_contact_start"]), "no impact in the run"
    assert np.all(np.isfinite(run.trajectory.U)) and np.all(np.isfinite(run.trajectory.V))
    assert row["energy_drift_max"] <= 1e-9, row["energy_drift_max"]


def _same_rows(scheme: str, dim: int, T: float) -> None:
    a = run_one("clamped_bar", scheme, nx=16, T=T, step_repeats=1).row
    b = run_one(f"embedded_bar[of=clamped_bar,dim={dim}]", scheme, nx=16, T=T,
                step_repeats=1).row
    assert b["symmetry_defect"] <= 1e-11
    for col in ("err_u_linf_l2", "err_u_l2_h1", "err_v_l2_l2", "err_stress_l2",
                "energy_final", "penetration_max"):
        assert b[col] == pytest.approx(a[col], rel=1e-9, abs=1e-12, nan_ok=True), col


@pytest.mark.parametrize("dim", [2, 3])
def test_embedded_bar_gives_the_1d_row(dim: int) -> None:
    """laursen_chawla through the first contact (its chatter included); laursen_love up
    to the impact: there its massive contact dofs bounce (the restored energy), and
    round-off splits the active set across the section, as `standard`'s
    (tests/test_sparse.py), so that the 2D/3D rows leave the 1D one."""
    _same_rows("laursen_chawla", dim, 2.5)
    _same_rows("laursen_love", dim, 0.99)


def test_laursen_chawla_conserves_the_energy_on_the_clamped_bar() -> None:
    """nx 80, T 12 (four periods, four impacts): relative drift below 1e-9, the energy
    recomputed from the samples."""
    run = run_one("clamped_bar", "laursen_chawla", nx=80, T=12.0, stride=1, step_repeats=1)
    assert run.row["status"] == "ok" and run.trajectory.extra["contact_steps"] > 0
    E = _energy(run.semi, run.trajectory)
    assert np.max(np.abs(E - E[0])) / abs(E[0]) <= 1e-9
    assert run.row["energy_drift_max"] <= 1e-9
    assert abs(E[0] - make_case("clamped_bar").exact_energy) <= 1e-3


def test_laursen_chawla_keeps_the_persistency_and_penetrates_little() -> None:
    """While the obstacle pushes (stress < 0) the contact node does not move; it
    penetrates (the price of the conserved energy), within the declared bound."""
    from contact_bench.api.registry import make_scheme

    run = run_one("clamped_bar", "laursen_chawla", nx=40, T=3.0, stride=1, step_repeats=1)
    tr = run.trajectory
    pushing = np.flatnonzero(tr.stress[1:] < 0.0) + 1
    assert pushing.size > 10
    assert np.all(tr.U[pushing, 0] == tr.U[pushing - 1, 0])
    pen = run.row["penetration_max"]
    assert 0.0 < pen <= make_scheme("laursen_chawla").penetration_bound(run.semi, run.row["dt"])


def test_laursen_love_restores_the_energy_balance_on_the_disc() -> None:
    """The disc (P1, small grid) bounces: exact contact (no penetration beyond
    round-off) and the energy recomputed from the samples within 1e-3 (round-off, in
    fact) of its start, although the exact contact alone loses energy at the impact."""
    run = run_one("disc_drop[degree=1,lift=0.5]", "laursen_love", nx=2, T=5.0, stride=1,
                  step_repeats=1)
    row = run.row
    assert row["status"] == "ok" and run.trajectory.extra["contact_steps"] > 0
    E = _energy(run.semi, run.trajectory)
    assert np.max(np.abs(E - E[0])) / abs(E[0]) <= 1e-3
    assert row["energy_drift_max"] <= 1e-3
    assert row["penetration_max"] <= 1e-10 * np.max(np.abs(run.semi.U0) + 1.0)


def test_both_are_the_midpoint_rule_before_the_impact() -> None:
    """Before the first contact both equal standard Newmark (1/4, 1/2), the midpoint rule
    on a linear problem, from another kernel (the bar's banded one)."""
    ref = run_one("clamped_bar", "standard", nx=20, T=0.9, stride=1, step_repeats=1)
    for scheme in SCHEMES:
        run = run_one("clamped_bar", scheme, nx=20, T=0.9, stride=1, step_repeats=1)
        assert run.trajectory.extra["contact_steps"] == 0
        np.testing.assert_allclose(run.trajectory.U, ref.trajectory.U, rtol=0, atol=1e-12)
        np.testing.assert_allclose(run.trajectory.V, ref.trajectory.V, rtol=0, atol=1e-10)


def test_laursen_love_stress_carries_its_energy_restoring_impulse() -> None:
    """The stress column is every contact force the step applies: the obstacle's and the
    kick that restores the energy, spread over its step. Over the run its integral is the
    impulse the statistics keep (the momentum balance's) to round-off; over the clamped
    bar's exact first contact (its bounces included) it is close to that contact's 0.5:
    0.4914 at nx 80, dt 0.005 (0.498 at nx 160), the scheme's own transfer (before, the
    column carried 0.104 of it: the kicks were missing)."""
    from contact_bench.api.registry import make_case
    from contact_bench.harness.quantities import reference_first_contact

    T = 2.5
    run = run_one("clamped_bar", "laursen_love", nx=80, T=T, stride=1, step_repeats=1)
    tr, dt = run.trajectory, float(run.row["dt"])
    ref = reference_first_contact(make_case("clamped_bar").exact(T), T)
    assert ref.impulse == pytest.approx(0.5, abs=1e-9)
    during = (tr.t > ref.start) & (tr.t <= ref.end + dt)
    assert dt * float(np.sum(-tr.stress[during])) == pytest.approx(0.5, abs=1e-2)
    assert dt * float(np.sum(-tr.stress[1:])) == pytest.approx(tr.extra["contact_impulse"],
                                                               rel=1e-12)
