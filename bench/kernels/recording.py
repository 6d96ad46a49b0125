"""What every sparse kernel records: samples, contact statistics, the blow-up rule.

Written once here and used by `contact_bench.kernels.sparse`, `sparse_family`,
`sparse_impact` and `sparse_explicit`:

* `SampleBuffers`: the sample arrays (time, U, V, smallest gap, stress, energy) of a
  run, sample 0 written from the problem's initial state; `SampleBuffers.trajectory`
  wraps what a kernel wrote into a `Trajectory`.
* the contact statistics: one float array (`new_stats`) with named slots (`CHATTER`,
  ..., `FIRST_CONTACT_IMPULSE`, then from `SAMPLE_IMPULSE` one slot per sample), updated
  each step by `stats_update` (status switches, first contact, peak force) and
  `impulse_update` (the contact impulse with the velocity update's weights), and read
  into `Trajectory.extra` by `contact_extra`.
* `write_sample`: one sample (time, U, V, smallest gap, stress, energy, the impulse so
  far) and the blow-up test (`contact_bench.core.sampling.blown_up`).
* `smallest_gap`: the smallest gap of the contact dofs; `csr_energy`: the discrete
  energy 1/2 V.M.V + 1/2 U.K.U - F.U + offset with M, K as CSR arrays.

The compiled functions are numba `njit`s: a kernel calls them, and so can plain Python.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from contact_bench.api.plugin import Trajectory
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.sampling import blown_up, n_samples
from contact_bench.kernels.csr import csr_matvec

# ------------------------------------------------------------------ contact statistics

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


# ---------------------------------------------------------------------------- samples


@njit(cache=True)
def smallest_gap(gap0, U, dofs, start=np.inf):  # pragma: no cover - compiled
    """min(start, min_j gap0[j] + U[dofs[j]]): the smallest gap of the contact dofs
    `dofs` (their initial gaps gap0), or `start` if smaller (a running minimum)."""
    g = start
    for j in range(dofs.size):
        g = min(g, gap0[j] + U[dofs[j]])
    return g


@njit(cache=True)
def csr_energy(Mp, Mi, Mx, Kp, Ki, Kx, F, U, V, offset, w):  # pragma: no cover - compiled
    """1/2 V.M.V + 1/2 U.K.U - F.U + offset, M and K as CSR arrays; w is scratch (n)."""
    csr_matvec(Mp, Mi, Mx, V, w)
    e = 0.5 * (V @ w)
    csr_matvec(Kp, Ki, Kx, U, w)
    return e + 0.5 * (U @ w) - F @ U + offset


@njit(cache=True)
def write_sample(k, t, U, V, gap0, idx, stress, e, E0, t_out, U_out, V_out, cu_out, s_out,
                 E_out, stats):  # pragma: no cover - compiled
    """Write sample k: time t, U, V, the smallest gap of the contact dofs idx, the stress,
    the energy e and the impulse so far (`impulse_sample`). True when the run has blown
    up (`contact_bench.core.sampling.blown_up`: e not finite or far above |E0|)."""
    t_out[k] = t
    U_out[k, :] = U
    V_out[k, :] = V
    cu_out[k] = smallest_gap(gap0, U, idx)
    s_out[k] = stress
    E_out[k] = e
    impulse_sample(stats, k)
    return blown_up(e, E0)


class SampleBuffers:
    """The sample arrays of a run of `n_samples(nsteps, stride)` samples: t, U, V, gap
    (the smallest gap of the contact dofs), stress and energy, with sample 0 written from
    the problem's initial state (stress 0; a kernel may overwrite sample 0's entries)."""

    def __init__(self, p: SparseProblem, nsteps: int, stride: int) -> None:
        k = n_samples(nsteps, stride)
        n = p.nfree
        self.t = np.zeros(k)
        self.U = np.zeros((k, n))
        self.V = np.zeros((k, n))
        self.gap = np.zeros(k)
        self.stress = np.zeros(k)
        self.energy = np.zeros(k)
        self.U[0], self.V[0] = p.U0, p.V0
        self.gap[0] = float(np.min(p.gaps(p.U0))) if p.contact.size else np.inf
        self.energy[0] = p.energy(p.U0, p.V0)

    @property
    def size(self) -> int:
        """The number of samples the buffers hold."""
        return self.t.size

    def arrays(self) -> tuple[np.ndarray, ...]:
        """(t, U, V, gap, stress, energy): a kernel's output arguments, in that order."""
        return self.t, self.U, self.V, self.gap, self.stress, self.energy

    def trajectory(self, k: int, done: int, min_gap: float, blow: int, dt: float,
                   stats: np.ndarray) -> Trajectory:
        """The first k samples as a `Trajectory`: `done` steps taken, `min_gap` the
        smallest gap over every step, `blow` the blow-up step (< 0: none), the contact
        statistics `stats` (`contact_extra`) in `extra`."""
        return Trajectory(t=self.t[:k], U=self.U[:k], V=self.V[:k], contact_u=self.gap[:k],
                          stress=self.stress[:k], energy=self.energy[:k],
                          min_contact_u=float(min_gap), steps_done=int(done),
                          blowup_time=None if blow < 0 else float(blow * dt),
                          extra=contact_extra(stats, k))
