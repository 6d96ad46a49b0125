"""Prepare once, step many: the common shape of the sparse schemes' steppers.

A stepper's constructor does all the set-up of a scheme on a `SparseProblem` that does
not depend on the number of steps (factorisations, Delassus matrices, contact laws,
initial acceleration and predictors); `run(nsteps, stride)` makes a fresh state,
allocates the samples and statistics and calls the one compiled loop
(`contact_bench.core.loop.drive`) with the scheme's step. A caller that
times the stepping times `run` alone, and its set-up by timing the constructor. `run`
starts from the same state every time, so two calls return the same trajectory.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import replace
from typing import Any, NamedTuple

import numpy as np

from contact_bench.api.plugin import Stepper, Trajectory
from contact_bench.api.problem import banded
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.contact_stats import new_friction_book, new_stats
from contact_bench.core.loop import START_DATA, Record
from contact_bench.core.obstacle import Sphere
from contact_bench.kernels.csr import CSR, csr_arrays
from contact_bench.kernels.recording import SampleBuffers


def with_tforce(state: type, name: str, doc: str) -> type:
    """The named tuple `name`: the fields of the named tuple `state` (owned there), then
    `tforce`, the step's force on each tangent row, which the loop's friction work reads
    (`contact_bench.core.loop.book_friction`): a frictional scheme's state beside its
    frictionless one. Made in `state`'s module, where it must be bound to `name` (numba's
    cache finds it there by name)."""
    cls = NamedTuple(name, [*state.__annotations__.items(), ("tforce", np.ndarray)])
    cls.__module__, cls.__doc__ = state.__module__, doc
    return cls


class SparseStepper(Stepper, ABC):
    """A scheme prepared on `problem` with step `dt`; `run` steps it from t = 0.

    A stepper that steps contact dof by contact dof refuses a problem whose gap operator
    is general (a slanted or curved obstacle, two bodies) in one line unless it declares
    `any_gap_operator` (its contact goes through `contact_bench.kernels.contact`), and a
    time-dependent load (`SparseProblem.load`) unless it adds it (`adds_time_load`)."""

    #: the kernel adds `SparseProblem.load` at each step's time level
    adds_time_load: bool = False
    #: the kernel takes any gap operator G (else only dof selections)
    any_gap_operator: bool = False
    #: the kernel follows a curved obstacle (`ContactSet.obstacle`): its contact solve
    #: re-linearises the gaps every step (`contact_bench.kernels.contact.gaps`)
    follows_curved: bool = False

    def __init__(self, problem: SparseProblem, dt: float) -> None:
        if not self.any_gap_operator:
            problem.contact.selected_dofs(f"the compiled {type(self).__name__}")
        ob = getattr(problem.contact, "obstacle", None)
        if ob is not None and not self.follows_curved:
            c = problem.contact
            if c.frictional:
                law = (f"mu = {float(np.max(c.friction)):g}" if c.friction is not None
                       and np.any(np.asarray(c.friction) > 0)
                       else f"Tresca threshold {float(np.max(c.tresca)):g}")
                raise ValueError(f"friction ({law}) on a curved obstacle (a sphere "
                                 f"of radius {ob.radius:g}): the compiled "
                                 f"{type(self).__name__} keeps its normal and tangent rows "
                                 "fixed for the run")
            raise ValueError(f"the compiled {type(self).__name__} does not follow a curved "
                             "obstacle (its gap operator is fixed for the run)")
        if getattr(problem, "load", None) is not None and not self.adds_time_load:
            raise ValueError(f"the compiled {type(self).__name__} does not add a "
                             "time-dependent load (SparseProblem.load)")
        self.problem = problem
        self.dt = float(dt)

    @abstractmethod
    def run(self, nsteps: int, stride: int) -> Trajectory:
        """`nsteps` steps from the initial state, a sample every `stride` steps and at
        the last one."""


class LoopStepper(SparseStepper):
    """A scheme prepared for the one compiled loop (`contact_bench.core.loop.drive`):
    a subclass's constructor sets `ops` (its typed operators), `gamma` (the weight of a
    step's end force in its impulse), `force0` (the force at t = 0, the statistics'
    start), `sample0` (the entries of sample 0 it gives itself, e.g. {"energy": E0} with
    a contact law's energy) and `start` (`loop.START_*`); the class gives its compiled
    `loop` (a staticmethod: the scheme's cached `x_loop(ops, st, rec, nsteps, stride)`,
    which calls `drive` with the scheme's step) and `new_state()`, a fresh state.

    `run_keeping(nsteps, stride, dofs)`: the same run keeping only the displacement
    samples of `dofs` (`SampleBuffers`' keep)."""

    loop: Callable[..., tuple[int, int, float, int]]
    #: the loop writes every sample (a selection of dofs can be kept)
    keeps_selection = True

    def __init__(self, problem: SparseProblem, dt: float) -> None:
        super().__init__(problem, dt)
        self.ops: tuple[Any, ...] = ()
        self.gamma = 1.0
        self.force0 = 0.0
        self.sample0: dict[str, float] = {}
        self.start = START_DATA

    def new_state(self) -> tuple[Any, ...]:
        """A fresh state (the initial one, copied, and zeroed scratch) for one run."""
        raise NotImplementedError

    def gap_operator(self) -> CSR | Sphere:
        """The gap operator G (gaps = gap0 + G U) the loop's bookkeeping reads, or the
        curved obstacle (its exact gaps)."""
        c = self.problem.contact
        if getattr(c, "obstacle", None) is not None:
            return c.obstacle
        return csr_arrays(c.gap_operator(self.problem.nfree))

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
        return self._run(nsteps, stride, np.asarray(dofs, np.int64))

    def _run(self, nsteps: int, stride: int, keep: np.ndarray | None) -> Trajectory:
        p = self.problem
        out = SampleBuffers(p, nsteps, stride, keep)
        for name, value in self.sample0.items():
            getattr(out, name)[0] = value
        stats = new_stats(self.force0, out.size)
        t, U, V, gap, stress, energy = out.arrays()
        book = new_friction_book(p.contact.tangents if getattr(p.contact, "frictional", False)
                                 else None, out.size, p.contact.size)
        rec = Record(t, U, V, gap, stress, energy, stats, np.zeros(p.contact.size, np.bool_),
                     self.gap_operator(), np.asarray(p.contact.gap0, float), self.dt,
                     float(self.gamma), int(self.start), book)
        k, done, min_gap, blow = type(self).loop(self.ops, self.new_state(), rec, int(nsteps),
                                                 int(stride))
        return out.trajectory(k, done, min_gap, blow, self.dt, stats, book)


def keep_selection(traj: Trajectory, dofs: np.ndarray) -> Trajectory:
    """A full trajectory reduced to what `LoopStepper.run_keeping` keeps: U[:, dofs],
    no V, the largest |U| and |V| of each sample in extra."""
    extra = dict(traj.extra, U_absmax=np.max(np.abs(traj.U), axis=1, initial=0.0),
                 V_absmax=np.max(np.abs(traj.V), axis=1, initial=0.0))
    return replace(traj, U=np.ascontiguousarray(traj.U[:, np.asarray(dofs, np.int64)]),
                   V=np.empty((traj.t.size, 0)), extra=extra)


def run_keeping(stepper: Stepper, nsteps: int, stride: int, dofs: np.ndarray) -> Trajectory:
    """`stepper.run(nsteps, stride)` keeping only the displacement samples of `dofs` (and
    each sample's largest |U|, |V|): without the full samples in memory when the stepper
    can (`LoopStepper.run_keeping`), else reduced after the run."""
    if isinstance(stepper, LoopStepper):
        return stepper.run_keeping(nsteps, stride, dofs)
    return keep_selection(stepper.run(nsteps, stride), dofs)
