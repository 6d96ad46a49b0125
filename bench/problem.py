"""From a case and a mesh to the space-discrete problem a scheme integrates."""

from __future__ import annotations

import numpy as np

from bench.errors import BenchError
from bench.fem import MASSLESS_KINDS, assemble, mass_variant
from bench.plugin import Case, Semidiscrete


def discretise(case: Case, x: np.ndarray, mass_kind: str = "consistent") -> Semidiscrete:
    """Assemble with scikit-fem, pick the mass variant, eliminate a clamped far end.

    Gravity is a body acceleration: the load is F = -g M 1 with the scheme's own mass
    M, so a massless contact node feels no gravity and a rigid free fall is exact for
    every mass variant. Initial data are nodal interpolants of the case's u0 and v0.
    """
    asm = assemble(x, case.rho, case.E)
    M = mass_variant(asm, mass_kind)
    K = asm.K
    n_nodes = x.size
    U = np.asarray(case.u0(x), dtype=float) * np.ones(n_nodes)
    V = np.asarray(case.v0(x), dtype=float) * np.ones(n_nodes)
    if not (np.all(np.isfinite(U)) and np.all(np.isfinite(V))):
        raise BenchError(f"case {case.spec}: initial data are not finite")
    if U[0] < 0:
        raise BenchError(f"case {case.spec}: u0(0) = {U[0]:g} < 0 violates the constraint u(0) >= 0")
    F = -case.g * M.matvec(np.ones(n_nodes))
    if case.far_end == "clamped":
        m = n_nodes - 1
        uL = float(case.u_L)
        U[-1] = uL
        V[-1] = 0.0
        full_load = F.copy()
        F = F[:m].copy()
        F[m - 1] -= K.off[m - 1] * uL  # coupling with the clamped node
        # energy of the full vector minus the reduced expression
        offset = 0.5 * K.diag[m] * uL**2 - full_load[m] * uL
    elif case.far_end == "free":
        m = n_nodes
        uL = None
        offset = 0.0
    else:
        raise BenchError(f"case {case.spec}: far_end must be 'clamped' or 'free', got {case.far_end!r}")
    h0 = x[1] - x[0]
    E_contact = float(np.asarray(case.E(np.array([0.5 * h0]))).ravel()[0]) if callable(case.E) else float(case.E)
    xs = 0.5 * (x[1:] + x[:-1])
    Ex = np.asarray(case.E(xs)) if callable(case.E) else case.E
    rx = np.asarray(case.rho(xs)) if callable(case.rho) else case.rho
    c_max = float(np.max(np.sqrt(np.asarray(Ex, float) / np.asarray(rx, float))))
    return Semidiscrete(
        x=x, nfree=m, M=M.head(m), K=K.head(m), F=F, U0=U[:m].copy(), V0=V[:m].copy(),
        u_fixed=uL, energy_offset=float(offset), massless=mass_kind in MASSLESS_KINDS,
        E_contact=E_contact, c_max=c_max,
    )
