"""The contact statistics of a run: one float array with named slots, updated each step
from the step's contact forces and smallest gap, read into `Trajectory.extra`.

The first contact's start and end are instants between steps, not step times: a step
with a force after one without (or the reverse) brackets the switch, and the switch is
put where the free motion's smallest gap crosses zero (`free_crossing`): the secant of the
two free steps before the start, extrapolated forward, and the secant of the two free
steps after the end, extrapolated backward (the end is settled one step late), each
clipped to the step that brackets the switch. The free side is used because it means the
same for every contact law: inside the contact the gap is held at exactly zero by an exact
(Lagrange) scheme, negative by the compliance of a penalty or Nitsche law, and whatever a
velocity-level (Moreau-Jean, restitution) law leaves, while on the free side every scheme
integrates the same free motion. The force is not used: it has no linear trend across a
switch (an exact contact's force jumps, the clamped bar's from 0 to 1/2 and back), so its
linear zero crossing would put every switch at a step. Without two free steps on the side
(a contact from the first step, a release at the run's last step, a contact that resumes
at once) the switch is the midpoint of its step; a contact whose last step without
force already touches (gap <= 0: a body that starts on the obstacle) starts at that step.

The compiled sparse kernels (`contact_bench.kernels`) and the plain-numpy
`contact_bench.api.TrajectoryRecorder` keep them with the same functions, so that a
scheme written in numpy reports the same chatter, first contact and peak force as a
compiled one. The update functions are numba `njit`s: a kernel calls them, and so can
plain Python.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit

from contact_bench.core.refcount import uncounted, uncounted_inline

#: status switches of the contact dofs (chatter)
CHATTER = 0
#: the first contact's start, between the last step without force and the first with
#: (module docstring; NaN before)
FIRST_CONTACT_START = 1
#: the first contact's end, between its last step with force and the first without
#: (module docstring; NaN before)
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
#: the smallest gap of the last update and its time (NaN before any)
GAP_1 = 9
TIME_1 = 10
#: the smallest gap of the update before it and its time (NaN before)
GAP_2 = 11
TIME_2 = 12
#: 1 while the first contact's end waits for the next step's gap to be settled
END_PENDING = 13
#: the first of the per-sample slots: the impulse accumulated up to each sample
SAMPLE_IMPULSE = 14
#: the names of the slots before `SAMPLE_IMPULSE`, in slot order
STATS_FIELDS = ("chatter", "first_contact_start", "first_contact_end", "peak_contact_force",
                "contact_steps", "first_contact_peak", "contact_impulse", "last_force",
                "first_contact_impulse", "gap_1", "time_1", "gap_2", "time_2", "end_pending")


def new_stats(force0: float = 0.0, samples: int = 0) -> np.ndarray:
    """The contact statistics of a run, zero or NaN as the slots' docs say, with the
    force at t = 0 `force0` (the one the initial acceleration holds, 0 for exact contact)
    in `LAST_FORCE`, and `samples` per-sample impulse slots (0 until written).

    A kernel calls `stats_update` each step, and `impulse_update` if its velocity update
    is a weighted sum of the end forces of the step."""
    out = np.zeros(SAMPLE_IMPULSE + int(samples))
    out[:SAMPLE_IMPULSE] = [0.0, np.nan, np.nan, 0.0, 0.0, 0.0, np.nan, float(force0), np.nan,
                            np.nan, np.nan, np.nan, np.nan, 0.0]
    return out


@uncounted
def free_crossing(ta, ga, tb, gb, lo, hi):  # pragma: no cover - compiled
    """The time where the line through the free gaps (ta, ga), (tb, gb) crosses zero,
    clipped to [lo, hi] (the step that brackets the switch); its midpoint when the gaps
    are not both finite or the line is flat."""
    if not (np.isfinite(ta) and np.isfinite(ga) and np.isfinite(tb) and np.isfinite(gb)) \
            or ga == gb or ta == tb:
        return 0.5 * (lo + hi)
    t = tb - gb * (tb - ta) / (gb - ga)
    return min(max(t, lo), hi)


def sampled_switches(t: np.ndarray, on: np.ndarray, gap: np.ndarray
                     ) -> tuple[int, int, float, float | None] | None:
    """The first contact of sampled states, by the rule of the per-step statistics: the
    first sample a in contact (`on`), the first sample b after it not in contact (t.size
    if none), the start (t[0] if a = 0) and the end (None if b = t.size) interpolated
    from the samples' smallest gaps `gap` (`free_crossing` on the two free samples next
    to each switch; the midpoint without them). None without contact."""
    if not on.any():
        return None
    a = int(np.argmax(on))
    off = np.flatnonzero(~on[a:])
    b = a + int(off[0]) if off.size else t.size
    nan = np.nan
    if a == 0:
        start = float(t[0])
    elif gap[a - 1] <= 0.0:  # touching already at the last sample without force
        start = float(t[a - 1])
    else:
        ta, ga = (float(t[a - 2]), float(gap[a - 2])) if a >= 2 else (nan, nan)
        start = float(free_crossing(ta, ga, float(t[a - 1]), float(gap[a - 1]),
                                    float(t[a - 1]), float(t[a])))
    end = None
    if b < t.size:
        free = b + 1 < t.size and not on[b + 1]
        tb, gb = (float(t[b + 1]), float(gap[b + 1])) if free else (nan, nan)
        end = float(free_crossing(float(t[b]), float(gap[b]), tb, gb, float(t[b - 1]),
                                  float(t[b])))
    return a, b, start, end


@uncounted
def stats_gap(stats, gap, t):  # pragma: no cover - compiled
    """Keep the smallest gap `gap` at time t as the last one (the one before it shifts)."""
    stats[GAP_2] = stats[GAP_1]
    stats[TIME_2] = stats[TIME_1]
    stats[GAP_1] = gap
    stats[TIME_1] = t


@uncounted_inline
def stats_update(stats, status, lam, gap, t):  # pragma: no cover - compiled
    """Update the contact statistics with the contact forces lam of the state at time t
    (one per contact dof, >= 0) and its smallest gap; status (in/out) the previous
    contact status of each contact dof, updated. The first contact's start and end are
    interpolated from the free gaps (module docstring)."""
    total = 0.0
    anyc = False
    for i in range(lam.size):
        now = lam[i] > 0.0
        if now != status[i]:
            stats[CHATTER] += 1.0
            status[i] = now
        total += lam[i]
        anyc = anyc or now
    t0 = stats[TIME_1]  # the previous update's time (NaN: none)
    if stats[END_PENDING] > 0.0:  # the end's step, settled by this step's free gap
        stats[END_PENDING] = 0.0
        if not anyc:
            stats[FIRST_CONTACT_END] = free_crossing(stats[TIME_1], stats[GAP_1], t, gap,
                                                     stats[TIME_2], stats[TIME_1])
    if anyc:
        stats[CONTACT_STEPS] += 1.0
        if np.isnan(stats[FIRST_CONTACT_START]):
            if np.isnan(t0):  # in contact from the start
                stats[FIRST_CONTACT_START] = t
            elif stats[GAP_1] <= 0.0:  # touching already at the last step without force
                stats[FIRST_CONTACT_START] = t0
            else:
                stats[FIRST_CONTACT_START] = free_crossing(stats[TIME_2], stats[GAP_2], t0,
                                                           stats[GAP_1], t0, t)
        if np.isnan(stats[FIRST_CONTACT_END]) and total > stats[FIRST_CONTACT_PEAK]:
            stats[FIRST_CONTACT_PEAK] = total
    elif not np.isnan(stats[FIRST_CONTACT_START]) and np.isnan(stats[FIRST_CONTACT_END]):
        stats[FIRST_CONTACT_END] = 0.5 * (t0 + t)  # until the next step settles it
        stats[END_PENDING] = 1.0
    if total > stats[PEAK_CONTACT_FORCE]:
        stats[PEAK_CONTACT_FORCE] = total
    stats_gap(stats, gap, t)


@uncounted
def first_contact_impulse(stats, impulse):  # pragma: no cover - compiled
    """Keep `impulse` as the first contact's once that contact has ended (and not yet
    kept)."""
    if not np.isnan(stats[FIRST_CONTACT_END]) and np.isnan(stats[FIRST_CONTACT_IMPULSE]):
        stats[FIRST_CONTACT_IMPULSE] = impulse


@uncounted_inline
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


# ------------------------------------------------------------------ friction work
# (kept only for a problem with friction: a frictionless run's book has no tangent rows,
# and its trajectory no "friction_work")


class FrictionBook(NamedTuple):
    """The work and the impulse of the tangential contact forces on the body
    (`friction_update`): the tangent rows T as CSR arrays (`ContactSet.tangents`, point
    by point, n_t rows a point; none without friction), T U and the effective forces of
    the last step, the work so far (acc, one value) and at each sample, and the
    tangential impulse over dt so far summed per tangent (timp, n_t values: row j n_t +
    k adds to k) and at each sample (tsamples, samples x n_t)."""

    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray
    ut: np.ndarray
    last: np.ndarray
    acc: np.ndarray
    samples: np.ndarray
    timp: np.ndarray
    tsamples: np.ndarray


def new_friction_book(tangents: Any = None, samples: int = 0, points: int = 0
                      ) -> FrictionBook:
    """The book of a run with tangent rows `tangents` (a sparse matrix; None: frictionless,
    an empty book that keeps nothing) for `points` contact points (n_t = rows / points
    tangents each; 0: one) and `samples` per-sample slots."""
    if tangents is None:
        e = np.zeros(0)
        return FrictionBook(np.zeros(1, np.int64), np.zeros(0, np.int64), e, e, e,
                            np.zeros(1), e, e, np.zeros((0, 0)))
    T = sp.csr_matrix(tangents, dtype=float)
    m = T.shape[0]
    nt = m // int(points) if points else 1
    if points and (nt < 1 or nt * int(points) != m):
        raise ValueError(f"{m} tangent rows are not a whole number per point for "
                         f"{points!r} contact points")
    return FrictionBook(T.indptr.astype(np.int64), T.indices.astype(np.int64),
                        T.data.astype(float), np.zeros(m), np.zeros(m), np.zeros(1),
                        np.zeros(int(samples)), np.zeros(nt), np.zeros((int(samples), nt)))


@njit(cache=True)
def friction_start(fb, U):  # pragma: no cover - compiled
    """Start the book at the state U: T U kept, no tangential force before t = 0."""
    for i in range(fb.ut.size):
        acc = 0.0
        for k in range(fb.indptr[i], fb.indptr[i + 1]):
            acc += fb.data[k] * U[fb.indices[k]]
        fb.ut[i] = acc
        fb.last[i] = 0.0


@njit(cache=True)
def friction_update(fb, tforce, U, gamma):  # pragma: no cover - compiled
    """Add the step's friction work: (gamma f^{n+1} + (1 - gamma) f^n) . (T U^{n+1} - T
    U^n), f the tangential forces on the tangent rows (f^{n+1} = tforce, this step's;
    f^n the previous step's), gamma the loop's impulse weight (`impulse_update`): the
    step's tangential impulse over dt times the tangential displacement it moves through.
    For Newmark with gamma = 1/2 and for Moreau-Jean's theta = 1/2 (the force its
    impulse over dt, gamma = 1) this is exactly the tangential forces' share of the
    energy's change over the step, so E - friction work is conserved where E is. The
    same weighted force, summed per tangent, is the step's tangential impulse over dt
    (`impulse_update`'s rule on the tangent rows)."""
    w = 0.0
    nt = fb.timp.size
    for i in range(fb.ut.size):
        acc = 0.0
        for k in range(fb.indptr[i], fb.indptr[i + 1]):
            acc += fb.data[k] * U[fb.indices[k]]
        f = gamma * tforce[i] + (1.0 - gamma) * fb.last[i]
        w += f * (acc - fb.ut[i])
        fb.timp[i % nt] += f
        fb.ut[i] = acc
        fb.last[i] = tforce[i]
    fb.acc[0] += w


@njit(cache=True)
def friction_sample(fb, k):  # pragma: no cover - compiled
    """Record the friction work and the tangential impulse so far as sample k's
    (nothing for an empty book)."""
    if k < fb.samples.size:
        fb.samples[k] = fb.acc[0]
        for j in range(fb.timp.size):
            fb.tsamples[k, j] = fb.timp[j]


def friction_extra(fb: FrictionBook, samples: int, dt: float) -> dict[str, Any]:
    """{"friction_work": the work at each of the first `samples` samples,
    "tangential_impulse": the tangential contact impulse on the body so far at each of
    them, (samples, n_t), per tangent (a step of dt)} for a book with tangent rows; {}
    for a frictionless run's (its trajectory unchanged)."""
    if fb.indptr.size <= 1:
        return {}
    return {"friction_work": np.array(fb.samples[:samples]),
            "tangential_impulse": float(dt) * np.array(fb.tsamples[:samples])}
