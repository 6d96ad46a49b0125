"""Converged references of the impact scenes: mesh-independent observables of a sparse
run, their Richardson extrapolation over a refinement sequence, and the stored artefact.

A body scene without a closed form after its impact (the disc drop) gets its reference
from a refinement sequence at a fixed CFL (`benchmarks/converged_reference.py` runs it
and writes results/references/<scene>.json and .md). What is compared is what does not
depend on the mesh (`observables`):

* contact_start, contact_end, contact_duration: the first contact (a positive total
  contact force), with the kernel's per-step statistics where the trajectory has them,
  else from the samples, its start and end interpolated within the step that brackets
  each switch where the free motion's smallest gap crosses zero (as the harness's
  first-contact columns: `contact_bench.core.contact_stats`);
* peak_force, contact_impulse: the largest total contact force (the resultant, not per
  unit area: the contact zone's measure depends on the mesh) over the first contact, and
  its integral over it;
* rebound_velocity: the vertical velocity of the centre of mass at take-off,
  v(t_last) - (F_z / m) (t_last - contact_end), exact in free flight after the contact;
* vibration_energy: the energy left in the body's deformation and relative motion at the
  last sample, 1/2 U.K.U + 1/2 V.M.V less the vertical translation's kinetic energy
  (its M-weighted momentum squared over twice its mass), relative to the initial energy;
* force_history: the total contact force at fixed times (linear interpolation of the
  samples).

`richardson`: from the values at h, h/2, h/4 the observed order p = log2((q1 - q2) / (q2 -
q3)) and the extrapolated q3 + (q3 - q2) / (2^p - 1). With four levels the reference's
error is estimated as the difference between the extrapolations of the last two triples
(and at least the last correction over 2^p, so a lucky agreement does not pass for
zero error); with three, as the correction itself. An order outside [0.5, 4] (a
non-monotone sequence) is not trusted: the finest value is kept and its error is the
last difference. The force history is extrapolated as a whole, with the order of its
l2 differences.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from contact_bench.core.contact_stats import sampled_switches

#: the artefacts' folder: results/references in the repository
REFERENCES = Path(__file__).resolve().parents[2] / "results" / "references"
#: the scalar observables, in the artefact's order
SCALARS = ("contact_start", "contact_end", "contact_duration", "peak_force",
           "contact_impulse", "rebound_velocity", "vibration_energy")
#: the error columns err_<q> a scene gets against its stored reference
QUANTITIES = (*SCALARS, "force_history")
#: an observed order outside this range is not used for extrapolation
ORDER_RANGE = (0.5, 4.0)


def total_force(problem: Any, traj: Any) -> np.ndarray:
    """The total contact force of each sample (the resultant on the contact zone)."""
    return -np.asarray(traj.stress, float) * float(np.sum(problem.contact.weights))


def first_contact(problem: Any, traj: Any, dt: float) -> dict[str, float]:
    """start, end, peak_force, contact_impulse of the first contact (module docstring);
    {} without contact; no end or impulse when it lasts to the run's end."""
    extra = getattr(traj, "extra", None) or {}
    start = extra.get("first_contact_start")
    if start is not None and "first_contact_peak" in extra:
        if not math.isfinite(start):
            return {}
        out = {"contact_start": float(start),
               "peak_force": float(extra["first_contact_peak"])}
        end = extra.get("first_contact_end")
        if end is not None and math.isfinite(end):
            out["contact_end"] = float(end)
            if extra.get("first_contact_impulse") is not None:
                out["contact_impulse"] = float(extra["first_contact_impulse"])
        return out
    t = np.asarray(traj.t, float)
    force = total_force(problem, traj)
    switches = sampled_switches(t, force > 0.0, np.asarray(traj.contact_u, float))
    if switches is None:
        return {}
    a, b, start, end = switches
    out = {"contact_start": start, "peak_force": float(np.max(force[a:b]))}
    if end is not None:
        out["contact_end"] = end
        lo = max(a - 1, 0)
        out["contact_impulse"] = float(np.sum(0.5 * (force[lo:b] + force[lo + 1:b + 1])
                                              * np.diff(t[lo:b + 1])))
    return out


