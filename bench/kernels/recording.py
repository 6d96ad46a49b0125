"""The sample buffers of a compiled run and the energy the steps' samples read.

* `SampleBuffers`: the sample arrays (time, U, V, smallest gap, stress, energy) of a
  run, sample 0 written from the problem's initial state; `SampleBuffers.trajectory`
  wraps what the loop wrote into a `Trajectory` (with the contact statistics of
  `contact_bench.core.contact_stats` in its extra). Given `keep` (a few dofs), only those
  dofs' displacements are kept, with the largest |U| and |V| of each sample (a
  reference that needs no more holds n_keep, not n, values per sample: `store_state`).
* `csr_energy`: the discrete energy 1/2 V.M.V + 1/2 U.K.U - F.U + offset, M and K CSR.

The loop that writes the samples and keeps the statistics is
`contact_bench.core.loop.drive`, the one owner of that bookkeeping.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from contact_bench.api.plugin import Trajectory
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.contact_stats import FrictionBook, contact_extra, friction_extra
from contact_bench.core.sampling import n_samples
from contact_bench.kernels.csr import matvec

# ---------------------------------------------------------------------------- samples


@njit(cache=True)
def csr_energy(M, K, F, U, V, offset, w):  # pragma: no cover - compiled
    """1/2 V.M.V + 1/2 U.K.U - F.U + offset, M and K as `CSR`; w is scratch (n)."""
    matvec(M, V, w)
    e = 0.5 * (V @ w)
    matvec(K, U, w)
    return e + 0.5 * (U @ w) - F @ U + offset


@njit(cache=True)
def plain_sample(o, s):  # pragma: no cover - compiled
    """The sample of a scheme whose energy is csr_energy's and whose stress is its
    contact force's, -sum(force) / the zone's measure (`contact_bench.core.loop`'s
    sample for ops with M, K, F, offset, weights and a state with U, V, force, w)."""
    e = csr_energy(o.M, o.K, o.F, s.U, s.V, o.offset, s.w)
    return e, -s.force.sum() / o.weights.sum(), s.V


class SampleBuffers:
    """The sample arrays of a run of `n_samples(nsteps, stride)` samples: t, U, V, gap
    (the smallest gap of the contact dofs), stress and energy, with sample 0 written from
    the problem's initial state (stress 0; a kernel may overwrite sample 0's entries).

    `keep` (dofs): U holds only those dofs' columns and V none; the largest |U| and |V|
    of each sample go to the trajectory's extra (`U_absmax`, `V_absmax`). The kernels
    receive the selection as the tuple (buf, dofs, absmax) and write it with
    `store_state` (a kernel that writes U_out itself cannot keep a selection)."""

    def __init__(self, p: SparseProblem, nsteps: int, stride: int,
                 keep: np.ndarray | None = None) -> None:
        k = n_samples(nsteps, stride)
        n = p.nfree
        self.t = np.zeros(k)
        self.keep = None if keep is None else np.ascontiguousarray(keep, np.int64)
        if self.keep is None:
            self.U = np.zeros((k, n))
            self.V = np.zeros((k, n))
            self.U[0], self.V[0] = p.U0, p.V0
        else:
            self.U = np.zeros((k, self.keep.size))
            self.V = np.zeros((k, 0))
            self.U_absmax, self.V_absmax = np.zeros(k), np.zeros(k)
            self.U[0] = np.asarray(p.U0, float)[self.keep]
            self.U_absmax[0] = np.max(np.abs(p.U0), initial=0.0)
            self.V_absmax[0] = np.max(np.abs(p.V0), initial=0.0)
        self.gap = np.zeros(k)
        self.stress = np.zeros(k)
        self.energy = np.zeros(k)
        self.gap[0] = float(np.min(p.gaps(p.U0))) if p.contact.size else np.inf
        self.energy[0] = p.energy(p.U0, p.V0)

    @property
    def size(self) -> int:
        """The number of samples the buffers hold."""
        return self.t.size

    def arrays(self) -> tuple[np.ndarray, ...]:
        """(t, U, V, gap, stress, energy): a kernel's output arguments, in that order
        (U and V as (buf, dofs, absmax) selections when only some dofs are kept)."""
        if self.keep is None:
            return self.t, self.U, self.V, self.gap, self.stress, self.energy
        return (self.t, (self.U, self.keep, self.U_absmax),
                (self.V, np.zeros(0, np.int64), self.V_absmax), self.gap, self.stress,
                self.energy)

    def trajectory(self, k: int, done: int, min_gap: float, blow: int, dt: float,
                   stats: np.ndarray, friction: FrictionBook | None = None) -> Trajectory:
        """The first k samples as a `Trajectory`: `done` steps taken, `min_gap` the
        smallest gap over every step, `blow` the blow-up step (< 0: none), the contact
        statistics `stats` (`contact_extra`) in `extra` (with `U_absmax`, `V_absmax` when
        only some dofs were kept, and the friction work and tangential impulse at each
        sample, `friction_extra`, when the run kept it)."""
        extra = contact_extra(stats, k)
        if friction is not None:
            extra.update(friction_extra(friction, k, dt))
        if self.keep is not None:
            extra.update(U_absmax=self.U_absmax[:k], V_absmax=self.V_absmax[:k])
        return Trajectory(t=self.t[:k], U=self.U[:k], V=self.V[:k], contact_u=self.gap[:k],
                          stress=self.stress[:k], energy=self.energy[:k],
                          min_contact_u=float(min_gap), steps_done=int(done),
                          blowup_time=None if blow < 0 else float(blow * dt),
                          extra=extra)
