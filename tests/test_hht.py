"""The hht kernel (three passes per step, schemes/hht.py) against a plain scipy HHT-alpha
step written here from the scheme's equations: sparse LU factorised once, one solve per
step in Python, the contact folded in with w = S^-1 e0. Relative 1e-12, as the Newmark
kernels against contact_bench.harness.scipy_reference (tests/test_reference.py); also the smallest
systems
(1 to 4 unknowns: the kernel's first and last rows are written apart from the loop)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.plugin import Semidiscrete
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case, make_scheme

TOL = 1e-12


def _plain_hht(semi: Semidiscrete, dt: float, nsteps: int, alpha: float
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(U, V, stress) after every step of HHT-alpha with exact contact at node 0:
    S U1 = M U~ + beta dt^2 (F + alpha K U) + contact, S = M + (1 + alpha) beta dt^2 K."""
    M, K, F = semi.M, semi.K, semi.F
    beta, gamma = (1.0 - alpha) ** 2 / 4.0, 0.5 - alpha
    bdt2 = beta * dt * dt
    n = semi.nfree
    first = 1 if semi.massless else 0
    U, V, A = semi.U0.copy(), semi.V0.copy(), np.zeros(n)
    if n > first:
        A[first:] = spla.splu(M.to_sparse().tocsc()[first:, first:]).solve(
            (F - K.matvec(U))[first:])
    lu = spla.splu((M.to_sparse() + (1.0 + alpha) * bdt2 * K.to_sparse()).tocsc())
    w = lu.solve(np.eye(n)[0])
    Us, Vs, S = [U.copy()], [V.copy()], [0.0]
    for _ in range(nsteps):
        Ut = U + dt * V + (0.5 - beta) * dt * dt * A
        U1 = lu.solve(M.matvec(Ut) + bdt2 * (F + alpha * K.matvec(U)))
        mu = -U1[0] / w[0] if U1[0] < 0.0 else 0.0
        if mu:
            U1 = U1 + mu * w
            U1[0] = 0.0
        A1 = (U1 - Ut) / bdt2
        V = V + dt * ((1.0 - gamma) * A + gamma * A1)
        if semi.massless:
            V[0] = (U1[0] - U[0]) / dt
            A1[0] = 0.0
        U, A = U1, A1
        Us.append(U.copy())
        Vs.append(V.copy())
        S.append(-mu / bdt2)
    return np.array(Us), np.array(Vs), np.array(S)


def _compare(spec: str, semi: Semidiscrete, dt: float, nsteps: int) -> np.ndarray:
    scheme = make_scheme(spec)
    got = scheme.integrate(semi, dt, nsteps, 1)
    U, V, S = _plain_hht(semi, dt, nsteps, float(scheme.alpha))
    u = np.abs(U).max()
    stiff = semi.K.diag[0] + semi.M.diag[0] / (scheme.beta * dt * dt)
    for name, want, scale in (("U", U, u), ("V", V, max(np.abs(V).max(), u / dt)),
                              ("stress", S, max(np.abs(S).max(), u * stiff))):
        err = np.abs(getattr(got, name) - want).max() / scale
        assert err < TOL, (spec, name, err)
    assert got.min_contact_u == pytest.approx(U[:, 0].min(), abs=TOL * u)
    return S


@pytest.mark.parametrize("spec", ["hht", "hht[alpha=-0.3]", "hht[mass=getfem]", "hht[alpha=0]"])
@pytest.mark.parametrize("case_name,nx,dt,T", [("clamped_bar", 20, 0.02, 2.5),
                                               ("dropped_bar", 30, 0.01, 1.3)])
def test_hht_trajectories_agree_with_a_plain_scipy_step(spec, case_name, nx, dt, T):
    """Massless contact node (the scheme's default mass and GetFEM's): whole
    trajectories with impacts and take-offs."""
    case = make_case(case_name)
    semi = discretise(case, mesh_nodes(case.L, nx), make_scheme(spec).mass_kind())
    S = _compare(spec, semi, dt, int(np.ceil(T / dt)))
    assert (S < 0).sum() >= 5  # impacts are part of the window


@pytest.mark.parametrize("case_name", ["clamped_bar", "dropped_bar"])
def test_hht_step_map_agrees_with_a_massive_contact_node(case_name):
    """Consistent mass (the contact node chatters, so round-off grows along a whole
    trajectory): three steps from states before, in and after contact."""
    case = make_case(case_name)
    spec = "hht[mass=consistent]"
    semi = discretise(case, mesh_nodes(case.L, 24), "consistent")
    dt = 0.01
    U, V, S = _plain_hht(semi, dt, 400, -0.1)
    assert (S < 0).sum() >= 5
    for k in np.unique(np.r_[0, np.nonzero(S < 0)[0][::7], 200, 350]):
        start = dataclasses.replace(semi, U0=U[k].copy(), V0=V[k].copy())
        _compare(spec, start, dt, 3)


@pytest.mark.parametrize("nx", [1, 2, 3, 4])
@pytest.mark.parametrize("mass", ["seed", "consistent"])
def test_hht_smallest_systems(nx, mass):
    """40 steps with a massless contact node; 4 with a massive one (it chatters: see
    above)."""
    case = make_case("clamped_bar")
    semi = discretise(case, mesh_nodes(case.L, nx), mass)
    if semi.nfree <= (1 if semi.massless else 0):
        pytest.skip("no free node besides the contact node")
    _compare(f"hht[mass={mass}]", semi, 0.1, 40 if semi.massless else 4)
