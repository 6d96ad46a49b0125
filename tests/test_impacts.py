"""contact_bench.harness.impacts: impacts, energy after each and rebound ratios, on a
synthetic trajectory and on the hertz_sphere scene."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp

from contact_bench.harness.impacts import impact_metrics, impact_table, impulse_residual
from contact_bench.harness.runner import run_one


def test_synthetic_two_impacts():
    # one dof of mass 2 moving vertically; contact area 1, force = -stress
    problem = SimpleNamespace(M=sp.identity(1, format="csr") * 2.0,
                              contact=SimpleNamespace(weights=np.array([1.0])),
                              vertical=np.array([1.0]), body_mass=2.0)
    t = np.arange(10.0)
    v = np.array([-1, -1, -0.5, 0.8, 0.8, -0.8, 0.0, 0.4, 0.4, 0.4])
    stress = -np.array([0, 0, 1, 1, 0, 0, 2, 0, 0, 0.0])
    energy = np.array([1, 1, 1, 1, 0.64, 0.64, 0.64, 0.16, 0.16, 0.16])
    traj = SimpleNamespace(t=t, V=v[:, None], stress=stress, energy=energy)
    table = impact_table(problem, traj)
    assert table["impact"].tolist() == [1, 2]
    assert table["start"].tolist() == [2.0, 6.0] and table["end"].tolist() == [3.0, 6.0]
    assert table["energy_after"].tolist() == pytest.approx([0.64, 0.16])
    assert table["rebound_ratio"].tolist() == pytest.approx([0.8, 0.5])
    row = impact_metrics(problem, traj)
    assert row == pytest.approx({"impacts": 2.0, "rebound_ratio": 0.8,
                                 "energy_after_first_impact": -0.36})
    # no vertical translation declared: no impact columns
    assert impact_metrics(SimpleNamespace(extra={}), traj) == {}


def test_hertz_sphere_rebounds_elastically():
    row = run_one("hertz_sphere", "redistributed").row
    assert row["impacts"] == 1
    assert row["rebound_ratio"] == pytest.approx(1.0, abs=0.01)
    assert abs(row["energy_after_first_impact"]) < 1e-4


def test_clamped_bar_quantity_columns():
    """The 1D clamped bar's first contact lasts 1 with force 1/2: the redistributed run
    finds the duration within a few steps; its peak force carries the node's oscillation."""
    row = run_one("clamped_bar", "redistributed", T=3.0).row
    assert row["err_contact_duration"] < 4 * row["dt"]
    assert 0.0 < row["err_peak_force"] < 1.0
    assert "err_free_fall" not in row  # not a quantity of this scene
    chatter = run_one("clamped_bar", "standard", T=3.0).row
    assert chatter["err_contact_duration"] > 0.5  # the standard mass lets go at once


def test_impulse_residual_of_a_balanced_and_a_broken_history():
    """A mass 2 under a load -1 with a contact force R: p_k - p_0 = -t_k + the trapezoid
    impulse of R holds for the constructed velocities; a kick breaks it."""
    dt = 0.5
    t = dt * np.arange(8)
    R = np.array([0, 0, 3, 4, 2, 0, 0, 0.0])
    impulse = dt * (np.cumsum(R) - 0.5 * R - 0.5 * R[0])
    p = -1.0 * t + impulse
    problem = SimpleNamespace(M=sp.identity(1, format="csr") * 2.0, F=np.array([-1.0]),
                              contact=SimpleNamespace(weights=np.array([1.0])),
                              vertical=np.array([1.0]), body_mass=2.0)
    traj = SimpleNamespace(t=t, V=(p / 2.0)[:, None], stress=-R, energy=np.ones(8))
    assert impulse_residual(problem, traj, dt) < 1e-15
    kicked = SimpleNamespace(t=t, V=((p + 0.1 * (t > 2)) / 2.0)[:, None], stress=-R,
                             energy=np.ones(8))
    assert impulse_residual(problem, kicked, dt) == pytest.approx(0.1 / impulse[-1])
    assert impulse_residual(problem, traj, 2 * dt) is None  # not every step


def test_impulse_residual_of_strided_samples():
    """Samples every 3 steps: the largest residual over the samples from the kernel's
    impulse at each (`extra["impulse"]`), or at the last sample from its total alone
    (`extra["contact_impulse"]`); without either (a kernel that keeps none) none."""
    dt = 0.5
    problem = SimpleNamespace(M=sp.identity(1, format="csr") * 2.0, F=np.array([-1.0]),
                              contact=SimpleNamespace(weights=np.array([1.0])),
                              vertical=np.array([1.0]), body_mass=2.0)
    t = 3 * dt * np.arange(4)
    J = 4.5
    p = -1.0 * t + np.array([0.0, 1.0, 3.0, J])
    traj = SimpleNamespace(t=t, V=(p / 2.0)[:, None], stress=np.zeros(4),
                           energy=np.ones(4), extra={"contact_impulse": J})
    assert impulse_residual(problem, traj, dt) < 1e-15
    broken = SimpleNamespace(**{**vars(traj), "extra": {"contact_impulse": J - 1.5}})
    assert impulse_residual(problem, broken, dt) == pytest.approx(1.5 / 3.0)
    assert impulse_residual(problem, SimpleNamespace(**{**vars(traj), "extra": {}}),
                            dt) is None
    cumulative = np.array([0.0, 1.0, 3.0, J])
    each = SimpleNamespace(**{**vars(traj), "extra": {"contact_impulse": J,
                                                      "impulse": cumulative}})
    assert impulse_residual(problem, each, dt) < 1e-15
    kicked = cumulative + np.array([0.0, 0.0, 0.6, 0.0])  # off at one inner sample only
    each.extra["impulse"] = kicked
    assert impulse_residual(problem, each, dt) == pytest.approx(0.6 / J)


