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

from contact_bench.api.plugin import Trajectory
from contact_bench.api.sparse import SparseProblem


class SparseStepper(ABC):
    """A scheme prepared on `problem` with step `dt`; `run` steps it from t = 0."""

    def __init__(self, problem: SparseProblem, dt: float) -> None:
        self.problem = problem
        self.dt = float(dt)

    @abstractmethod
    def run(self, nsteps: int, stride: int) -> Trajectory:
        """`nsteps` steps from the initial state, a sample every `stride` steps and at
        the last one."""
