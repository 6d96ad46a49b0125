"""The sampled energy keeps its digits as the mesh grows.

U.K.U summed as diagonal then off-diagonal terms cancels for a smooth U: E(0) of the
clamped bar was off by 2.2e-4 at 1e5 dofs. Every kernel sums the energy through
`contact_bench.core.sampling.energy_of` (or `Tridiag.quad`): strain from element
differences, rounding-level row sums of the assembled stiffness taken as 0.
"""

from __future__ import annotations

import importlib.util
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

from contact_bench.api.fem import Tridiag, mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case, schemes
from contact_bench.core.sampling import energy_of
from contact_bench.core.tridiag import tri_quad


def _exact_quad(d: np.ndarray, e: np.ndarray, x: np.ndarray) -> float:
    s = sum(Fraction(float(di)) * Fraction(float(xi)) ** 2 for di, xi in zip(d, x, strict=True))
    s += 2 * sum(Fraction(float(ei)) * Fraction(float(a)) * Fraction(float(b))
                 for ei, a, b in zip(e, x[:-1], x[1:], strict=True))
    return float(s)


@pytest.mark.parametrize("seed", range(4))
def test_tri_quad_is_the_quadratic_form(seed: int) -> None:
    """Any symmetric tridiagonal (row sums far from 0): x^T A x to round-off, in numba
    and in numpy (`Tridiag.quad`, also along a stack of vectors)."""
    rng = np.random.default_rng(seed)
    n = 50
    d, e, x = rng.normal(size=n) + 3.0, rng.normal(size=n - 1), rng.normal(size=n)
    exact = _exact_quad(d, e, x)
    scale = float(np.sum(np.abs(d) * x * x) + 2 * np.sum(np.abs(e * x[:-1] * x[1:])))
    assert abs(tri_quad(d, e, x) - exact) <= 1e-14 * scale
    A = Tridiag(d, e)
    assert abs(A.quad(x) - exact) <= 1e-14 * scale
    np.testing.assert_allclose(A.quad(np.stack([x, 2 * x])), [A.quad(x), 4 * A.quad(x)],
                               rtol=1e-14)


@pytest.mark.parametrize("n", [1, 2, 3, 9, 10, 11, 17, 258, 259, 266, 530])
def test_energy_of_is_the_energy(n: int) -> None:
    """energy_of (vector blocks of 8 rows, blocks of QUAD_BLOCK, scalar rest) is 1/2 V.M.V
    + 1/2 U.K.U - F.U + offset to round-off, at sizes that end in each of its parts."""
    rng = np.random.default_rng(n)
    Md, Me = rng.normal(size=n) + 3.0, rng.normal(size=max(n - 1, 0))
    Kd, Ke = rng.normal(size=n) + 3.0, rng.normal(size=max(n - 1, 0))
    F, U, V = rng.normal(size=n), rng.normal(size=n), rng.normal(size=n)
    exact = (Fraction(_exact_quad(Md, Me, V)) / 2 + Fraction(_exact_quad(Kd, Ke, U)) / 2
             - sum(Fraction(float(f)) * Fraction(float(u)) for f, u in zip(F, U, strict=True))
             + Fraction(0.25))
    scale = 1.0 + sum(float(np.sum(np.abs(d) * x * x) + 2 * np.sum(np.abs(e * x[:-1] * x[1:])))
                      for d, e, x in ((Md, Me, V), (Kd, Ke, U))) + float(np.sum(np.abs(F * U)))
    assert abs(energy_of(Md, Me, Kd, Ke, F, U, V, 0.25) - float(exact)) <= 1e-14 * scale


def test_rigid_translation_has_no_strain() -> None:
    """The assembled stiffness of a free bar on a graded mesh: a translation strains
    nothing (the float matrix's own U.K.U is 0.14 at 1e6 dofs on dropped_bar, the plain
    sum 8137: benchmarks/rowsum_rounding.py)."""
    case = make_case("dropped_bar")
    semi = discretise(case, mesh_nodes(case.L, 20_000, 1.5))
    U = np.full(semi.nfree, 5.0)
    assert tri_quad(semi.K.diag, semi.K.off, U) == 0.0
    assert semi.K.quad(U) == 0.0


@pytest.mark.parametrize("nx", [100_000])
@pytest.mark.parametrize("mass", ["consistent", "lumped", "seed", "getfem"])
def test_initial_energy_at_scale(nx: int, mass: str) -> None:
    """u0 linear: the discrete energy is 1/8 exactly; numba and numpy sums agree."""
    semi = discretise(make_case("clamped_bar"), mesh_nodes(1.0, nx), mass)
    E = energy_of(semi.M.diag, semi.M.off, semi.K.diag, semi.K.off, semi.F, semi.U0,
                  semi.V0, semi.energy_offset)
    assert abs(E - 0.125) <= 1e-12
    E_np = 0.5 * semi.M.quad(semi.V0) + 0.5 * semi.K.quad(semi.U0) + semi.energy_offset
    assert abs(E_np - 0.125) <= 1e-12


def _quiet_energy():
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "quiet_energy.py"
    spec = importlib.util.spec_from_file_location("_bench_quiet_energy", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


#: E(0) - 1/8 at nx elements: the Nitsche term of E_theta (theta = 1, gamma0 = 5), the
#: first element's strain energy released by the ODE schemes' relaxed start
_E0_SHIFT = {"nitsche": lambda h: -h / 40, "ode_adaptive": lambda h: -h / 8,
             "ode_verlet": lambda h: -h / 8}


@pytest.mark.parametrize("scheme", schemes().names())
def test_quiet_run_energy_exact(scheme: str) -> None:
    """clamped_bar at nx = 1e5, 10 steps of 1e-7 (every sample kept): E(0) is the
    analytic 1/8 (or its known shift) and every sampled energy equals the exactly summed
    energy of its own sampled state (benchmarks/quiet_energy.py) to 1e-10 relative;
    the plain sum was 2.2e-4 off in E(0)."""
    nx = 100_000
    r = _quiet_energy().quiet_run(scheme, nx)
    assert r["status"] == "ok", r["notes"]
    assert r["samples"] == 11
    assert abs(r["E0_minus_exact"] - _E0_SHIFT.get(scheme, lambda h: 0.0)(1.0 / nx)) <= 1e-13
    assert r["max_dev_ref"] <= 1e-10
