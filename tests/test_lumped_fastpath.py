"""The fused lumped-mass kernels (contact_bench.kernels.lumped) against the generic tridiagonal
kernels.

Same inputs through both paths of `restitution` (lumped, beta = 0) and `taylor_flanagan`
(lumped): the sampled U, V, stress, energy, u(0, t), min u0, steps and blow-up must
agree to round-off. The two paths round differently (2U - Um + dt^2 M^-1 (F - KU)
against (M (2U - Um) + dt^2 (F - KU)) / M; kick-drift against velocity Verlet), so the
comparison is not bitwise. Every quantity is compared in displacement units, relative
to max|U|: V times dt (restitution's V is (U^{n+1} - U^{n-1}) / 2 dt), the stress times
dt^2 / M00 (the displacement the contact force gives node 0 in a step), the energy
divided by max|U| sum|K_ii| (it is a sum of O(1/h) terms that cancel). Measured on
these runs: at most 7e-14 (plain relative differences: U 7e-14, V 4e-12, as the
difference quotient loses digits). A generic run against itself with U0 moved by one
ulp differs by as much (or, for e = 1 over many impacts, by O(1): the impacts amplify
round-off), so the runs here stop after the first impact and release.
A jittered mesh makes every coefficient differ from its neighbour (a uniform mesh
would hide a shifted stencil).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import contact_bench.schemes.restitution as restitution
import contact_bench.schemes.taylor_flanagan as taylor_flanagan
from contact_bench.api.fem import mesh_nodes
from contact_bench.api.plugin import Semidiscrete, Trajectory
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case, make_scheme

TOL = 2e-13  # relative to max|U|, every quantity in displacement units (see above)


def _jittered(L: float, nx: int, seed: int = 3) -> np.ndarray:
    x = np.linspace(0.0, L, nx + 1)
    x[1:-1] += np.random.default_rng(seed).uniform(-0.3, 0.3, nx - 1) * (L / nx)
    return x


def _scene(case: str) -> tuple[Semidiscrete, float, int]:
    """(lumped semi on a jittered mesh, dt = 0.9 hmin / c, steps through the first impact)."""
    c = make_case(case)
    semi = discretise(c, _jittered(c.L, 40), "lumped")
    if case == "clamped_bar":  # and a nonzero initial velocity, to exercise V0
        semi = dataclasses.replace(semi, V0=0.05 * np.sin(np.pi * semi.x[:semi.nfree]))
    dt = 0.9 * semi.hmin / semi.c_max
    T = {"clamped_bar": 4.0, "dropped_bar": 2.0}[case]  # contact on (1, 2) and (1, 5/3)
    return semi, dt, int(T / dt)


def _assert_agree(fast: Trajectory, ref: Trajectory, semi: Semidiscrete, dt: float) -> None:
    assert fast.steps_done == ref.steps_done
    assert fast.blowup_time == ref.blowup_time
    np.testing.assert_array_equal(fast.t, ref.t)
    np.testing.assert_array_equal(fast.stress != 0, ref.stress != 0)  # same contact samples
    scale = {"U": 1.0, "contact_u": 1.0, "V": dt, "stress": dt * dt / semi.M.diag[0],
             "energy": 1.0 / (np.abs(ref.U).max() * np.abs(semi.K.diag).sum())}
    for q, to_u in scale.items():
        a, b = getattr(fast, q), getattr(ref, q)
        assert a.shape == b.shape, q
        err = np.abs(a - b).max() * to_u / np.abs(ref.U).max()
        assert err <= TOL, (q, err)
    assert abs(fast.min_contact_u - ref.min_contact_u) <= TOL * np.abs(ref.U).max()


@pytest.mark.parametrize("case", ["clamped_bar", "dropped_bar"])
@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_restitution_fast_path_agrees_with_generic(case, e):
    semi, dt, nsteps = _scene(case)
    fast = restitution.run_paoli_schatzman(semi, dt, nsteps, 3, e, 0.0)
    ref = restitution.run_paoli_schatzman(semi, dt, nsteps, 3, e, 0.0, fast=False)
    assert (ref.stress != 0).sum() > 5  # the contact is active on several samples
    if e > 0:
        assert ref.min_contact_u < 0  # the restitution penetration is exercised
    else:
        assert ref.min_contact_u == 0.0 and fast.min_contact_u == 0.0
    _assert_agree(fast, ref, semi, dt)


@pytest.mark.parametrize("case", ["clamped_bar", "dropped_bar"])
def test_taylor_flanagan_fast_path_agrees_with_generic(case):
    semi, dt, nsteps = _scene(case)
    fast = taylor_flanagan.run_taylor_flanagan(semi, dt, nsteps, 3)
    ref = taylor_flanagan.run_taylor_flanagan(semi, dt, nsteps, 3, fast=False)
    assert (ref.stress != 0).sum() > 5
    _assert_agree(fast, ref, semi, dt)


def test_fast_paths_blow_up_at_the_same_step():
    c = make_case("clamped_bar")
    semi = discretise(c, mesh_nodes(c.L, 40), "lumped")
    dt = 1.1 * semi.hmin / semi.c_max  # above the lumped central difference limit h / c
    runs = [restitution.run_paoli_schatzman(semi, dt, 400, 2, 0.5, 0.0, fast=f)
            for f in (True, False)]
    runs += [taylor_flanagan.run_taylor_flanagan(semi, dt, 400, 2, fast=f) for f in (True, False)]
    for fast, ref in (runs[:2], runs[2:]):
        assert ref.blowup_time is not None and ref.steps_done < 400
        assert fast.blowup_time == ref.blowup_time and fast.steps_done == ref.steps_done
        assert fast.t.size == ref.t.size
        np.testing.assert_allclose(fast.U[:-1], ref.U[:-1], rtol=0, atol=1e-12)


@pytest.mark.parametrize("spec, fast", [
    ("restitution", True), ("restitution[e=1]", True), ("restitution[mass=consistent]", False),
    ("restitution[beta=0.25]", False), ("taylor_flanagan[mass=lumped]", True),
    ("taylor_flanagan", False),
])
def test_fast_path_is_taken_exactly_for_a_diagonal_system(monkeypatch, spec, fast):
    calls = []
    for mod, name in ((restitution, "ps_lumped_kernel"), (taylor_flanagan, "tf_lumped_kernel")):
        kernel = getattr(mod, name)
        monkeypatch.setattr(mod, name, lambda *a, _k=kernel: calls.append(1) or _k(*a))
    scheme = make_scheme(spec)
    c = make_case("clamped_bar")
    semi = discretise(c, mesh_nodes(c.L, 20), scheme.mass_kind())
    scheme.integrate(semi, 0.5 * semi.hmin / semi.c_max, 10, 5)
    assert bool(calls) == fast