def observables(problem: Any, traj: Any, dt: float, times: np.ndarray | None = None
                ) -> dict[str, Any]:
    """The run's observables (module docstring); `times`: the force history's grid
    (those inside the run's samples)."""
    out: dict[str, Any] = dict(first_contact(problem, traj, dt))
    t = np.asarray(traj.t, float)
    force = total_force(problem, traj)
    if "contact_end" in out:
        out["contact_duration"] = out["contact_end"] - out["contact_start"]
        after = t > out["contact_end"]
        vertical = getattr(problem, "vertical", None)
        mass = getattr(problem, "body_mass", None)
        if after.any() and not np.any(force[after] > 0.0) and vertical is not None and mass:
            U, V = np.asarray(traj.U[-1], float), np.asarray(traj.V[-1], float)
            m_vertical = problem.M @ vertical
            pz = float(V @ m_vertical)  # the vertical momentum
            accel = float(problem.F @ vertical) / float(mass)
            out["rebound_velocity"] = pz / float(mass) - accel * (float(t[-1])
                                                                  - out["contact_end"])
            # the rigid part: the vertical translation only (the frictionless plane and
            # the vertical load keep every horizontal momentum at zero; an axisymmetric
            # meridian has no radial translation)
            kin = 0.5 * float(V @ (problem.M @ V)) - 0.5 * pz * pz / float(
                vertical @ m_vertical)
            E0 = float(traj.energy[0])
            out["vibration_energy"] = (kin + 0.5 * float(U @ (problem.K @ U))) / E0
    if times is not None:
        times = np.asarray(times, float)
        inside = times <= t[-1] * (1 + 1e-12)
        out["force_history"] = np.interp(times[inside], t, force)
    return out


def richardson(values: list[float]) -> tuple[float, float, float | None]:
    """(reference, its estimated error, observed order or None) from values at h, h/2,
    h/4 (, h/8) (module docstring)."""
    q = [float(v) for v in values]
    if len(q) < 3:
        raise ValueError(f"{len(q)} levels: Richardson needs at least 3")

    def triple(a: float, b: float, c: float) -> tuple[float, float | None]:
        d1, d2 = a - b, b - c
        if d2 == 0.0:
            return c, None
        if d1 == 0.0 or d1 / d2 <= 0.0:
            return c, None
        p = math.log2(d1 / d2)
        if not ORDER_RANGE[0] <= p <= ORDER_RANGE[1]:
            return c, None
        return c + (c - b) / (2.0**p - 1.0), p

    ext, p = triple(*q[-3:])
    if p is None:
        return q[-1], abs(q[-1] - q[-2]), None
    last = abs(ext - q[-1])
    if len(q) >= 4:
        prev, p_prev = triple(*q[-4:-1])
        err = max(abs(ext - prev), last / 2.0**p) if p_prev is not None else last
    else:
        err = last
    return ext, err, p


def richardson_history(histories: list[np.ndarray]) -> tuple[np.ndarray, float, float | None]:
    """The force history's reference, its estimated relative l2 error and order: the
    whole history extrapolated with the order of its l2 differences (as `richardson`)."""
    h = [np.asarray(x, float) for x in histories]
    n = min(x.size for x in h)
    h = [x[:n] for x in h]
    norm = float(np.linalg.norm(h[-1])) or 1.0

    def triple(a, b, c):
        d1, d2 = float(np.linalg.norm(a - b)), float(np.linalg.norm(b - c))
        if d2 == 0.0 or d1 == 0.0:
            return c, None
        p = math.log2(d1 / d2)
        if not ORDER_RANGE[0] <= p <= ORDER_RANGE[1]:
            return c, None
        return c + (c - b) / (2.0**p - 1.0), p

    ext, p = triple(*h[-3:])
    if p is None:
        return h[-1], float(np.linalg.norm(h[-1] - h[-2])) / norm, None
    last = float(np.linalg.norm(ext - h[-1])) / norm
    if len(h) >= 4:
        prev, p_prev = triple(*h[-4:-1])
        err = (max(float(np.linalg.norm(ext - prev)) / norm, last / 2.0**p)
               if p_prev is not None else last)
    else:
        err = last
    return ext, err, p


