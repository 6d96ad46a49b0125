"""`TrajectoryRecorder`: the sampling, energy, gap and blow-up rules of every scheme, for a
new scheme's time loop in plain Python/numpy, on any problem (the bar or a 2D/3D body),
so that it copies no boilerplate::

    rec = TrajectoryRecorder(problem, dt, nsteps, stride)   # records step 0 (U0, V0)
    for step in range(1, nsteps + 1):
        ...                                               # advance U, V to t = step * dt
        if rec.record(step, U, V, stress, forces):        # True: blown up, stop
            break
    return rec.trajectory()

The rules (docs/plugin-api.md): a sample every `stride` steps and at the last step; the
smallest gap (the bar: u(0, t)) over every step, `min_contact_u`; the energy
1/2 V.M.V + 1/2 U.K.U - F.U + energy_offset (`problem.energy`) unless the scheme gives
its own; the run stops at the first sample whose energy is not finite or exceeds
`BLOWUP_FACTOR` |E(0)|. Given the contact forces of each step (one per contact point, >= 0),
it keeps the contact statistics of the compiled kernels (status switches, first
contact's start and end, peak total force, the impulse, at every sample too:
`Trajectory.extra`), with the same functions as the compiled loop
(`contact_bench.core.loop`: `book_step`, `book_sample`), so a scheme written in numpy
gets every statistic a compiled one gets. `gamma` is the weight of a step's end force in
its impulse (1: the step's force acts over the whole step, as a kick-drift step's kick).

A compiled (numba) kernel of the bar takes `rec.buffers` (a `Samples`) and writes its
samples with `contact_bench.core.sampling.record_sample`, then `rec.from_kernel(...)` wraps them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

from contact_bench.api.plugin import Semidiscrete, Trajectory
from contact_bench.core.contact_stats import (
    contact_extra,
    friction_extra,
    friction_start,
    friction_update,
    new_friction_book,
    new_stats,
    stats_gap,
)
from contact_bench.core.loop import START_DATA, Record, book_sample, book_step, smallest_gap
from contact_bench.core.sampling import Samples, energy_of, is_sample, n_samples


def discrete_energy(semi: Semidiscrete, U: np.ndarray, V: np.ndarray) -> float:
    """The energy of the bar's state (U, V): 1/2 V.M.V + 1/2 U.K.U - F.U + energy_offset
    (kinetic + strain + gravity potential of the full nodal vector), computed as every
    built-in kernel computes it."""
    M, K = semi.M, semi.K
    return float(energy_of(M.diag, M.off, K.diag, K.off, semi.F, np.ascontiguousarray(U, float),
                           np.ascontiguousarray(V, float), semi.energy_offset))


class TrajectoryRecorder:
    """Sample buffers of a run of `nsteps` steps of size `dt`, keeping every `stride`-th
    step and the last one, and the run's bookkeeping (see the module docstring).

    `problem`: the problem the scheme received (`Scheme.prepare`), or a bar's
    `Semidiscrete`. `energy0` replaces the energy of the initial state when the scheme's
    own energy has more terms (a penalty or Nitsche term); pass the same kind of value
    to `record`.
    """

    def __init__(self, problem: Any, dt: float, nsteps: int, stride: int,
                 energy0: float | None = None, gamma: float = 1.0) -> None:
        from contact_bench.api.problem import as_problem  # the problem layer imports this one

        self.problem = p = as_problem(problem)
        self.dt, self.nsteps, self.stride = float(dt), int(nsteps), int(stride)
        k, n = n_samples(self.nsteps, self.stride), p.nfree
        self.t, self.U, self.V = np.zeros(k), np.zeros((k, n)), np.zeros((k, n))
        self.contact_u, self.stress, self.energy = np.zeros(k), np.zeros(k), np.zeros(k)
        self.samples = 0
        self.steps_done = 0
        self.blowup_step = -1
        self.energy0 = p.energy(p.U0, p.V0) if energy0 is None else float(energy0)
        self.stats = new_stats(samples=k)  # the compiled loop's contact statistics
        G = sp.csr_matrix(p.contact.gap_operator(n))
        curved = getattr(p.contact, "obstacle", None)  # its exact gaps
        # the friction work and tangential impulse, with the compiled loop's functions
        # (with friction only)
        self.friction = new_friction_book(
            p.contact.tangents if getattr(p.contact, "frictional", False) else None, k,
            p.contact.size)
        self._rec = Record(self.t, self.U, self.V, self.contact_u, self.stress, self.energy,
                           self.stats, np.zeros(p.contact.size, np.bool_),
                           curved or (G.indptr.astype(np.int64), G.indices.astype(np.int64),
                                      G.data.astype(float)), np.asarray(p.contact.gap0, float),
                           self.dt, float(gamma), START_DATA, self.friction)
        friction_start(self.friction, self._state(p.U0))
        self.min_contact_u = self._gap(p.U0, np.inf)
        stats_gap(self.stats, self.min_contact_u, 0.0)  # the free gap at t = 0
        self._forces_given = False
        self.energy[0] = self.energy0
        book_sample(self._rec, 0, 0.0, self._state(p.U0), self._state(p.V0), 0.0,
                    self.energy0)
        self.samples = 1

    @staticmethod
    def _state(X: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(X, float)

    def _gap(self, U: np.ndarray, start: float) -> float:
        r = self._rec
        return float(smallest_gap(r.G, r.gap0, self._state(U), start))

    @property
    def buffers(self) -> Samples:
        """(t, U, V, contact_u, stress, energy) as the `Samples` that `record_sample` takes
        in a compiled kernel (sample 0 already written)."""
        return Samples(self.t, self.U, self.V, self.contact_u, self.stress, self.energy)

    def record(self, step: int, U: np.ndarray, V: np.ndarray, stress: float,
               forces: np.ndarray | None = None, energy: float | None = None,
               tangential_forces: np.ndarray | None = None) -> bool:
        """After step `step` (1 ... nsteps): the new state, its contact stress (<= 0 in
        compression), optionally the step's contact forces (one per contact point, >= 0)
        and the scheme's own energy (default: `problem.energy`, computed at samples
        only); on a problem with friction, the step's force on each tangent row (the
        friction work, `contact_bench.core.contact_stats.friction_update`; None: 0).
        Returns True when the run has blown up: stop stepping then."""
        self.steps_done = step
        gap = self._gap(U, np.inf)
        self.min_contact_u = min(self.min_contact_u, gap)
        if forces is not None:  # the compiled loop's statistics, impulse included
            self._forces_given = True
            book_step(self._rec, self._state(forces), gap, step)
        if self.friction.ut.size:
            f = (np.zeros(self.friction.ut.size) if tangential_forces is None
                 else self._state(tangential_forces))
            friction_update(self.friction, f, self._state(U), self._rec.gamma)
        if not is_sample(step, self.nsteps, self.stride):
            return False
        e = self.problem.energy(U, V) if energy is None else float(energy)
        blown = book_sample(self._rec, self.samples, step * self.dt, self._state(U),
                            self._state(V), float(stress), e)
        self.samples += 1
        if blown:
            self.blowup_step = step
            return True
        return False

    def trajectory(self, **extra: Any) -> Trajectory:
        """The recorded samples as a `Trajectory` (extra: scheme-specific diagnostics;
        the contact statistics when `record` was given the forces)."""
        stats = contact_extra(self.stats, self.samples) if self._forces_given else {}
        stats.update(friction_extra(self.friction, self.samples, self.dt))
        return self.from_kernel(self.samples, self.steps_done, self.min_contact_u,
                                self.blowup_step, **stats, **extra)

    def from_kernel(self, samples: int, steps_done: int, min_contact_u: float,
                    blowup_step: int, **extra: Any) -> Trajectory:
        """Wrap the buffers filled by a compiled kernel: samples written, steps done, the
        minimum of u(0, t_n) over all steps, the blow-up step (< 0: none)."""
        k = samples
        return Trajectory(
            t=self.t[:k], U=self.U[:k], V=self.V[:k], contact_u=self.contact_u[:k],
            stress=self.stress[:k], energy=self.energy[:k],
            min_contact_u=float(min_contact_u), steps_done=int(steps_done),
            blowup_time=None if blowup_step < 0 else float(blowup_step * self.dt),
            extra=extra)
