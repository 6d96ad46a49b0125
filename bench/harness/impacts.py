"""Impact by impact: the contact episodes of a sparse run and what each leaves behind.

An impact is a maximal run of samples with a positive total contact force (the
trajectory's stress times the contact area). For each: its start and end sample times,
the energy at the first sample after it (relative to E0) and the rebound ratio, the
vertical velocity of the centre of mass after it over the one before it (minus sign:
a bounce that keeps the speed has ratio 1). The centre-of-mass velocity needs the
problem's vertical translation (`SparseProblem.vertical`, the dofs moved by a unit vertical
translation) and mass (`SparseProblem.body_mass`); a problem without them has no impact table.
The times are those of the samples: a stride above 1 blurs them by up to a stride.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pandas loads when a run has impacts to tabulate, not with the harness
    import pandas as pd

IMPACT_COLUMNS = ("impact", "start", "end", "energy_after", "rebound_ratio")


def impact_table(problem: Any, traj: Any) -> pd.DataFrame | None:
    """One row per impact (module docstring), or None without a vertical translation."""
    vertical = getattr(problem, "vertical", None)
    mass = getattr(problem, "body_mass", None)
    if vertical is None or not mass or traj.stress.size < 2:
        return None
    import pandas as pd

    force = -np.asarray(traj.stress) * float(np.sum(problem.contact.weights))
    on = np.r_[False, force > 0.0, False]
    edges = np.flatnonzero(np.diff(on.astype(np.int8)))
    starts, ends = edges[::2], edges[1::2] - 1  # sample indices, inclusive
    vz = (traj.V @ (problem.M @ vertical)) / float(mass)
    E0 = traj.energy[0]
    rows = []
    for k, (a, b) in enumerate(zip(starts, ends, strict=True), start=1):
        after = min(b + 1, traj.t.size - 1)
        before = max(a - 1, 0)
        ratio = -vz[after] / vz[before] if vz[before] != 0.0 and b + 1 < traj.t.size else np.nan
        rows.append((k, float(traj.t[a]), float(traj.t[b]),
                     float(traj.energy[after] / E0) if b + 1 < traj.t.size else np.nan,
                     float(ratio)))
    return pd.DataFrame(rows, columns=list(IMPACT_COLUMNS))


def impulse_residual(problem: Any, traj: Any, dt: float) -> float | None:
    """The impulse balance: rigid vertical translations lie in ker K, so the change of
    vertical momentum p = vertical.M.V equals the load's vertical resultant times t plus
    the contact impulse J. Relative to the total contact impulse J_N; None without a
    vertical translation or contact.

    J is the kernel's own when the trajectory carries it: the impulse the scheme applies
    in its velocity (momentum) update, accumulated step by step with that update's
    weights (`contact_bench.kernels.sparse`). Recorded at every sample
    (`Trajectory.extra["impulse"]`): the largest residual over the samples; only the
    run's total (`extra["contact_impulse"]`): the residual at the last sample. A
    trajectory without it: at every step's samples, J integrated from the sampled forces
    by the trapezoid rule (exact only for a velocity update that is the trapezoid, e.g.
    Newmark with gamma = 1/2), otherwise None. The same measure at any stride when the
    kernel records J at every sample."""
    vertical = getattr(problem, "vertical", None)
    t = np.asarray(traj.t)
    if vertical is None or t.size < 2:
        return None
    p = traj.V @ (problem.M @ vertical)
    load = float(problem.F @ vertical)
    extra = getattr(traj, "extra", None) or {}
    impulse = extra.get("impulse")
    if impulse is not None and np.shape(impulse) == t.shape:
        impulse = np.asarray(impulse, float)
    elif extra.get("contact_impulse") is not None:  # the total only: the last sample
        J = float(extra["contact_impulse"])
        if not J > 0.0:
            return None
        return float(abs(p[-1] - p[0] - load * (t[-1] - t[0]) - J) / J)
    elif np.allclose(np.diff(t), dt, rtol=1e-9, atol=0):  # every step: the trapezoid
        force = -np.asarray(traj.stress) * float(np.sum(problem.contact.weights))
        impulse = dt * (np.cumsum(force) - 0.5 * force - 0.5 * force[0])
    else:
        return None
    if not impulse[-1] > 0.0:
        return None
    residual = p - p[0] - load * (t - t[0]) - (impulse - impulse[0])
    return float(np.max(np.abs(residual)) / impulse[-1])


def tangent_translations(problem: Any) -> np.ndarray | None:
    """(n_t, n): the rigid translations along the contact's tangents, one per tangent
    index k (`ContactSet.tangents`: row j n_t + k is point j's k-th unit tangent), read
    from point 0's rows on a body whose free dofs are the nodes' components in turn
    (`SparseProblem.dim` a node); None without tangent rows or when a translation so
    built is not rigid (K tau not zero: a curved obstacle, eliminated dofs)."""
    contact = problem.contact
    T = getattr(contact, "tangents", None)
    dim = getattr(problem, "dim", None)
    if T is None or not dim or contact.size == 0 or problem.nfree % int(dim):
        return None
    T = T.tocsr()
    nt = T.shape[0] // contact.size
    out = np.zeros((nt, problem.nfree))
    for k in range(nt):
        d = np.zeros(int(dim))
        row = T[k]
        d[row.indices % int(dim)] = row.data
        out[k] = np.tile(d, problem.nfree // int(dim))
    scale = abs(problem.K).max() * np.abs(out).max()
    if np.abs(problem.K @ out.T).max() > 1e-9 * scale:
        return None
    return out


def tangential_impulse_residual(problem: Any, traj: Any) -> float | None:
    """The tangential impulse balance, as `impulse_residual` along each tangent: the
    change of momentum tau_k.M.V along the rigid translation tau_k of tangent k
    (`tangent_translations`) equals the load's resultant along it times t plus the
    kernel's tangential impulse J_k (`Trajectory.extra["tangential_impulse"]`, recorded
    at every sample). The largest residual over the samples and tangents, relative to the
    normal impulse J_N at the last sample (`extra["impulse"]`); None without them."""
    extra = getattr(traj, "extra", None) or {}
    J = extra.get("tangential_impulse")
    impulse = extra.get("impulse")
    tau = tangent_translations(problem)
    t = np.asarray(traj.t)
    if J is None or impulse is None or tau is None or t.size < 2 or traj.V.shape[1] == 0:
        return None
    J = np.asarray(J, float)
    JN = float(np.asarray(impulse)[-1] - np.asarray(impulse)[0])
    if not JN > 0.0:
        return None
    p = traj.V @ (problem.M @ tau.T)  # (samples, n_t)
    load = tau @ problem.F
    residual = p - p[0] - np.outer(t - t[0], load) - (J - J[0])
    return float(np.max(np.abs(residual)) / JN)


def impact_metrics(problem: Any, traj: Any, dt: float | None = None) -> dict[str, float]:
    """The row's impact columns: number of impacts, the first impact's rebound ratio, the
    energy after it minus 1 (relative to E0), and the impulse residual
    (`impulse_residual`: from the kernel's accumulated impulse when the trajectory
    carries it, else from the sampled forces at every step)."""
    table = impact_table(problem, traj)
    if table is None:
        return {}
    out = {"impacts": float(len(table))}
    res = impulse_residual(problem, traj, dt) if dt else None
    if res is not None:
        out["impulse_residual"] = res
    if len(table):
        out["rebound_ratio"] = float(table["rebound_ratio"].iloc[0])
        out["energy_after_first_impact"] = float(table["energy_after"].iloc[0] - 1.0)
    return out


__all__ = ["IMPACT_COLUMNS", "impact_metrics", "impact_table", "impulse_residual",
           "tangent_translations", "tangential_impulse_residual"]
