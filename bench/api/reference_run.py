"""A scene's numerical reference as a declared fine run (`ReferenceRun`) and what the
harness hands back from it (`ReferenceSamples`).

A scene without a closed form after the impact compares a run with the same scene run
finer (`Case.reference_run`). The scene only declares that run: which scheme, at which
resolution, step, number of steps and stride, and which dofs' displacements the error
norms read (`keep`). The harness computes it once, keeps it on disk keyed by the
request and the code (`contact_bench.harness.reference_cache`), reports its cost apart
(`ref_s`) and passes the samples to `Case.quantity_errors(..., reference=)`. Only the
kept dofs' displacements are stored (with each sample's largest |U| over every dof and
the contact stress), so a reference's memory grows with n_keep x samples, not with its
own dofs x samples.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass(frozen=True)
class ReferenceRun:
    """The fine run a scene declares as its reference: `scheme` (a spec) on the scene's
    problem at resolution `nx` (the scheme's mass variant), `nsteps` steps of `dt`, a
    sample every `stride` steps, the displacement samples of the dofs `keep` kept."""

    scheme: str
    nx: int
    dt: float
    nsteps: int
    stride: int
    keep: np.ndarray = field(compare=False)
    #: a line naming the run (report notes)
    label: str = ""
    #: the 1D bar's mesh grading (`contact_bench.api.fem.mesh_nodes`; 1: uniform)
    grading: float = 1.0

    def inputs(self) -> dict[str, Any]:
        """The request as plain values (the cache key's part), `keep` by its digest."""
        keep = np.ascontiguousarray(self.keep, np.int64)
        return {"scheme": self.scheme, "nx": int(self.nx), "dt": repr(float(self.dt)),
                "nsteps": int(self.nsteps), "stride": int(self.stride),
                "keep": hashlib.sha256(keep.tobytes()).hexdigest()[:16],
                "n_keep": int(keep.size), "grading": repr(float(self.grading))}


@dataclass
class ReferenceSamples:
    """A computed `ReferenceRun`: sample times t (K,), the kept dofs' displacements U
    (K, n_keep), the largest |U| over every dof at each sample `U_absmax` (K,), the
    contact stress (K,) and the contact zone's measure (total force = -stress x
    measure), the reference problem's number of dofs; `seconds`: what computing it took
    (set-up and stepping), `cached`: read back from the disk, not computed now."""

    t: np.ndarray
    U: np.ndarray
    U_absmax: np.ndarray
    stress: np.ndarray
    contact_measure: float
    ndofs: int
    seconds: float
    description: str = ""
    cached: bool = False

    @property
    def nbytes(self) -> int:
        return int(self.t.nbytes + self.U.nbytes + self.U_absmax.nbytes + self.stress.nbytes)
