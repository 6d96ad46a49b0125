"""The SPIKE (lane-interleaved) kernels of ode_verlet and taylor_flanagan (consistent
mass) against their natural-order reference kernels.

Same inputs through both paths (`run_ode_verlet`, `run_taylor_flanagan` with `fast`
True / False): the samples, contact status, stress, energy, u(0, t), min u0, steps and
blow-up step must agree to round-off. The paths round differently (the partitioned
solve, FMA contraction, the order of the stencil's terms), so the comparison is not
bitwise. Every quantity is compared in displacement units relative to max|U|, as in
tests/test_lumped_fastpath.py: V times dt, the energy divided by max|U| sum|K_ii|, the
stress times dt^2 / M00 (taylor_flanagan) or 1 / K00 (ode_verlet's massless node:
lambda = K00 u0 + K01 u1 - F0). Measured on these runs: at most 1.5e-14. A jittered mesh
makes every coefficient differ from its neighbour; nx = 12 is a single row of lanes
(m = 1: every neighbour in another lane), nx = 40 and 70 several rows.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.linalg as sl

import contact_bench.schemes.ode_verlet as ode_verlet
import contact_bench.schemes.taylor_flanagan as taylor_flanagan
from contact_bench.api.fem import mesh_nodes
from contact_bench.api.plugin import Semidiscrete, Trajectory
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case, make_scheme

TOL = 1e-12  # relative to max|U|, every quantity in displacement units (see above)


def _jittered(L: float, nx: int, seed: int = 5) -> np.ndarray:
    x = np.linspace(0.0, L, nx + 1)
    x[1:-1] += np.random.default_rng(seed).uniform(-0.3, 0.3, nx - 1) * (L / nx)
    return x


def _scene(case: str, nx: int, mass: str) -> tuple[Semidiscrete, float, int]:
    """(semi on a jittered mesh, dt = 0.9 x the limit h / (c sqrt 3), steps through the
    first impact and release)."""
    c = make_case(case)
    semi = discretise(c, _jittered(c.L, nx), mass)
    if case == "clamped_bar":  # and a nonzero initial velocity, to exercise V0
        semi = dataclasses.replace(semi, V0=0.05 * np.sin(np.pi * semi.x[:semi.nfree]))
    dt = 0.9 * semi.hmin / (semi.c_max * np.sqrt(3.0))
    T = {"clamped_bar": 2.5, "dropped_bar": 2.0}[case]
    return semi, dt, int(T / dt)


def _assert_agree(fast: Trajectory, ref: Trajectory, dt: float, stress_to_u: float,
                  semi: Semidiscrete) -> float:
    assert fast.steps_done == ref.steps_done
    assert fast.blowup_time == ref.blowup_time
    np.testing.assert_array_equal(fast.t, ref.t)
    np.testing.assert_array_equal(fast.stress != 0, ref.stress != 0)  # same contact samples
    umax = np.abs(ref.U).max()
    scale = {"U": 1.0, "contact_u": 1.0, "V": dt, "stress": stress_to_u,
             "energy": 1.0 / (umax * np.abs(semi.K.diag).sum())}
    worst = 0.0
    for q, to_u in scale.items():
        a, b = getattr(fast, q), getattr(ref, q)
        assert a.shape == b.shape, q
        err = np.abs(a - b).max() * to_u / umax
        assert err <= TOL, (q, err)
        worst = max(worst, err)
    assert abs(fast.min_contact_u - ref.min_contact_u) <= TOL * umax
    return worst


@pytest.mark.parametrize("case", ["clamped_bar", "dropped_bar"])
@pytest.mark.parametrize("nx, variant", [(12, "seed"), (40, "getfem"), (70, "conservative")])
def test_ode_verlet_spike_kernel_agrees_with_reference(case, nx, variant):
    semi, dt, nsteps = _scene(case, nx, variant)
    fast = ode_verlet.run_ode_verlet(semi, dt, nsteps, 3)
    ref = ode_verlet.run_ode_verlet(semi, dt, nsteps, 3, fast=False)
    on = ref.stress != 0
    assert on.sum() > 5 and not on[-1]  # contact active on several samples, then released
    assert ref.min_contact_u == 0.0 and fast.min_contact_u == 0.0
    _assert_agree(fast, ref, dt, 1.0 / semi.K.diag[0], semi)


def _verlet_numpy(semi: Semidiscrete, dt: float, nsteps: int) -> np.ndarray:
    """(P_U^mod) by velocity Verlet in plain numpy (banded solves): U at the last step."""
    M, K, F = semi.M, semi.K, semi.F
    band = np.vstack((np.r_[0.0, M.off[1:]], M.diag[1:]))

    def acc(U: np.ndarray) -> np.ndarray:
        U[0] = max(0.0, (F[0] - K.off[0] * U[1]) / K.diag[0])
        A = np.zeros_like(U)
        r = (F - K.matvec(U))[1:]
        A[1:] = r / band[1] if r.size == 1 else sl.solveh_banded(band, r)  # LAPACK: n >= 2
        return A

    U, V = semi.U0.copy(), semi.V0.copy()
    A = acc(U)
    for _ in range(nsteps):
        V[1:] += 0.5 * dt * A[1:]
        U[1:] += dt * V[1:]
        A = acc(U)
        V[1:] += 0.5 * dt * A[1:]
    return U


@pytest.mark.parametrize("nx", [1, 2])  # nfree = 2, 3 (the reference kernel needs 3)
def test_ode_verlet_spike_kernel_on_the_smallest_meshes(nx):
    c = make_case("dropped_bar")
    semi = discretise(c, mesh_nodes(c.L, nx), "getfem")  # seed: M_bar = 0 at nx = 1
    dt = 0.5 * semi.hmin / (semi.c_max * np.sqrt(3.0))
    nsteps = int(2.0 / dt)
    tr = ode_verlet.run_ode_verlet(semi, dt, nsteps, nsteps)
    assert tr.min_contact_u == 0.0  # the obstacle is reached
    U = _verlet_numpy(semi, dt, nsteps)
    assert np.abs(tr.U[-1] - U).max() <= 1e-12 * np.abs(U).max()


@pytest.mark.parametrize("case", ["clamped_bar", "dropped_bar"])
@pytest.mark.parametrize("nx", [12, 40, 70])
def test_taylor_flanagan_spike_kernel_agrees_with_reference(case, nx):
    semi, dt, nsteps = _scene(case, nx, "consistent")
    fast = taylor_flanagan.run_taylor_flanagan(semi, dt, nsteps, 3)
    ref = taylor_flanagan.run_taylor_flanagan(semi, dt, nsteps, 3, fast=False)
    assert (ref.stress != 0).sum() > 5  # the contact correction (lambda w) is exercised
    _assert_agree(fast, ref, dt, dt * dt / semi.M.diag[0], semi)


def test_spike_kernels_blow_up_at_the_same_step():
    c = make_case("clamped_bar")
    runs = []
    for mass, run in (("seed", ode_verlet.run_ode_verlet),
                      ("consistent", taylor_flanagan.run_taylor_flanagan)):
        semi = discretise(c, mesh_nodes(c.L, 40), mass)
        dt = 1.1 * semi.hmin / (semi.c_max * np.sqrt(3.0))  # above the limit h / (c sqrt 3)
        runs.append([run(semi, dt, 400, 2, fast=f) for f in (True, False)])
    for fast, ref in runs:
        assert ref.blowup_time is not None and ref.steps_done < 400
        assert fast.blowup_time == ref.blowup_time and fast.steps_done == ref.steps_done
        assert fast.t.size == ref.t.size
        np.testing.assert_allclose(fast.U[:-1], ref.U[:-1], rtol=0, atol=1e-12)


@pytest.mark.parametrize("spec, nx, nsteps, kernel", [
    ("ode_verlet", 200, 1300, "verlet_spike_kernel"),
    ("ode_verlet[variant=getfem]", 200, 1300, "verlet_spike_kernel"),
    ("ode_verlet", 20, 10, "verlet_kernel"),  # small: the serial natural-order kernel
    ("ode_verlet", 200, 10, "verlet_kernel"),  # too short to pay back the SPIKE set-up
    ("taylor_flanagan", 200, 1300, "tf_spike_kernel"),
    ("taylor_flanagan", 20, 10, "taylor_flanagan_kernel"),
    ("taylor_flanagan[mass=lumped]", 20, 10, "tf_lumped_kernel"),
    ("taylor_flanagan[mass=lumped]", 200, 1300, "tf_lumped_kernel"),
])
def test_integrate_takes_the_fastest_kernel(monkeypatch, spec, nx, nsteps, kernel):
    calls = []
    mod = ode_verlet if spec.startswith("ode_verlet") else taylor_flanagan
    names = ("verlet_spike_kernel", "verlet_kernel") if mod is ode_verlet else (
        "tf_spike_kernel", "tf_lumped_kernel", "taylor_flanagan_kernel")
    for name in names:
        k = getattr(mod, name)
        monkeypatch.setattr(mod, name, lambda *a, _k=k, _n=name: calls.append(_n) or _k(*a))
    scheme = make_scheme(spec)
    c = make_case("clamped_bar")
    semi = discretise(c, mesh_nodes(c.L, nx), scheme.mass_kind())
    assert 20 < ode_verlet.SERIAL_BELOW == taylor_flanagan.SERIAL_BELOW <= 200
    scheme.integrate(semi, 0.5 * semi.hmin / semi.c_max, nsteps, nsteps)
    assert calls == [kernel]
