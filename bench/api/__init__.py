"""The plugin contract (cases, schemes, what passes between them), parameters, the registry,
and the finite-element assembly with scikit-fem.

What a plugin author needs is importable from here (docs/plugin-api.md):
`from contact_bench.api import Scheme, Traits, Contact, Energy, TrajectoryRecorder, ...`.
"""

from contact_bench.api.derived import DerivedScene
from contact_bench.api.params import Param
from contact_bench.api.plugin import (
    BarCase,
    BodyCase,
    CallStepper,
    Case,
    Contact,
    Energy,
    Exact,
    Family,
    Scheme,
    Semidiscrete,
    Stepper,
    Traits,
    Trajectory,
)
from contact_bench.api.problem import BarProblem, BarScale, as_problem, banded
from contact_bench.api.recorder import TrajectoryRecorder, discrete_energy
from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core.errors import BenchError
from contact_bench.core.sampling import (
    BLOWUP_FACTOR,
    Run,
    Samples,
    blown_up,
    energy_of,
    energy_rows,
    is_sample,
    n_samples,
    record_sample,
    row_sums,
)

__all__ = [
    "BLOWUP_FACTOR", "BarCase", "BarProblem", "BarScale", "BenchError", "BodyCase",
    "CallStepper", "Case", "Contact", "DerivedScene", "Energy", "Exact", "Family", "Param",
    "Scheme",
    "Semidiscrete", "Stepper", "Traits", "Trajectory", "TrajectoryRecorder", "as_problem",
    "banded", "blown_up",
    "discrete_energy", "energy_of", "energy_rows", "is_sample", "make_case", "make_scheme",
    "n_samples", "record_sample", "row_sums", "Run", "Samples",
]
