"""The first-contact error columns of a run against its exact 1D reference.

For every scene whose reference is exact and provides the contact stress
(`Case.reference_quantities`), the reference's first contact (start, end, duration,
peak force, impulse: `contact_bench.exact.contacts.first_contact`, bracketed and
integrated on the exact sigma(0, t)) against the run's own, as relative errors
|run / reference - 1| in the columns err_contact_start, err_contact_end,
err_contact_duration, err_peak_force and err_contact_impulse.

The run's own first contact (`run_first_contact`), with "in contact" meaning a
positive contact force, as in the reference:
* per-step statistics of the kernel where it keeps them (the sparse kernels:
  `Trajectory.extra` first_contact_start / first_contact_end, the times of the first
  step with a force and of the first step after it without, first_contact_peak, the
  largest total force over the steps of that contact, and first_contact_impulse, the
  impulse up to its end with the velocity update's weights): the switch is put half a
  step before each (the midpoint between the last step on one side and the first on the
  other), so start and end are within dt / 2 of the scheme's own switch; peak and
  impulse are divided by the contact area (per unit section, as the 1D reference's
  -sigma(0, t); the embedded bar's section has measure 1);
* else the samples (the 1D kernels): the force -stress of each sample, start and end
  at the midpoints between the samples around each switch (within half a sample
  spacing: a stride above 1 blurs them by up to stride dt / 2), the peak over the
  samples of the contact (a stride can miss it), the impulse by the trapezoid rule
  over the contact's samples and the one on each side (the velocity update of
  Newmark with gamma = 1/2 at stride 1).
A run without contact has err_peak_force 1 and no time columns; a run whose first
contact lasts to its end has no end or duration column, and neither has a reference
whose contact lasts to T. A reference start at t = 0 gives no err_contact_start (no
relative error of 0).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from contact_bench.api.kept import Kept
from contact_bench.api.plugin import CONTACT_QUANTITIES, Case, Exact, Trajectory
from contact_bench.exact.contacts import FirstContact, first_contact

KEEP = 8
#: the last few references' first contacts, keyed on the reference object and T (each
#: entry holds its reference, so that the id in its key stays that object's)
FIRST_CONTACTS: Kept[tuple[Exact, FirstContact | None]] = Kept(
    "first contacts of references", max_items=KEEP)


def reference_first_contact(exact: Exact, T: float) -> FirstContact | None:
    """`first_contact(exact.stress, T)`, kept for the next runs on the same reference."""
    return FIRST_CONTACTS.get_or_build(
        (id(exact), float(T)), lambda: (exact, first_contact(exact.stress, T)))[1]


def run_first_contact(traj: Trajectory, dt: float, area: float = 1.0
                      ) -> FirstContact | None:
    """The run's first contact (module docstring): from the kernel's per-step
    statistics when `traj.extra` has them, else from the samples; None without contact.
    `area`: the contact area the total force is divided by (sparse problems)."""
    extra = traj.extra or {}
    start = extra.get("first_contact_start")
    if start is not None and "first_contact_peak" in extra:
        if not math.isfinite(start):
            return None
        end = extra.get("first_contact_end")
        ended = end is not None and math.isfinite(end)
        impulse = extra.get("first_contact_impulse")
        return FirstContact(start=float(start) - 0.5 * dt,
                            end=float(end) - 0.5 * dt if ended else None,
                            peak_force=float(extra["first_contact_peak"]) / area,
                            impulse=float(impulse) / area if ended and impulse is not None
                            else None)
    t = np.asarray(traj.t, float)
    force = -np.asarray(traj.stress, float)
    on = force > 0.0
    if not on.any():
        return None
    a = int(np.argmax(on))
    off = np.flatnonzero(~on[a:])
    b = a + int(off[0]) if off.size else t.size
    start = float(t[0]) if a == 0 else 0.5 * float(t[a - 1] + t[a])
    end = impulse = None
    if b < t.size:
        end = 0.5 * float(t[b - 1] + t[b])
        lo = max(a - 1, 0)
        impulse = float(np.sum(0.5 * (force[lo:b] + force[lo + 1:b + 1]) * np.diff(t[lo:b + 1])))
    return FirstContact(start=start, end=end, peak_force=float(np.max(force[a:b])),
                        impulse=impulse)


def contact_quantity_errors(reference: FirstContact | None, run: FirstContact | None
                            ) -> dict[str, float]:
    """The columns err_<q> for the quantities q the reference has (module docstring)."""
    if reference is None:
        return {}
    ref = reference.quantities()
    if ref.get("contact_start") == 0.0:
        del ref["contact_start"]
    if run is None:
        return {"err_peak_force": 1.0}
    mine = run.quantities()
    return {f"err_{q}": abs(mine[q] / ref[q] - 1.0) for q in CONTACT_QUANTITIES
            if q in ref and q in mine}


def first_contact_errors(case: Case, exact: Exact, T: float, traj: Trajectory, dt: float,
                         problem: Any = None) -> dict[str, float]:
    """The row's first-contact error columns of a run of `case` (against `exact` on
    [0, T]); none unless the case declares them (`Case.reference_quantities`)."""
    if not set(CONTACT_QUANTITIES) & set(case.reference_quantities):
        return {}
    contact = getattr(problem, "contact", None)
    area = float(np.sum(contact.weights)) if contact is not None else 1.0
    return contact_quantity_errors(reference_first_contact(exact, T),
                                   run_first_contact(traj, dt, area))


__all__ = ["contact_quantity_errors", "first_contact_errors", "reference_first_contact",
           "run_first_contact"]
