"""What every sparse kernel records: samples, contact statistics, the blow-up rule.

Written once here and used by `contact_bench.kernels.sparse`, `sparse_family`,
`sparse_impact` and `sparse_explicit`:

* `SampleBuffers`: the sample arrays (time, U, V, smallest gap, stress, energy) of a
  run, sample 0 written from the problem's initial state; `SampleBuffers.trajectory`
  wraps what a kernel wrote into a `Trajectory`. Given `keep` (a few dofs), only those
  dofs' displacements are kept, with the largest |U| and |V| of each sample (a
  reference that needs no more holds n_keep, not n, values per sample: `store_state`).
* the contact statistics (`contact_bench.core.contact_stats`, shared with the plain-numpy
  `TrajectoryRecorder`): one float array (`new_stats`) with named slots, updated each
  step by `stats_update` and `impulse_update`, read into `Trajectory.extra` by
  `contact_extra`.
* `write_sample`: one sample (time, U, V, smallest gap, stress, energy, the impulse so
  far) and the blow-up test (`contact_bench.core.sampling.blown_up`).
* `smallest_gap`: the smallest gap of the contact dofs; `csr_energy`: the discrete
  energy 1/2 V.M.V + 1/2 U.K.U - F.U + offset with M, K as CSR arrays.

The compiled functions are numba `njit`s: a kernel calls them, and so can plain Python.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.extending import overload

from contact_bench.api.plugin import Trajectory
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.contact_stats import contact_extra, impulse_sample
from contact_bench.core.sampling import blown_up, n_samples
from contact_bench.kernels.csr import csr_matvec

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


@njit(cache=True)
def write_sample(k, t, U, V, gap0, idx, stress, e, E0, t_out, U_out, V_out, cu_out, s_out,
                 E_out, stats):  # pragma: no cover - compiled
    """Write sample k: time t, U, V, the smallest gap of the contact dofs idx, the stress,
    the energy e and the impulse so far (`impulse_sample`). True when the run has blown
    up (`contact_bench.core.sampling.blown_up`: e not finite or far above |E0|)."""
    t_out[k] = t
    store_state(U_out, k, U)
    store_state(V_out, k, V)
    cu_out[k] = smallest_gap(gap0, U, idx)
    s_out[k] = stress
    E_out[k] = e
    impulse_sample(stats, k)
    return blown_up(e, E0)


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
                   stats: np.ndarray) -> Trajectory:
        """The first k samples as a `Trajectory`: `done` steps taken, `min_gap` the
        smallest gap over every step, `blow` the blow-up step (< 0: none), the contact
        statistics `stats` (`contact_extra`) in `extra` (with `U_absmax`, `V_absmax` when
        only some dofs were kept)."""
        extra = contact_extra(stats, k)
        if self.keep is not None:
            extra.update(U_absmax=self.U_absmax[:k], V_absmax=self.V_absmax[:k])
        return Trajectory(t=self.t[:k], U=self.U[:k], V=self.V[:k], contact_u=self.gap[:k],
                          stress=self.stress[:k], energy=self.energy[:k],
                          min_contact_u=float(min_gap), steps_done=int(done),
                          blowup_time=None if blow < 0 else float(blow * dt),
                          extra=extra)
