"""Prepare once, step many: the common shape of the sparse schemes' steppers.

A stepper's constructor does all the set-up of a scheme on a `SparseProblem` that does
not depend on the number of steps (factorisations, Delassus matrices, contact laws,
initial acceleration and predictors); `run(nsteps, stride)` copies the initial state,
allocates the samples and statistics and calls the compiled kernel. A caller that
times the stepping times `run` alone, and its set-up by timing the constructor. `run`
starts from the same state every time, so two calls return the same trajectory.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from contact_bench.api.plugin import Stepper, Trajectory
from contact_bench.api.problem import banded
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.contact_stats import new_stats
from contact_bench.kernels.recording import SampleBuffers


class SparseStepper(Stepper, ABC):
    """A scheme prepared on `problem` with step `dt`; `run` steps it from t = 0.

    The compiled kernels step contact dof by contact dof: a problem whose gap operator
    is general (a slanted or curved obstacle) is refused here in one line, and so is a
    time-dependent load (`SparseProblem.load`) unless the stepper adds it
    (`adds_time_load`)."""

    #: the kernel adds `SparseProblem.load` at each step's time level
    adds_time_load: bool = False

    def __init__(self, problem: SparseProblem, dt: float) -> None:
        problem.contact.selected_dofs(f"the compiled {type(self).__name__}")
        if getattr(problem, "load", None) is not None and not self.adds_time_load:
            raise ValueError(f"the compiled {type(self).__name__} does not add a "
                             "time-dependent load (SparseProblem.load)")
        self.problem = problem
        self.dt = float(dt)

    @abstractmethod
    def run(self, nsteps: int, stride: int) -> Trajectory:
        """`nsteps` steps from the initial state, a sample every `stride` steps and at
        the last one."""


class KernelStepper(SparseStepper):
    """A stepper whose `run` is one call of a compiled kernel with the sparse kernels'
    argument layout:

        kernel(*operators, *state, *params, nsteps, stride, energy offset,
               t, U, V, gap, stress, energy, stats, *tail)
            -> (samples written, steps done, smallest gap, blow-up step or -1)

    `state` (the arrays the kernel advances in place) is copied at every run. A
    subclass's constructor sets `kernel`, `operators`, `state`, `params`, `tail`, the
    force at t = 0 `force0` (the statistics' start) and `sample0`, the entries of sample
    0 it writes itself (e.g. {"energy": E0} with a contact law's energy).

    `run_keeping(nsteps, stride, dofs)`: the same run keeping only the displacement
    samples of `dofs` (`SampleBuffers`' keep), for a kernel that writes its samples with
    `write_sample` only (`keeps_selection`)."""

    #: the kernel writes every sample through `write_sample` (a selection can be kept)
    keeps_selection = True

    def __init__(self, problem: SparseProblem, dt: float) -> None:
        super().__init__(problem, dt)
        self.kernel: Callable[..., tuple[int, int, float, int]]
        self.operators: tuple[Any, ...] = ()
        self.state: tuple[Any, ...] = ()
        self.params: tuple[Any, ...] = ()
        self.tail: tuple[Any, ...] = ()
        self.force0 = 0.0
        self.sample0: dict[str, float] = {}

    def run(self, nsteps: int, stride: int) -> Trajectory:
        traj = self._run(nsteps, stride, None)
        if banded(self.problem) is None:
            return traj
        # the bar: its sampled energies summed as the 1D kernels sum them (exactly, where
        # CSR dot products lose digits to cancellation at large n), plus the law's energy
        E = np.array([self.problem.energy(U, V) + self.law_energy(U)
                      for U, V in zip(traj.U, traj.V, strict=True)])
        return replace(traj, energy=E)

    def law_energy(self, U: np.ndarray) -> float:
        """The contact law's energy in state U (a penalty's springs), part of the recorded
        energy; none with exact contact."""
        return 0.0

    def run_keeping(self, nsteps: int, stride: int, dofs: np.ndarray) -> Trajectory:
        """`run` with only U[:, dofs] kept (V none), and the largest |U|, |V| of each
        sample in extra["U_absmax"], extra["V_absmax"]: the same steps, bit for bit."""
        if not self.keeps_selection:
            return keep_selection(self.run(nsteps, stride), dofs)
        return self._run(nsteps, stride, np.asarray(dofs, np.int64))

    def _run(self, nsteps: int, stride: int, keep: np.ndarray | None) -> Trajectory:
        out = SampleBuffers(self.problem, nsteps, stride, keep)
        for name, value in self.sample0.items():
            getattr(out, name)[0] = value
        stats = new_stats(self.force0, out.size)
        k, done, min_gap, blow = self.kernel(
            *self.operators, *(a.copy() for a in self.state), *self.params, int(nsteps),
            int(stride), float(self.problem.energy_offset), *out.arrays(), stats, *self.tail)
        return out.trajectory(k, done, min_gap, blow, self.dt, stats)


def keep_selection(traj: Trajectory, dofs: np.ndarray) -> Trajectory:
    """A full trajectory reduced to what `KernelStepper.run_keeping` keeps: U[:, dofs],
    no V, the largest |U| and |V| of each sample in extra."""
    extra = dict(traj.extra, U_absmax=np.max(np.abs(traj.U), axis=1, initial=0.0),
                 V_absmax=np.max(np.abs(traj.V), axis=1, initial=0.0))
    return replace(traj, U=np.ascontiguousarray(traj.U[:, np.asarray(dofs, np.int64)]),
                   V=np.empty((traj.t.size, 0)), extra=extra)


def run_keeping(stepper: Stepper, nsteps: int, stride: int, dofs: np.ndarray) -> Trajectory:
    """`stepper.run(nsteps, stride)` keeping only the displacement samples of `dofs` (and
    each sample's largest |U|, |V|): without the full samples in memory when the stepper
    can (`KernelStepper.run_keeping`), else reduced after the run."""
    if isinstance(stepper, KernelStepper):
        return stepper.run_keeping(nsteps, stride, dofs)
    return keep_selection(stepper.run(nsteps, stride), dofs)