def load(name: str, folder: Path | None = None) -> dict[str, Any] | None:
    """The stored reference of scene `name` (results/references/<name>.json), or None."""
    path = (folder or REFERENCES) / f"{name}.json"
    if not path.is_file():
        return None
    return json.loads(path.read_text())


def drop_errors(case: Any, problem: Any, traj: Any, dt: float) -> dict[str, float]:
    """A dropped body's errors (the disc, the ball): err_free_fall, the largest vertical
    displacement error of any dof against `case.free_fall` over the samples before the
    impact (`case.impact_time` less 1.5 dt), relative to `case.lift`, read block by block
    (`sample_blocks`); and `stored_errors`."""
    from contact_bench.api.sparse import sample_blocks

    out: dict[str, float] = {}
    before = traj.t < case.impact_time - 1.5 * dt
    if before.any():
        vert = np.flatnonzero(problem.vertical > 0)
        fall = case.free_fall(traj.t)
        err = max(float(np.max(np.abs(traj.U[b][:, vert] - fall[b, None])))
                  for b in sample_blocks(int(np.count_nonzero(before)), vert.size))
        out["err_free_fall"] = err / float(case.lift)
    out.update(stored_errors(case, problem, traj, dt))
    return out


def stored_errors(case: Any, problem: Any, traj: Any, dt: float) -> dict[str, float]:
    """The columns of `errors` against the stored reference of the scene
    (`load(case.name)`) when it is this variant's (`case.spec`); {} otherwise."""
    stored = load(case.name)
    if stored is None or stored["case"] != case.spec:
        return {}
    return errors(stored, problem, traj, dt)


def errors(reference: dict[str, Any], problem: Any, traj: Any, dt: float
           ) -> dict[str, float]:
    """The columns err_<q> of a run against a stored reference: |run / ref - 1| for the
    scalars both have (err_contact_start none when the reference starts at t = 0), and
    err_force_history, the l2 error over the reference's grid times inside the run over
    the reference's l2 norm there."""
    times = np.asarray(reference["force_history"]["times"], float)
    mine = observables(problem, traj, dt, times)
    out: dict[str, float] = {}
    for q in SCALARS:
        ref = reference["scalars"].get(q)
        if ref is None or q not in mine or ref["value"] == 0.0:
            continue
        out[f"err_{q}"] = abs(mine[q] / ref["value"] - 1.0)
    fh = mine.get("force_history")
    if fh is not None and fh.size:
        ref_f = np.asarray(reference["force_history"]["force"], float)[:fh.size]
        norm = float(np.linalg.norm(ref_f))
        if norm > 0.0:
            out["err_force_history"] = float(np.linalg.norm(fh - ref_f)) / norm
    return out


def error_floor(case: Any, column: str, folder: Path | None = None) -> float | None:
    """The stored reference's own estimated error in the units of the error column
    `column` (err_<q>: relative, as `errors` computes it) for scene `case` (a Case), or
    None when the scene's variant has no stored reference or the column is not one of
    its quantities. A run's error below it is not resolved by the reference."""
    if not column.startswith("err_"):
        return None
    stored = load(case.name, folder)
    if stored is None or stored["case"] != case.spec:
        return None
    q = column[4:]
    if q == "force_history":
        return float(stored["force_history"]["error"])
    entry = stored["scalars"].get(q)
    if q not in SCALARS or entry is None or not entry["value"]:
        return None
    return float(abs(entry["error"] / entry["value"]))


__all__ = ["QUANTITIES", "REFERENCES", "SCALARS", "drop_errors", "error_floor", "errors",
           "first_contact", "load", "observables", "richardson", "richardson_history",
           "stored_errors", "total_force"]
