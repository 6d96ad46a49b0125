"""Published reference values of production codes' verification cases, and a run's
errors against them.

A verification case (code_aster's SDNV100, Ansys's VM265) publishes a few numbers:
impact and release times, a contact force, a velocity. Each is stored in its scene file
as a `Published` value with its source (read in the named document, or derived there
from the document's own formula) and the tolerance the comparison uses (the document's
where it gives one, else the precision the value is printed with). The run's side is
read from its trajectory (`bar_observables`): the first contact as in
`contact_bench.exact.converged.first_contact` (start and end within half a step or a
sample of the scheme's own switch), the contact force the median of the samples' total
force inside the contact (the 1D references' force is constant during the contact; a
scheme's peak carries its oscillations and its mean the half steps at the switches)
times the section's area (a bar's stress is per unit section), the peak force the same
with the peak, the rebound
velocity the
mass-weighted mean velocity at the last sample (after the release: free flight).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from contact_bench.exact.converged import first_contact, total_force


@dataclass(frozen=True)
class Published:
    """A published reference value: the number, the relative tolerance the comparison
    uses, and where it comes from (and how exact it is)."""

    value: float
    tolerance: float
    source: str


def bar_observables(problem: Any, traj: Any, dt: float, area: float = 1.0
                    ) -> dict[str, float]:
    """impact_time, release_time, contact_duration, contact_force (the median over the
    contact's samples), peak_force (both times `area`) and rebound_velocity of a run (module
    docstring); those the run has."""
    fc = first_contact(problem, traj, dt)
    out: dict[str, float] = {}
    if not fc:
        return out
    out["impact_time"] = fc["contact_start"]
    out["peak_force"] = fc["peak_force"] * float(area)
    if "contact_end" in fc:
        out["release_time"] = fc["contact_end"]
        out["contact_duration"] = fc["contact_end"] - fc["contact_start"]
        t = np.asarray(traj.t, float)
        inside = (t > fc["contact_start"]) & (t < fc["contact_end"])
        if inside.any():
            force = total_force(problem, traj)[inside]
            out["contact_force"] = float(np.median(force)) * float(area)
        if float(traj.t[-1]) > fc["contact_end"]:
            ones = np.ones(problem.M.shape[0])
            m = problem.M @ ones
            out["rebound_velocity"] = float(np.asarray(traj.V[-1]) @ m) / float(ones @ m)
    return out


def published_errors(published: dict[str, Published], mine: dict[str, float]
                     ) -> dict[str, float]:
    """err_published_<q> = |run / published - 1| for every published q the run has."""
    return {f"err_published_{q}": abs(mine[q] / p.value - 1.0)
            for q, p in published.items() if q in mine and p.value != 0.0}


__all__ = ["Published", "bar_observables", "published_errors"]
