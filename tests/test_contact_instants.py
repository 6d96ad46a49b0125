"""Contact instants between steps (`contact_bench.core.contact_stats`): the first
contact's start and end where the free motion's smallest gap crosses zero, for the
compiled loop, the plain-numpy recorder and the samples of the 1D kernels alike.

The dropped bar (L 10, height 5, g 10) falls freely until its end touches the obstacle
at t = sqrt(2 height / g) = 1: a rigid fall, which every scheme here integrates exactly
(a quadratic in t), so the exact start is known between steps. dt = 0.003 puts it a
third of the way into the step [0.999, 1.002]: the step's midpoint, the rule before,
is off by 5e-4 (dt / 6); the free secant's error is dt^2 g / (2 v) ~ 5e-6."""

from __future__ import annotations

import math

import numpy as np
import pytest

from contact_bench.api import TrajectoryRecorder
from contact_bench.api.fem import mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case
from contact_bench.core.contact_stats import new_stats, stats_gap, stats_update
from contact_bench.harness import run_one

DT = 0.003
HEIGHT, G = 5.0, 10.0
#: the impact of the rigid fall, computed apart from any scheme
T_IMPACT = math.sqrt(2.0 * HEIGHT / G)
#: the free secant's bound (module docstring), with room
TOL = 2e-5


def test_the_steps_bracket_the_impact_away_from_its_midpoint():
    n = math.floor(T_IMPACT / DT)
    mid = (n + 0.5) * DT
    assert n * DT < T_IMPACT < (n + 1) * DT and abs(mid - T_IMPACT) > 20 * TOL


@pytest.mark.parametrize("case, scheme", [
    ("dropped_bar", "redistributed"),  # the banded 1D kernel: samples (stride 1)
    ("embedded_bar[of=dropped_bar]", "redistributed"),  # the compiled loop's statistics
    ("embedded_bar[of=dropped_bar]", "penalty"),  # a penetrating law
    ("embedded_bar[of=dropped_bar]", "moreau_jean"),  # a velocity-level law
])
def test_the_start_is_the_free_falls_crossing_between_steps(case, scheme):
    row = run_one(case, scheme, nx=10, dt=DT, T=1.2).row
    start = T_IMPACT * (1.0 + row["err_contact_start"])  # the column: |start / 1 - 1|
    assert row["err_contact_start"] < TOL / T_IMPACT, (scheme, start)
    if row.get("first_contact_start") is not None:  # the statistics themselves
        assert abs(row["first_contact_start"] - T_IMPACT) < TOL


def test_the_recorder_interpolates_start_and_end_from_the_free_gaps():
    """A hand-made motion through `TrajectoryRecorder.record(..., forces=)`: the rigid
    fall to the obstacle, held there with a force, then released at te = 1.1234 at speed
    2 (gap 2 (t - te)): start T_IMPACT and end te between steps, to round-off for the
    linear release."""
    case = make_case("dropped_bar")
    semi = discretise(case, mesh_nodes(case.L, 4), "lumped")
    te, nsteps = 1.1234, 420
    rec = TrajectoryRecorder(semi, DT, nsteps, 1)
    ones = np.ones_like(semi.U0)
    for step in range(1, nsteps + 1):
        t = step * DT
        gap = HEIGHT - 0.5 * G * t * t if t < T_IMPACT else max(0.0, 2.0 * (t - te))
        force = 1.0 if T_IMPACT <= t < te else 0.0
        rec.record(step, gap * ones, 0.0 * ones, -force, forces=np.array([force]))
    extra = rec.trajectory().extra
    assert abs(extra["first_contact_start"] - T_IMPACT) < TOL
    assert extra["first_contact_end"] == pytest.approx(te, abs=1e-12)


def test_without_two_free_steps_the_switch_is_its_steps_midpoint():
    stats = new_stats()
    status = np.zeros(1, np.bool_)
    stats_gap(stats, 1.0, 0.0)
    stats_update(stats, status, np.array([1.0]), 0.0, 1.0)  # contact at the first step
    stats_update(stats, status, np.array([0.0]), 0.5, 2.0)  # released at the last one
    assert stats[1] == 0.5 and stats[2] == 1.5
