"""The one stepping loop of the compiled sparse schemes, and all of its bookkeeping.

A compiled scheme gives two numba functions over its own typed structures (named tuples
of arrays and numbers: its operators `ops`, read only, and its state `st`, advanced in
place):

* `step(ops, st, n) -> int`: advance from step n - 1 to step n; leave the step's contact
  force of each contact point (>= 0, the one its velocity update feels) in `st.force`,
  and a frictional step the force on each tangent row in `st.tforce`; return `OK`, or
  `BLOWN` when the state is no longer finite (the run stops there);
* `sample(ops, st) -> (energy, stress, V)`: the sampled energy, stress and velocity of
  the state reached (a scheme whose velocity is not a state, or is staggered, computes
  it here).

`drive(step, sample, ops, st, rec, nsteps, stride)` makes the steps and does the
bookkeeping, here and nowhere else: the contact statistics (chatter, first contact with
its start and end interpolated within the step from the smallest gap, peak force,
impulse: `contact_bench.core.contact_stats`) and the friction work and tangential
impulse (with tangential forces: `contact_stats.friction_update`) after every step, the
smallest gap over every step, a sample every `stride` steps and at the last one (time, U,
V, smallest gap, stress, energy, the impulse, the friction work and the tangential
impulse so far), and the blow-up rule
(`contact_bench.core.sampling.blown_up`) at each sample. Each distinct step function
compiles its own specialisation of the loop (numba dispatchers as arguments), so the
loop costs no indirect call. `drive` is inlined into (numba `inline="always"`) and
cached with its caller: a scheme module calls it from its own cached entry point, three
lines,

    @njit(cache=True)
    def run_x(ops, st, rec, nsteps, stride):
        return drive(x_step, x_sample, ops, st, rec, nsteps, stride)

whose cache holds the specialised loop. (Compiled as a function of its own, the loop
would hold the dispatchers as Python objects, which numba cannot cache; a cached loop
keyed on every scheme's dispatcher could not be read by a process that has not imported
them all.)

`Record` holds what the loop writes (the sample arrays of `SampleBuffers`, the
statistics) and what it needs for it: the gap operator G (CSR, one row per contact
point: gaps = gap0 + G U), the step, the impulse weight of the step's end force, and how
the scheme starts (`START_*`). The plain-numpy `contact_bench.api.TrajectoryRecorder`
calls the same `book_step` and `book_sample` (and `friction_update`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, types
from numba.extending import overload

from contact_bench.core.contact_stats import (
    LAST_FORCE,
    friction_sample,
    friction_start,
    friction_update,
    impulse_sample,
    impulse_update,
    stats_gap,
    stats_update,
)
from contact_bench.core.obstacle import min_gap
from contact_bench.core.refcount import uncounted_inline
from contact_bench.core.sampling import blown_up

#: `step`'s return: the step is done
OK = 0
#: `step`'s return: the state is not finite any more; the run stops at this step
BLOWN = 1

#: the run starts from the problem's initial state, sample 0 written by `SampleBuffers`
START_DATA = 0
#: `step(ops, st, 0)` computes level 0's contact force (a two-step scheme that samples
#: level n once it has made step n + 1): counted in the statistics, its stress sampled
START_LEVEL = 1
#: `step(ops, st, 0)` projects the initial state (massless dofs solved): sample 0 and
#: the energy of reference are the projected state's, its force the impulse's start
START_PROJECTED = 2


class Record(NamedTuple):
    """What `drive` writes and reads besides the scheme's own structures."""

    t: np.ndarray
    U: object  # (samples, n) array, or a kept selection (buf, dofs, absmax)
    V: object
    gap: np.ndarray
    stress: np.ndarray
    energy: np.ndarray
    stats: np.ndarray  # `contact_bench.core.contact_stats.new_stats`
    status: np.ndarray  # the contact status of each contact point (chatter)
    G: tuple  # the gap operator as CSR arrays (gaps = gap0 + G U), or a curved obstacle
    gap0: np.ndarray
    dt: float
    gamma: float  # the weight of the step's end force in its impulse
    start: int  # START_DATA, START_LEVEL or START_PROJECTED
    #: the friction work's book (`contact_bench.core.contact_stats.FrictionBook`; empty
    #: without friction)
    friction: tuple


def store_state(out, k, X):  # pragma: no cover - compiled through its overload
    """Row k of a state's samples: `out[k, :] = X` for an array; for a kept selection
    (buf, dofs, absmax) buf[k, :] = X[dofs] and absmax[k] = max |X| (NaN if X has one)."""
    if isinstance(out, tuple):
        buf, dofs, absmax = out
        buf[k, :] = X[dofs]
        absmax[k] = np.max(np.abs(X))
    else:
        out[k, :] = X