#: one spec per sparse kernel (and form of the impulse: gamma-weighted forces, the whole
#: step's force, the impulse itself, the two-step scheme's centred weights, the ODE's)
KERNELS = [
    ("disc_drop", "redistributed"),  # newmark_sparse, gamma = 1/2
    ("disc_drop", "hht"),  # newmark_sparse, HHT's gamma
    ("disc_drop", "redistributed[beta=0]"),  # quasistatic_sparse
    ("disc_drop", "penalty[beta=0]"),  # explicit_law_sparse
    ("disc_drop", "taylor_flanagan"),  # taylor_flanagan_sparse (consistent mass)
    ("disc_drop[degree=1]", "taylor_flanagan[mass=lumped]"),  # central_sparse
    ("disc_drop", "moreau_jean"),  # moreau_jean_sparse: P
    ("disc_drop[degree=1]", "restitution[e=0.5]"),  # paoli_schatzman_sparse
    ("disc_drop", "ode_verlet"),  # verlet_sparse
    ("disc_drop", "ode_adaptive"),  # adaptive_sparse: J integrated with the state
]


@pytest.mark.parametrize("case, scheme", KERNELS)
def test_disc_drop_impulse_residual_at_every_stride(case, scheme):
    """Each sparse kernel records the impulse its momentum update applies at every sample:
    the residual is the largest over the samples, to round-off, the same at stride 1 and
    7 (the samples differ, the impulse does not); the last sample's balance from the
    samples alone agrees; the first contact's impulse (when it ended within the run) is
    the recorded impulse at its end; removing part of the impulse breaks the balance."""
    every = run_one(case, scheme, nx=2, T=15.0, stride=1)
    strided = run_one(case, scheme, nx=2, T=15.0, stride=7)
    assert every.row["status"] == strided.row["status"] == "ok"
    assert strided.trajectory.t.size < every.trajectory.t.size / 5
    tr, p = every.trajectory, every.semi
    J = tr.extra["contact_impulse"]
    assert J > 0.0 and tr.extra["impulse"].shape == tr.t.shape
    assert tr.extra["impulse"][-1] == J
    assert J == pytest.approx(strided.trajectory.extra["contact_impulse"], rel=1e-12)
    assert np.array_equal(strided.trajectory.extra["impulse"], tr.extra["impulse"][
        np.r_[np.arange(0, tr.t.size - 1, 7), tr.t.size - 1]])
    vertical = p.vertical
    mom = tr.V @ (p.M @ vertical)
    final = abs(mom[-1] - mom[0] - float(p.F @ vertical) * tr.t[-1] - J) / J
    assert every.row["impulse_residual"] < 1e-8 and strided.row["impulse_residual"] < 1e-8
    assert final <= every.row["impulse_residual"]
    if "first_contact_impulse" in tr.extra:  # the first contact ended: J at its end
        end = int(np.argmin(np.abs(tr.t - tr.extra["first_contact_end"])))
        assert tr.extra["first_contact_impulse"] == pytest.approx(tr.extra["impulse"][end],
                                                                  rel=1e-12)
        assert 0.0 < tr.extra["first_contact_impulse"] < J
    cut = dict(strided.trajectory.extra)
    cut["impulse"] = np.minimum(cut["impulse"], 0.8 * J)
    broken = dataclasses.replace(strided.trajectory, extra=cut)
    assert impulse_residual(strided.semi, broken, strided.row["dt"]) > 0.1


def test_run_outputs_hold_the_impact_table(tmp_path):
    from contact_bench.cli.main import main

    code = main(["run", "--case", "disc_drop", "--scheme", "redistributed", "--scheme",
                 "standard", "--nx", "2", "--T", "15", "--format", "csv", "--out",
                 str(tmp_path)])
    assert code == 0
    import pandas as pd

    table = pd.read_csv(tmp_path / "impacts.csv")
    assert list(table.columns) == ["case", "scheme", "nx", "dt", "impact", "start", "end",
                                   "energy_after", "rebound_ratio"]
    red = table[table["scheme"] == "redistributed"]
    std = table[table["scheme"] == "standard"]
    assert len(red) >= 1 and red["start"].iloc[0] == pytest.approx(10.0, abs=0.02)
    assert len(std) > len(red)  # the standard mass chatters
