"""The contact statistics of a run: one float array with named slots, updated each step
from the step's contact forces, read into `Trajectory.extra`.

The compiled sparse kernels (`contact_bench.kernels`) and the plain-numpy
`contact_bench.api.TrajectoryRecorder` keep them with the same functions, so that a
scheme written in numpy reports the same chatter, first contact and peak force as a
compiled one. The update functions are numba `njit`s: a kernel calls them, and so can
plain Python.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

#: status switches of the contact dofs (chatter)
CHATTER = 0
#: the time of the first step with a positive contact force (NaN before)
FIRST_CONTACT_START = 1
#: the time of the first step after the first contact without force (NaN before)
FIRST_CONTACT_END = 2
#: the peak total contact force over the run
PEAK_CONTACT_FORCE = 3
#: the number of steps in contact
CONTACT_STEPS = 4
#: the peak total contact force over the first contact
FIRST_CONTACT_PEAK = 5
#: the contact impulse accumulated by `impulse_update` (NaN for a kernel that keeps none)
CONTACT_IMPULSE = 6
#: the previous step's total contact force (at the start: the force at t = 0)
LAST_FORCE = 7
#: the impulse up to the end of the first contact (NaN until it ends)
FIRST_CONTACT_IMPULSE = 8
#: the first of the per-sample slots: the impulse accumulated up to each sample
SAMPLE_IMPULSE = 9
#: the names of the slots before `SAMPLE_IMPULSE`, in slot order
STATS_FIELDS = ("chatter", "first_contact_start", "first_contact_end", "peak_contact_force",
                "contact_steps", "first_contact_peak", "contact_impulse", "last_force",
                "first_contact_impulse")


def new_stats(force0: float = 0.0, samples: int = 0) -> np.ndarray:
    """The contact statistics of a run, zero or NaN as the slots' docs say, with the
    force at t = 0 `force0` (the one the initial acceleration holds, 0 for exact contact)
    in `LAST_FORCE`, and `samples` per-sample impulse slots (0 until written).

    A kernel calls `stats_update` each step, and `impulse_update` if its velocity update
    is a weighted sum of the end forces of the step."""
    out = np.zeros(SAMPLE_IMPULSE + int(samples))
    out[:SAMPLE_IMPULSE] = [0.0, np.nan, np.nan, 0.0, 0.0, 0.0, np.nan, float(force0), np.nan]
    return out


@njit(cache=True)
def stats_update(stats, status, lam, step, dt):  # pragma: no cover - compiled
    """Update the contact statistics with the step's contact forces lam (one per contact
    dof, >= 0; the force of step `step`, at t = step dt); status (in/out) the previous
    contact status of each contact dof, updated."""
    total = 0.0
    anyc = False
    for i in range(lam.size):
        now = lam[i] > 0.0
        if now != status[i]:
            stats[CHATTER] += 1.0
            status[i] = now
        total += lam[i]
        anyc = anyc or now
    if anyc:
        stats[CONTACT_STEPS] += 1.0
        if np.isnan(stats[FIRST_CONTACT_START]):
            stats[FIRST_CONTACT_START] = step * dt
        if np.isnan(stats[FIRST_CONTACT_END]) and total > stats[FIRST_CONTACT_PEAK]:
            stats[FIRST_CONTACT_PEAK] = total
    elif not np.isnan(stats[FIRST_CONTACT_START]) and np.isnan(stats[FIRST_CONTACT_END]):
        stats[FIRST_CONTACT_END] = step * dt
    if total > stats[PEAK_CONTACT_FORCE]:
        stats[PEAK_CONTACT_FORCE] = total


@njit(cache=True)
def first_contact_impulse(stats, impulse):  # pragma: no cover - compiled
    """Keep `impulse` as the first contact's once that contact has ended (and not yet
    kept)."""
    if not np.isnan(stats[FIRST_CONTACT_END]) and np.isnan(stats[FIRST_CONTACT_IMPULSE]):
        stats[FIRST_CONTACT_IMPULSE] = impulse


@njit(cache=True)
def impulse_update(stats, lam, dt, gamma):  # pragma: no cover - compiled
    """Add the step's contact impulse dt (gamma F_{n+1} + (1 - gamma) F_n), F the total
    force sum(lam) (F_{n+1} this step's, F_n the previous step's, `LAST_FORCE`); gamma the
    weight of the step's velocity update on its end force (Newmark and explicit Newmark:
    their gamma; the kick-drift central difference, whose kick carries the step's force
    whole: 1). Call it after the step's forces are final. The impulse at the step that
    ends the first contact carries the (1 - gamma) share of its last force."""
    total = 0.0
    for i in range(lam.size):
        total += lam[i]
    if np.isnan(stats[CONTACT_IMPULSE]):
        stats[CONTACT_IMPULSE] = 0.0
    stats[CONTACT_IMPULSE] += dt * (gamma * total + (1.0 - gamma) * stats[LAST_FORCE])
    stats[LAST_FORCE] = total
    first_contact_impulse(stats, stats[CONTACT_IMPULSE])


@njit(cache=True)
def impulse_sample(stats, k):  # pragma: no cover - compiled
    """Record the accumulated impulse as sample k's (nothing when the statistics have no
    slot for it or no impulse is kept). Call it when sample k is written."""
    if SAMPLE_IMPULSE + k < stats.size and not np.isnan(stats[CONTACT_IMPULSE]):
        stats[SAMPLE_IMPULSE + k] = stats[CONTACT_IMPULSE]


def contact_extra(stats: np.ndarray, samples: int | None = None) -> dict[str, Any]:
    """The contact statistics of a run as `Trajectory.extra`; "contact_impulse" and
    "first_contact_impulse" only from a kernel that accumulates them, and "impulse" (the
    accumulated impulse at each of the first `samples` samples) only if its statistics
    recorded them."""
    out: dict[str, Any] = {
        "chatter": float(stats[CHATTER]),
        "first_contact_start": float(stats[FIRST_CONTACT_START]),
        "first_contact_end": float(stats[FIRST_CONTACT_END]),
        "peak_contact_force": float(stats[PEAK_CONTACT_FORCE]),
        "contact_steps": float(stats[CONTACT_STEPS])}
    if stats.size > FIRST_CONTACT_PEAK:
        out["first_contact_peak"] = float(stats[FIRST_CONTACT_PEAK])
    if stats.size > CONTACT_IMPULSE and not np.isnan(stats[CONTACT_IMPULSE]):
        out["contact_impulse"] = float(stats[CONTACT_IMPULSE])
        if samples is not None and stats.size >= SAMPLE_IMPULSE + samples:
            out["impulse"] = np.array(stats[SAMPLE_IMPULSE:SAMPLE_IMPULSE + samples])
    if stats.size > FIRST_CONTACT_IMPULSE and not np.isnan(stats[FIRST_CONTACT_IMPULSE]):
        out["first_contact_impulse"] = float(stats[FIRST_CONTACT_IMPULSE])
    return out