@overload(store_state)
def _store_state_compiled(out, k, X):  # pragma: no cover - compiled
    if isinstance(out, types.Array):
        def full(out, k, X):
            out[k, :] = X
        return full
    if isinstance(out, types.BaseTuple):
        def kept(out, k, X):
            buf, dofs, absmax = out
            for j in range(dofs.size):
                buf[k, j] = X[dofs[j]]
            absmax[k] = np.max(np.abs(X))
        return kept
    return None


@uncounted_inline
def smallest_gap(G, gap0, U, start):  # pragma: no cover - compiled
    """min(start, the smallest gap of the contact points in U): gap0 + G U for G's CSR
    arrays, the exact nonlinear gaps for a curved obstacle (`contact_bench.core.obstacle.
    min_gap`)."""
    return min_gap(G, gap0, U, start)


@uncounted_inline
def book_forces(stats, status, force, gap, n, dt, gamma):  # pragma: no cover - compiled
    """The statistics of step n (step dt, impulse weight gamma) from its contact forces and
    its smallest gap (`stats_update`, `impulse_update`), on the arrays they write: numba
    counts references to every array of a typed tuple passed to a compiled function, so
    the loop passes these two, not the whole `Record`."""
    stats_update(stats, status, force, gap, n * dt)
    impulse_update(stats, force, dt, gamma)


@njit(cache=True)
def book_step(rec, force, gap, n):  # pragma: no cover - compiled
    """The statistics of step n from its contact forces and its smallest gap
    (`book_forces` with the record's arrays, step and weight)."""
    book_forces(rec.stats, rec.status, force, gap, n, rec.dt, rec.gamma)


def book_friction(rec, st):  # pragma: no cover - compiled through its overload
    """The step's friction work and tangential impulse (`friction_update`) from the
    tangential forces a frictional step leaves in `st.tforce`; nothing for a state
    without them. Inlined
    (numba `inline="always"`): a call would count references to every array of rec and
    st once per step, for nothing in a frictionless run."""


@overload(book_friction, inline="always")
def _book_friction_compiled(rec, st):  # pragma: no cover - compiled
    if "tforce" in getattr(st, "fields", ()):
        def book(rec, st):
            friction_update(rec.friction, st.tforce, st.U, rec.gamma)
        return book

    def none(rec, st):
        pass
    return none


@njit(cache=True)
def book_sample(rec, k, t, U, V, stress, e):  # pragma: no cover - compiled
    """Write sample k (time t, U, V, the smallest gap, stress, energy e, the impulse so
    far). True when the run has blown up (e not finite or far above |E(0)|)."""
    rec.t[k] = t
    store_state(rec.U, k, U)
    store_state(rec.V, k, V)
    rec.gap[k] = smallest_gap(rec.G, rec.gap0, U, np.inf)
    rec.stress[k] = stress
    rec.energy[k] = e
    impulse_sample(rec.stats, k)
    friction_sample(rec.friction, k)
    return blown_up(e, rec.energy[0])


@njit(inline="always")
def drive(step, sample, ops, st, rec, nsteps, stride):  # pragma: no cover - compiled
    """`nsteps` steps of the scheme (`step`, `sample`) from its state `st`, a sample every
    `stride` steps and at the last. Returns (samples written, steps done, smallest gap,
    blow-up step or -1)."""
    if rec.start == START_LEVEL:
        step(ops, st, 0)
        book_step(rec, st.force, smallest_gap(rec.G, rec.gap0, st.U, np.inf), 0)
        rec.stress[0] = sample(ops, st)[1]
    elif rec.start == START_PROJECTED:
        step(ops, st, 0)
        rec.stats[LAST_FORCE] = st.force.sum()
        e, stress, V = sample(ops, st)
        rec.energy[0] = e
        book_sample(rec, 0, 0.0, st.U, V, stress, e)
    friction_start(rec.friction, st.U)
    # read once: each read of a typed tuple's field counts references (`book_forces`)
    G, gap0, stats, status, dt, gamma = rec.G, rec.gap0, rec.stats, rec.status, rec.dt, rec.gamma
    U, force = st.U, st.force
    min_gap = smallest_gap(G, gap0, U, np.inf)
    if rec.start != START_LEVEL:
        stats_gap(stats, min_gap, 0.0)  # the free gap at t = 0
    k = 1
    for n in range(1, nsteps + 1):
        if step(ops, st, n) == BLOWN:
            return k, n, min_gap, n
        gap = smallest_gap(G, gap0, U, np.inf)
        book_forces(stats, status, force, gap, n, dt, gamma)
        book_friction(rec, st)
        min_gap = min(min_gap, gap)
        if n % stride == 0 or n == nsteps:
            e, stress, V = sample(ops, st)
            blown = book_sample(rec, k, n * rec.dt, st.U, V, stress, e)
            k += 1
            if blown:
                return k, n, min_gap, n
    return k, nsteps, min_gap, -1
