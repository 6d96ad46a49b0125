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
contact's start and end, peak total force: `Trajectory.extra`).

A compiled (numba) kernel of the bar takes `rec.buffers` and writes its samples with
`contact_bench.core.sampling.record_sample`, then `rec.from_kernel(...)` wraps them.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from contact_bench.api.plugin import Semidiscrete, Trajectory
from contact_bench.core.contact_stats import contact_extra, new_stats, stats_update
from contact_bench.core.sampling import blown_up, energy_of, is_sample, n_samples


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
                 energy0: float | None = None) -> None:
        from contact_bench.api.problem import as_problem  # the problem layer imports this one

        self.problem = as_problem(problem)
        self.dt, self.nsteps, self.stride = float(dt), int(nsteps), int(stride)
        k, n = n_samples(self.nsteps, self.stride), self.problem.nfree
        self.t, self.U, self.V = np.zeros(k), np.zeros((k, n)), np.zeros((k, n))
        self.contact_u, self.stress, self.energy = np.zeros(k), np.zeros(k), np.zeros(k)
        self.samples = 0
        self.steps_done = 0
        self.blowup_step = -1
        p = self.problem
        self.energy0 = p.energy(p.U0, p.V0) if energy0 is None else float(energy0)
        self.min_contact_u = self._gap(p.U0)
        self._status = np.zeros(p.contact.size, np.bool_)
        self.stats = new_stats()  # the compiled kernels' contact statistics
        self._forces_given = False
        self._write(0, p.U0, p.V0, 0.0, self.energy0)

    def _gap(self, U: np.ndarray) -> float:
        gaps = self.problem.gaps(U)
        return float(np.min(gaps)) if gaps.size else np.inf

    @property
    def buffers(self) -> tuple[np.ndarray, ...]:
        """(t, U, V, contact_u, stress, energy): the arguments `t_out ... E_out` of
        `record_sample` in a compiled kernel (sample 0 already written)."""
        return self.t, self.U, self.V, self.contact_u, self.stress, self.energy

    def _write(self, step: int, U: np.ndarray, V: np.ndarray, stress: float,
               energy: float) -> None:
        k = self.samples
        self.t[k], self.U[k], self.V[k] = step * self.dt, U, V
        self.contact_u[k], self.stress[k], self.energy[k] = self._gap(U), stress, energy
        self.samples += 1

    def record(self, step: int, U: np.ndarray, V: np.ndarray, stress: float,
               forces: np.ndarray | None = None, energy: float | None = None) -> bool:
        """After step `step` (1 ... nsteps): the new state, its contact stress (<= 0 in
        compression), optionally the step's contact forces (one per contact point, >= 0)
        and the scheme's own energy (default: `problem.energy`, computed at samples
        only). Returns True when the run has blown up: stop stepping then."""
        self.steps_done = step
        self.min_contact_u = min(self.min_contact_u, self._gap(U))
        if forces is not None:  # the kernels' update of the contact statistics
            self._forces_given = True
            stats_update(self.stats, self._status, np.ascontiguousarray(forces, float), step,
                         self.dt)
        if not is_sample(step, self.nsteps, self.stride):
            return False
        e = self.problem.energy(U, V) if energy is None else float(energy)
        self._write(step, U, V, stress, e)
        if blown_up(e, self.energy0):
            self.blowup_step = step
            return True
        return False

    def trajectory(self, **extra: Any) -> Trajectory:
        """The recorded samples as a `Trajectory` (extra: scheme-specific diagnostics;
        the contact statistics when `record` was given the forces)."""
        stats = contact_extra(self.stats) if self._forces_given else {}
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
