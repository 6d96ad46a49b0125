"""Error norms against a reference solution, energy drift, penetration.

Space norms use scikit-fem's Gauss quadrature on each element (4 points): the P1
solution and the exact fields are evaluated at the quadrature points of every sample
time at once (vectorised, in blocks of samples x elements to bound memory). Time norms over the
sample times: L_inf is the max, L2(0,T) the trapezoidal rule. Every error is relative:
divided by the same norm of the exact solution (GetFEM's dynamic 1D contact test).
"""

from __future__ import annotations

import numpy as np
from skfem import Basis, ElementLineP1, MeshLine

from bench.plugin import Exact, Semidiscrete, Trajectory

ERROR_COLUMNS = (
    "err_u_linf_l2", "err_u_linf_h1", "err_v_linf_l2",
    "err_u_l2_l2", "err_u_l2_h1", "err_v_l2_l2", "err_stress_l2",
)
#: which reference quantity each error column needs
NEEDS = {
    "err_u_linf_l2": "u", "err_u_linf_h1": "u", "err_u_l2_l2": "u", "err_u_l2_h1": "u",
    "err_v_linf_l2": "v", "err_v_l2_l2": "v", "err_stress_l2": "stress",
}
_CHUNK_POINTS = 250_000  # quadrature values per field held at once (2 MB)
_QUAD_ORDER = 7  # 4 Gauss points per element


def _nodal(semi: Semidiscrete, A: np.ndarray, lo: int, hi: int, fixed: float) -> np.ndarray:
    """Columns lo..hi-1 of the nodal samples A, the clamped node (if any) filled in."""
    if hi <= semi.nfree:
        return A[:, lo:hi]
    out = np.empty((A.shape[0], hi - lo))
    out[:, : semi.nfree - lo] = A[:, lo:]
    out[:, semi.nfree - lo :] = fixed
    return out


def _space_norms(semi: Semidiscrete, traj: Trajectory, exact: Exact, need_v: bool) -> dict:
    """Squared space norms per sample, accumulated over blocks of elements x samples.

    Each element block gets its own scikit-fem basis (a MeshLine of those nodes), so
    memory is bounded by the block size, not by the mesh.
    """
    nel = semi.x.size - 1
    K = traj.t.size
    out = {k: np.zeros(K) for k in ("eu", "nu", "eux", "nux", "ev", "nv")}
    u_fixed = semi.u_fixed if semi.u_fixed is not None else 0.0
    nq = 4
    ec = min(nel, max(1, _CHUNK_POINTS // nq))
    step = max(1, _CHUNK_POINTS // (ec * nq))
    for e0 in range(0, nel, ec):
        e1 = min(nel, e0 + ec)
        basis = Basis(MeshLine(semi.x[e0 : e1 + 1]), ElementLineP1(), intorder=_QUAD_ORDER)
        Xe = basis.global_coordinates().value[0]  # (elements, nq)
        we = basis.dx
        d0, d1 = basis.element_dofs  # local node numbers of the block
        p0, p1 = (basis.basis[j][0].value for j in range(2))
        g0, g1 = (basis.basis[j][0].grad[0] for j in range(2))
        Ublk = _nodal(semi, traj.U, e0, e1 + 1, u_fixed)
        Vblk = _nodal(semi, traj.V, e0, e1 + 1, 0.0) if need_v else None
        for a in range(0, K, step):
            b = min(K, a + step)
            t = traj.t[a:b, None, None]
            Ua, Ub = Ublk[a:b, d0][:, :, None], Ublk[a:b, d1][:, :, None]
            uh = Ua * p0 + Ub * p1
            uxh = Ua * g0 + Ub * g1
            u = exact.u(Xe, t)
            ux = exact.ux(Xe, t)
            out["eu"][a:b] += np.sum(we * (uh - u) ** 2, axis=(1, 2))
            out["nu"][a:b] += np.sum(we * u**2, axis=(1, 2))
            out["eux"][a:b] += np.sum(we * (uxh - ux) ** 2, axis=(1, 2))
            out["nux"][a:b] += np.sum(we * ux**2, axis=(1, 2))
            if need_v:
                vh = Vblk[a:b, d0][:, :, None] * p0 + Vblk[a:b, d1][:, :, None] * p1
                v = exact.ut(Xe, t)
                out["ev"][a:b] += np.sum(we * (vh - v) ** 2, axis=(1, 2))
                out["nv"][a:b] += np.sum(we * v**2, axis=(1, 2))
    return out


def _rel_linf(err2: np.ndarray, norm2: np.ndarray) -> float:
    den = np.sqrt(norm2.max())
    return float(np.sqrt(err2.max()) / den) if den > 0 else float("nan")


def _rel_l2(t: np.ndarray, err2: np.ndarray, norm2: np.ndarray) -> float:
    if t.size < 2:
        return float("nan")
    den = np.sqrt(np.trapezoid(norm2, t))
    return float(np.sqrt(np.trapezoid(err2, t)) / den) if den > 0 else float("nan")


def error_metrics(semi: Semidiscrete, traj: Trajectory, exact: Exact,
                  provides: frozenset[str]) -> dict[str, float | None]:
    """The relative error columns that the reference provides (None for the others)."""
    row: dict[str, float | None] = dict.fromkeys(ERROR_COLUMNS)
    t = traj.t
    if "u" in provides:
        n = _space_norms(semi, traj, exact, need_v="v" in provides)
        h1e, h1n = n["eu"] + n["eux"], n["nu"] + n["nux"]
        row["err_u_linf_l2"] = _rel_linf(n["eu"], n["nu"])
        row["err_u_linf_h1"] = _rel_linf(h1e, h1n)
        row["err_u_l2_l2"] = _rel_l2(t, n["eu"], n["nu"])
        row["err_u_l2_h1"] = _rel_l2(t, h1e, h1n)
        if "v" in provides:
            row["err_v_linf_l2"] = _rel_linf(n["ev"], n["nv"])
            row["err_v_l2_l2"] = _rel_l2(t, n["ev"], n["nv"])
    if "stress" in provides:
        s = np.asarray(exact.stress(t), float)
        row["err_stress_l2"] = _rel_l2(t, (traj.stress - s) ** 2, s**2)
    return row


def energy_metrics(traj: Trajectory) -> dict[str, float]:
    E = traj.energy
    E0 = float(E[0])
    scale = abs(E0) if E0 != 0 else 1.0
    return {
        "energy_initial": E0,
        "energy_final": float(E[-1]),
        "energy_drift_max": float(np.max(np.abs(E - E0)) / scale),
    }


def penetration(traj: Trajectory) -> float:
    """Largest penetration max(-u(0, t_n)) over every step, 0 if none."""
    return float(max(0.0, -traj.min_contact_u))
