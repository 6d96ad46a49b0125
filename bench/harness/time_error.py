"""The time integrator's own error: a run against its semi-discrete problem's
time-converged solution (the same scheme, mesh and mass at dt / factor), beside the total
error against the scene's reference.

DiffEqDevTools-style work-precision separates the time integrator from the space
discretisation: the error of a run at dt against the same scheme on the same mesh and
mass at dt / `factor` (sampled at the run's times: stride x factor) estimates the time
error alone, since both share the semi-discrete problem (its mass variant and contact
formulation: a penalty's springs stay in it). With order p the fine run's own time error
is factor^-p of the run's: `factor` 16 leaves it below 1/16 of the measured one for p = 1.
The fine run is a cached reference (`contact_bench.harness.reference_cache`), computed
once per (scene, scheme, mesh, dt, T, stride, factor) and read back afterwards.

Columns: `err_time_u`, the largest error of U over the samples and dofs over the largest
|U_fine|; `err_time_stress`, the l2 error over the samples of the contact stress over its
l2 norm; `time_ref_compute_s`, what computing the fine run took.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from contact_bench.api.plugin import Case, Scheme, Trajectory
from contact_bench.api.reference_run import ReferenceRun
from contact_bench.harness.reference_cache import reference_samples

#: the columns this module fills
TIME_ERROR_COLUMNS = ("err_time_u", "err_time_stress")


def time_reference_run(scheme: Scheme, nx: int, dt: float, steps: int, stride: int,
                       nfree: int, factor: int, grading: float = 1.0) -> ReferenceRun:
    """The fine run of a run at (nx, dt, steps, stride): the same scheme at dt / factor,
    every dof kept, sampled at the run's times."""
    return ReferenceRun(scheme.spec, int(nx), dt / factor, steps * factor, stride * factor,
                        np.arange(nfree, dtype=np.int64),
                        f"{scheme.spec} at nx = {nx}, dt = {dt / factor:g} (dt / {factor})",
                        grading=float(grading))


def time_errors(case: Case, scheme: Scheme, problem: Any, traj: Trajectory, row: dict,
                steps: int, stride: int, factor: int, notes: list[str]) -> dict[str, Any]:
    """`err_time_u`, `err_time_stress` and `time_ref_compute_s` of a finished run (module
    docstring); {} for a run that stopped early."""
    if factor < 2 or traj.steps_done < steps:
        return {}
    request = time_reference_run(scheme, row["nx"], float(row["dt"]), steps, stride,
                                 problem.nfree, factor, row["grading"])
    ref = reference_samples(case, request)
    notes.append(f"time error against {ref.description} (its cost: time_ref_compute_s)")
    k = min(ref.t.size, traj.t.size)
    out: dict[str, Any] = {"time_ref_compute_s": ref.seconds}
    scale = float(np.max(ref.U_absmax[:k]))
    if scale > 0:
        out["err_time_u"] = float(np.max(np.abs(traj.U[:k] - ref.U[:k]))) / scale
    norm = float(np.linalg.norm(ref.stress[:k]))
    if norm > 0:
        out["err_time_stress"] = float(np.linalg.norm(traj.stress[:k] - ref.stress[:k])) / norm
    return out
