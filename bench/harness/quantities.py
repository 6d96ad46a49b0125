"""The first-contact error columns of a run against its exact 1D reference.

For every scene whose reference is exact and provides the contact stress
(`Case.reference_quantities`), the reference's first contact (start, end, duration,
peak force, impulse: `contact_bench.exact.contacts.first_contact`, bracketed and
integrated on the exact sigma(0, t)) against the run's own, as relative errors
|run / reference - 1| in the columns err_contact_start, err_contact_end,
err_contact_duration, err_peak_force and err_contact_impulse.

The run's own first contact (`run_first_contact`), with "in contact" meaning a
positive contact force, as in the reference, its start and end interpolated within the
step (or sample spacing) that brackets each switch, where the free motion's smallest gap
crosses zero (`contact_bench.core.contact_stats`: the secant of the two free steps next
to the switch; the midpoint without them):
* per-step statistics of the kernel where it keeps them (the sparse kernels and the
  recorder: `Trajectory.extra` first_contact_start / first_contact_end, interpolated from
  every step's smallest gap, first_contact_peak, the largest total force over the steps
  of that contact, and first_contact_impulse, the impulse up to its end with the velocity
  update's weights); peak and impulse are divided by the contact area (per unit section,
  as the 1D reference's -sigma(0, t); the embedded bar's section has measure 1);
* else the samples (the 1D kernels): the force -stress of each sample, start and end
  by the same rule on the samples' smallest gaps (contact_u; a stride above 1 spaces the
  free samples it reads by stride dt), the peak over the samples of the contact (a stride
  can miss it), the impulse by the trapezoid rule over the contact's samples and the one
  on each side (the velocity update of Newmark with gamma = 1/2 at stride 1).
Beside them, err_impulse_over_reference_contact: the impulse the run transfers over the
reference's first contact interval [start, end] (whatever its own contacts there: a
first contact that breaks into bounces after a few steps ends early, and its
err_contact_impulse measures the first bounce only), the integral of its force -stress
by the trapezoid rule over its samples, linear between them and at the interval's ends
(`interval_impulse`; a stride above 1 reads the force between samples linearly), against
the reference's impulse. None when the reference's contact does not end, or ends after
the run's last sample.
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
from contact_bench.api.plugin import (
    CONTACT_QUANTITIES,
    INTERVAL_IMPULSE,
    Case,
    Exact,
    Trajectory,
)
from contact_bench.core.contact_stats import sampled_switches
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
        return FirstContact(start=float(start),
                            end=float(end) if ended else None,
                            peak_force=float(extra["first_contact_peak"]) / area,
                            impulse=float(impulse) / area if ended and impulse is not None
                            else None)
    t = np.asarray(traj.t, float)
    force = -np.asarray(traj.stress, float)
    switches = sampled_switches(t, force > 0.0, np.asarray(traj.contact_u, float))
    if switches is None:
        return None
    a, b, start, end = switches
    impulse = None
    if b < t.size:
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


def interval_impulse(traj: Trajectory, start: float, end: float) -> float | None:
    """The integral of the run's force -stress over [start, end] by the trapezoid rule on
    its samples and the interval's ends (the force linear between samples); None when
    the interval is not inside the run's samples."""
    t = np.asarray(traj.t, float)
    if t.size < 2 or start < t[0] or end > t[-1] or end <= start:
        return None
    force = -np.asarray(traj.stress, float)
    inside = (t > start) & (t < end)
    tt = np.concatenate(([start], t[inside], [end]))
    ff = np.interp(tt, t, force)
    return float(np.sum(0.5 * (ff[1:] + ff[:-1]) * np.diff(tt)))


def first_contact_errors(case: Case, exact: Exact, T: float, traj: Trajectory, dt: float,
                         problem: Any = None) -> dict[str, float]:
    """The row's first-contact error columns of a run of `case` (against `exact` on
    [0, T]); none unless the case declares them (`Case.reference_quantities`)."""
    if not set(CONTACT_QUANTITIES) & set(case.reference_quantities):
        return {}
    contact = getattr(problem, "contact", None)
    area = float(np.sum(contact.weights)) if contact is not None else 1.0
    ref = reference_first_contact(exact, T)
    out = contact_quantity_errors(ref, run_first_contact(traj, dt, area))
    if ref is not None and ref.end is not None and ref.impulse:
        moved = interval_impulse(traj, ref.start, ref.end)
        if moved is not None:
            out[f"err_{INTERVAL_IMPULSE}"] = abs(moved / ref.impulse - 1.0)
    return out


__all__ = ["contact_quantity_errors", "first_contact_errors", "interval_impulse",
           "reference_first_contact", "run_first_contact"]
