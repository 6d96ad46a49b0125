"""Foundation: assembly, exact solutions, the standard and redistributed schemes."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from skfem import Basis, ElementLineP1, MeshLine
from skfem.models import laplace, mass

from contact_bench.api.fem import Tridiag, assemble, mass_variant, mesh_nodes
from contact_bench.cases.clamped_bar import ClampedBarExact
from contact_bench.core.errors import BenchError
from contact_bench.harness.runner import run_one


# ------------------------------------------------------------------------- assembly
@pytest.mark.parametrize("grading", [1.0, 2.0])
def test_assembly_sums_and_bands(grading):
    x = mesh_nodes(3.0, 17, grading)
    asm = assemble(x, rho=2.5, E=7.0)
    ones = np.ones(x.size)
    assert asm.M.matvec(ones).sum() == pytest.approx(2.5 * 3.0, rel=1e-13)
    assert np.abs(asm.K.matvec(ones)).max() < 1e-11
    # bands equal scikit-fem's own sparse matrices from its ready-made forms
    basis = Basis(MeshLine(x), ElementLineP1())
    Mref = 2.5 * mass.assemble(basis)
    Kref = 7.0 * laplace.assemble(basis)
    assert sp.linalg.norm(asm.M.to_sparse() - Mref) < 1e-13
    assert sp.linalg.norm(asm.K.to_sparse() - Kref) < 1e-11


def test_assembly_matches_hand_formulas_on_a_nonuniform_mesh():
    x = np.array([0.0, 0.1, 0.3, 0.7, 1.0])
    asm = assemble(x, rho=1.0, E=1.0)
    h = np.diff(x)
    np.testing.assert_allclose(asm.M.off, h / 6)
    np.testing.assert_allclose(asm.K.off, -1 / h)
    np.testing.assert_allclose(asm.M.diag, np.r_[h / 3, 0] + np.r_[0, h / 3])


def test_refined_skfem_mesh_order_would_break_bands():
    # the gotcha this module avoids: MeshLine().refined() does not keep x order
    m = MeshLine().refined(3)
    basis = Basis(m, ElementLineP1())
    with pytest.raises(ValueError, match="not tridiagonal"):
        Tridiag.from_sparse(mass.assemble(basis))


def test_mass_variants_totals():
    x = mesh_nodes(1.0, 10)
    asm = assemble(x, 1.0, 1.0)
    h = 0.1
    total = {k: mass_variant(asm, k).matvec(np.ones(11)).sum() for k in
             ("consistent", "lumped", "seed", "getfem", "conservative")}
    assert total["consistent"] == pytest.approx(1.0)
    assert total["lumped"] == pytest.approx(1.0)
    assert total["seed"] == pytest.approx(1.0 - h)
    assert total["getfem"] == pytest.approx(1.0 - h / 6)
    assert total["conservative"] == pytest.approx(1.0)
    assert mass_variant(asm, "singular").diag[1] == pytest.approx(7 * h / 12)
    for k in ("seed", "getfem", "conservative", "singular"):
        Mk = mass_variant(asm, k)
        assert Mk.diag[0] == 0 and Mk.off[0] == 0


# ------------------------------------------------------------------ exact solutions
def test_clamped_bar_exact_solution_properties():
    ex = ClampedBarExact()
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 1, 400)
    np.testing.assert_allclose(ex.u(x, 0.0), 0.5 - 0.5 * x, atol=1e-15)
    np.testing.assert_allclose(ex.ut(x + 1e-9, 0.0 + 1e-12)[x > 1e-6], 0.0, atol=1e-15)
    t = np.linspace(0, 12, 2401)
    np.testing.assert_allclose(ex.u(1.0, t), 0.0, atol=1e-15)
    u0 = ex.u(0.0, t)
    s = ex.stress(t)
    assert u0.min() >= -1e-15 and s.max() <= 0
    assert np.abs(u0 * s).max() <= 1e-15
    # u(0, t) from the note: 1/2 - t/2, 0, (t-2)/2 on [0,1], [1,2], [2,3], period 3
    tm = np.mod(t, 3)
    expected = np.where(tm <= 1, 0.5 - tm / 2, np.where(tm <= 2, 0.0, (tm - 2) / 2))
    np.testing.assert_allclose(u0, expected, atol=1e-14)
    # stress from the continuum: E u_x(0, t) off the switching times
    inside = np.abs(tm - np.round(tm)) > 1e-6
    np.testing.assert_allclose(ex.ux(0.0, t[inside]), s[inside])
    # energy 1/2 int u_t^2 + u_x^2 = 1/8 at every time, by fine midpoint quadrature
    xq = (np.arange(20000) + 0.5) / 20000
    for tk in rng.uniform(0, 12, 15):
        e = 0.5 * np.mean(ex.ut(xq, tk) ** 2 + ex.ux(xq, tk) ** 2)
        assert e == pytest.approx(0.125, abs=1e-4)
    # the wave equation holds weakly: finite differences of u match u_t and u_x
    xs, ts, d = rng.uniform(0.05, 0.95, 200), rng.uniform(0.05, 11.9, 200), 1e-7
    ok = (np.abs(np.mod(xs + ts, 1) - 0.5) < 0.45) & (np.abs(np.mod(xs - ts, 1) - 0.5) < 0.45)
    fd_t = (ex.u(xs, ts + d) - ex.u(xs, ts - d)) / (2 * d)
    fd_x = (ex.u(xs + d, ts) - ex.u(xs - d, ts)) / (2 * d)
    np.testing.assert_allclose(fd_t[ok], ex.ut(xs, ts)[ok], atol=1e-7)
    np.testing.assert_allclose(fd_x[ok], ex.ux(xs, ts)[ok], atol=1e-7)


def test_dropped_bar_series_agrees_with_characteristics():
    from contact_bench.cases.dropped_bar import DroppedBar
    from contact_bench.exact import dropped_series
    from contact_bench.exact.dropped_series import SERIES_TRUNCATION, series_u

    case = DroppedBar()
    assert (dropped_series.LENGTH, dropped_series.YOUNG, dropped_series.GRAVITY,
            dropped_series.HEIGHT) == (case.L, case.E, case.g, case.height)
    assert case.rho == 1.0
    ex = case.exact(6.5)
    rng = np.random.default_rng(1)
    x, t = rng.uniform(0, 10, 300), rng.uniform(0, 6.5, 300)
    diff = np.abs(series_u(x, t) - ex.u(x, t))
    assert diff.max() < SERIES_TRUNCATION
    # and the typo of the paper (sqrt(2 u0 / g)) would be far off: impact speed 10, not 1
    assert ex.ut(0.5, 0.999) == pytest.approx(-9.99, abs=1e-6)
    # energy including gravity
    xq = np.linspace(0, 10, 40001)[:-1] + 10 / 80000
    for tk in (0.3, 1.2, 2.0, 4.0, 6.4):
        e = np.mean(0.5 * ex.ut(xq, tk) ** 2 + 450 * ex.ux(xq, tk) ** 2 + 10 * ex.u(xq, tk)) * 10
        assert e == pytest.approx(500.0, rel=1e-6)


# -------------------------------------------------------------------------- schemes
@pytest.mark.parametrize("nx", [40, 80, 160])
def test_redistributed_getfem_energy_and_first_step(nx):
    dt = 0.08 / nx  # CFL 0.08: the drift at switching steps scales like dt^2
    run = run_one("clamped_bar", "redistributed[variant=getfem]", nx=nx, dt=dt)
    E = run.trajectory.energy
    h = 1 / nx
    assert E[0] == pytest.approx(0.125, rel=1e-13)
    # the first step moves the massless node to equilibrium, releasing the first
    # element's strain energy h/8 (up to O(dt^2) of the Crank-Nicolson step itself)
    assert (E[0] - E[1]) == pytest.approx(h / 8, rel=0.01)
    assert np.abs(E[1:] - E[1]).max() / E[1] < 1e-4
    assert run.row["status"] == "ok"


@pytest.mark.parametrize("spec", ["redistributed[variant=getfem]", "redistributed",
                                  "redistributed[variant=conservative]",
                                  "redistributed[beta=0]"])
def test_redistributed_converges_on_clamped_bar(spec):
    errs = []
    for nx in (20, 40, 80, 160):
        h = 1 / nx
        dt = 0.25 * h if "beta=0" not in spec else 0.5 * h / np.sqrt(3)
        errs.append(run_one("clamped_bar", spec, nx=nx, dt=dt, T=6.0, stride=4).row)
    for key in ("err_u_linf_l2", "err_u_l2_h1", "err_v_l2_l2", "err_stress_l2"):
        e = [r[key] for r in errs]
        assert all(b < a for a, b in zip(e, e[1:], strict=False)), (key, e)
    assert errs[0]["err_u_linf_l2"] / errs[-1]["err_u_linf_l2"] > 2.5  # order >~ 1/2


def test_standard_energy_grows_after_impacts():
    run = run_one("clamped_bar", "standard", nx=40, dt=0.01)
    tr = run.trajectory
    assert run.row["status"] == "ok"
    before = tr.energy[tr.t < 0.99]
    np.testing.assert_allclose(before, 0.125, rtol=1e-10)  # CN conserves until the impact
    assert tr.energy[tr.t > 2.5].min() > 1.5 * 0.125  # the seed's Fig. 5.3 (left)
    assert np.all(np.isfinite(tr.U))


@pytest.mark.parametrize("spec", ["standard", "redistributed", "redistributed[beta=0]",
                                  "standard[beta=0.3,gamma=0.6]"])
@pytest.mark.parametrize("case", ["clamped_bar", "dropped_bar"])
def test_exact_contact_never_penetrates(spec, case):
    nx = 40
    dt = 0.01 if case == "clamped_bar" else 0.005
    if "beta=0]" in spec:
        dt = 0.5 / nx / np.sqrt(3) if case == "clamped_bar" else 0.5 * 0.25 / 30 / np.sqrt(3)
    run = run_one(case, spec, nx=nx, dt=dt)
    assert run.row["penetration_max"] <= 1e-14 * 5
    assert run.trajectory.contact_u.min() >= -1e-14


def test_dropped_bar_redistributed_converges():
    errs = [run_one("dropped_bar", "redistributed", nx=nx, dt=0.25 * (10 / nx) / 30 * 4,
                    stride=2).row["err_u_linf_l2"] for nx in (25, 50, 100)]
    assert errs[2] < errs[1] < errs[0]


def test_bad_inputs_are_one_line_errors():
    with pytest.raises(BenchError, match="nx must be an integer"):
        run_one("clamped_bar", "standard", nx=0)
    with pytest.raises(BenchError, match="dt must be finite"):
        run_one("clamped_bar", "standard", dt=float("nan"))
    with pytest.raises(BenchError, match="did you mean 'redistributed'"):
        run_one("clamped_bar", "redistributd")
    with pytest.raises(BenchError, match="out of range"):
        run_one("clamped_bar", "standard[gamma=2]")
    with pytest.raises(BenchError, match="stability limit"):
        run_one("clamped_bar", "redistributed[beta=0]", nx=40, dt=0.1)
    with pytest.raises(BenchError, match="stride"):
        run_one("clamped_bar", "standard", dt=0.5, T=1.0, stride=5)


def test_blocked_assembly_equals_one_assembly(monkeypatch):
    import contact_bench.api.fem as fem

    x = mesh_nodes(2.0, 1234, 1.7)
    whole = fem.assemble(x, 1.3, lambda s: 1 + s)
    monkeypatch.setattr(fem, "_ASSEMBLY_BLOCK", 100)
    blocks = fem.assemble(x, 1.3, lambda s: 1 + s)
    for a, b in ((whole.M, blocks.M), (whole.K, blocks.K)):
        np.testing.assert_allclose(b.diag, a.diag, rtol=1e-14, atol=0)
        np.testing.assert_allclose(b.off, a.off, rtol=1e-14, atol=0)


def test_flat_points_broadcasts_and_keeps_the_shape():
    from contact_bench.api.plugin import flat_points

    x, t = np.arange(8.0).reshape(2, 4), np.array([[[0.5]], [[1.5]], [[2.5]]])
    xf, tf, shape = flat_points(x, t)
    assert shape == (3, 2, 4)
    assert xf.flags.c_contiguous and tf.flags.c_contiguous and xf.ndim == 1
    bx, bt = np.broadcast_arrays(x, t)
    np.testing.assert_array_equal(xf.reshape(shape), bx)
    np.testing.assert_array_equal(tf.reshape(shape), bt)
    assert flat_points(2.0, 3.0)[2] == ()
    with pytest.raises(ValueError):
        flat_points(np.zeros(3), np.zeros(4))
