"""GetFEM's dynamic 1D contact demo, Nitsche branch, replicated line by line in scipy.

GetFEM's `interface/tests/python/demo_dynamic_contact_1D.py` (version = 3, implicit
branch) gives NaN for theta = 1 with a redistributed or singular mass. This script
transcribes that branch (the same matrices, Dirichlet rows, M2, tests and updates;
scipy.sparse, NX = 20, dt = 0.002, T = 12, gamma0 = 5, beta = 1/4) and runs it as is and
with the two missing terms added ("fixed": -K_N1 U0 in the initial acceleration, -K_N1 U1
in every acceleration), and compares the fixed replay with the project's own `nitsche`
scheme. The explanation and the output are in docs/getfem-comparison.md.

    python benchmarks/getfem_nitsche_demo.py
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve


def _outer_at_contact(a: np.ndarray, b: np.ndarray, n: int) -> sp.csc_matrix:
    """a b^T as a sparse matrix, for vectors supported on nodes 0 and 1."""
    rows, cols = np.meshgrid([0, 1], [0, 1], indexing="ij")
    return sp.csc_matrix((np.outer(a[:2], b[:2]).ravel(), (rows.ravel(), cols.ravel())),
                         shape=(n, n))


def replicate_getfem_demo(theta: float, mass: int, fixed: bool, NX: int = 20, T: float = 12.0,
                          dt: float = 0.002, gamma0: float = 5.0,
                          beta: float = 0.25, gamma: float = 0.5) -> np.ndarray:
    """GetFEM demo_dynamic_contact_1D.py, version 3, implicit branch, line by line.

    mass: 0 standard, 1 redistributed (M11 += M00 + M01), 2 singular (M11 = 7h/12), as
    the demo's mass_matrix_type, in scipy.sparse (no dense n x n). fixed=True adds the
    missing -K_N1 U0 to MA0 and -K_N1 U1 to MA1. Returns the demo's sampled energy at
    every step (E(0) without the Nitsche term, as the demo samples it).
    """
    h, n = 1.0 / NX, NX + 1
    g = gamma0 / h
    x = np.linspace(0.0, 1.0, n)
    ends = np.r_[0.5, np.ones(n - 2), 0.5]
    M = sp.diags([np.full(n - 1, h / 6), 2 * h / 3 * ends, np.full(n - 1, h / 6)],
                 [-1, 0, 1], format="lil")
    K = sp.diags([np.full(n - 1, -1 / h), 2 / h * ends, np.full(n - 1, -1 / h)],
                 [-1, 0, 1], format="lil")
    K[n - 1, n - 2] = M[n - 1, n - 2] = 0.0  # the demo's Dirichlet rows
    M[n - 1, n - 1] = K[n - 1, n - 1] = 1.0
    if mass == 1:
        M[1, 1] += M[0, 0] + M[1, 0]
        M[0, 0] = M[0, 1] = M[1, 0] = 0.0
    elif mass == 2:
        M[1, 1] = 7 * h / 12
        M[0, 0] = M[0, 1] = M[1, 0] = 0.0
    M2 = M.copy()
    if mass:
        M2[0, 0] = 1.0
    M, K, M2 = M.tocsc(), K.tocsc(), M2.tocsc()
    sx = np.zeros(n)  # Grad of the basis functions at x = 0
    sx[:2] = -1 / h, 1 / h
    e0 = np.zeros(n)
    e0[0] = 1.0
    KN1 = -(theta / g) * _outer_at_contact(sx, sx, n)
    KN2 = (1 / g) * _outer_at_contact(g * e0 + theta * sx, g * e0 + sx, n)
    KN = (M + dt * dt * beta * (K + KN1)).tocsc()
    KNC = (KN + dt * dt * beta * KN2).tocsc()
    U0 = 0.5 - 0.5 * x
    V0 = np.zeros(n)
    MV0 = M @ V0
    MA0 = -K @ U0
    if fixed:  # the demo's initial acceleration misses the Nitsche term as well
        MA0 -= KN1 @ U0
    if mass:
        MA0[0] = 0.0
    s0 = ux = 0.0
    NT = int(round(T / dt)) + 1
    energy = np.zeros(NT)
    with np.errstate(all="ignore"):
        for nit in range(NT):
            if nit > 0:
                B = M @ U0 + dt * MV0 + (dt * dt * (1 - 2 * beta) / 2) * MA0
                U1 = spsolve(KN, B)
                ux = sx @ U1
                if g * U1[0] + ux < 0:
                    U1 = spsolve(KNC, B)
                    ux = sx @ U1
                Fc1 = (KN @ U1 - B) / (beta * dt * dt)
                s1 = min(0.0, g * U1[0] + ux)
                MA1 = Fc1 - K @ U1
                if fixed:
                    MA1 -= KN1 @ U1
                MV1 = MV0 + dt * ((1 - gamma) * MA0 + gamma * MA1)
                V1 = spsolve(M2, MV1)
                V1[n - 1] = 0.0
                if mass:
                    V1[0] = (U1[0] - U0[0]) / dt
                MA0 = MA1
                U0, V0, MV0, s0 = U1, V1, MV1, s1
            energy[nit] = (0.5 * (V0 @ M @ V0 + U0 @ K @ U0)
                           + 0.5 * theta * (h / gamma0) * (s0 * s0 - ux * ux))
    return energy


#: the demo's mass_matrix_type and this project's mass kind of the same matrix
DEMO_MASSES = {0: "consistent", 1: "getfem", 2: "singular"}


def own_energy(theta: int, mass: int, NX: int = 20, T: float = 12.0,
               dt: float = 0.002) -> np.ndarray:
    """This module's scheme on the demo's data (clamped_bar, NX elements): E_theta at
    every step, to compare with `replicate_getfem_demo`."""
    from contact_bench.api.fem import mesh_nodes
    from contact_bench.api.problem import discretise
    from contact_bench.api.registry import make_case, make_scheme

    semi = discretise(make_case("clamped_bar"), mesh_nodes(1.0, NX), DEMO_MASSES[mass])
    scheme = make_scheme(f"nitsche[theta={theta},mass={DEMO_MASSES[mass]}]")
    return scheme.integrate(semi, dt, int(round(T / dt)), 1).energy


def _main() -> None:
    runs = [(0, 1), (0, -1), (1, -1), (1, 0), (1, 1), (2, 1)]
    for mass, theta in runs:
        line = f"mass={DEMO_MASSES[mass]:10s} theta={theta:+d}: "
        E = replicate_getfem_demo(float(theta), mass, False)
        bad = np.flatnonzero(~np.isfinite(E))
        first = f"{bad[0] * 0.002:.4g}" if bad.size else "None"
        line += f"demo: nonfinite={first:5s} E(T)={E[-1]:<9.4g} "
        Ef = replicate_getfem_demo(float(theta), mass, True)
        own = own_energy(theta, mass)
        line += (f"fixed: E(T)={Ef[-1]:.10f}  max_t>0 |fixed - own| = "
                 f"{np.max(np.abs(Ef[1:] - own[1:])):.1e}")
        print(line)


if __name__ == "__main__":
    _main()
