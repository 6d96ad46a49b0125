"""`kane` (Kane, Repetto, Ortiz, Marsden 1999) and `contact_stabilized` (Deuflhard,
Krause, Ertel 2008; Klapproth's velocity): they run every scene form, never gain energy,
the contact-stabilizing predictor halves (at least) the standard scheme's contact-stress
error on the clamped bar, and the compiled step agrees with an independent scipy
implementation of the papers' updates."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.optimize import nnls
from scipy.sparse.linalg import splu

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.harness.runner import problem_for, run_one

SCHEMES = ("kane", "contact_stabilized", "contact_stabilized[velocity=dke]")
#: the body scenes on their declared small grids (`Case.study`), the bars on short runs
BARS = {"clamped_bar": dict(nx=20, T=3.0), "dropped_bar": dict(nx=20, T=2.0, dt=2.1e-3)}
BODIES = ("disc_drop", "sphere_drop", "embedded_bar", "hertz_sphere")


@pytest.mark.parametrize("scheme", SCHEMES)
def test_every_scene_form_runs_with_exact_contact(scheme: str) -> None:
    for scene, kw in BARS.items():
        run = run_one(scene, scheme, **kw)
        assert run.row["status"] == "ok", (scene, run.row["notes"])
        assert run.row["penetration_max"] == 0.0
        assert np.min(run.trajectory.stress) < 0.0, (scene, "no contact")
    for name in BODIES:
        case = make_case(make_case(name).study.small)
        row = run_one(case, scheme, nx=case.study.small_nx[0], T=case.study.small_T).row
        assert row["status"] == "ok", (name, row["notes"])
        assert np.isfinite(row["first_contact_start"]), (name, "no impact")
        assert row["penetration_max"] <= 1e-12, (name, row["penetration_max"])


COLUMNS = ("err_u_linf_l2", "err_u_l2_h1", "err_v_l2_l2", "err_stress_l2",
           "energy_initial", "energy_final", "energy_drift_max", "penetration_max")
#: relative agreement of the embedded bar's row with the 1D row. With the predictor the
#: rows agree to round-off (1e-9 of tests/test_sparse.py's embedded_bar tests, but for
#: the step at which a contact dof lifts off, decided on a round-off-sized force: 1.03e-9
#: of dropped_bar's stress error in 3D, measured); Kane's
#: contact dofs chatter (the massive contact node's impacts: a dof's status switches on
#: forces of round-off size, differently across the section), which moves the rows by
#: 7e-8 (clamped) to 1.5e-5 (dropped) relative, measured
AGREE = {"kane": 1e-4, "contact_stabilized": 1e-8, "contact_stabilized[velocity=dke]": 1e-8}


@pytest.mark.parametrize(("scheme", "dim"), [(s, 2) for s in SCHEMES] + [(SCHEMES[1], 3)])
def test_embedded_bar_rows_equal_the_1d_rows(scheme: str, dim: int) -> None:
    for scene, (T, dt) in {"clamped_bar": (2.5, None), "dropped_bar": (2.0, 2.1e-3)}.items():
        a = run_one(scene, scheme, nx=16, T=T, dt=dt).row
        b = run_one(f"embedded_bar[of={scene},dim={dim}]", scheme, nx=16, T=T, dt=dt).row
        assert a["status"] == b["status"] == "ok", b["notes"]
        for col in COLUMNS:
            assert b[col] == pytest.approx(a[col], rel=AGREE[scheme], abs=1e-12), (scene, col)


def _energy_steps(case: str, scheme: str, **kw) -> tuple[np.ndarray, np.ndarray]:
    run = run_one(case, scheme, stride=1, **kw)
    assert run.row["status"] == "ok", run.row["notes"]
    return np.asarray(run.trajectory.energy), run.trajectory


@pytest.mark.parametrize("scheme", SCHEMES)
def test_energy_never_grows_on_the_clamped_bar_and_the_disc(scheme: str) -> None:
    """Every step's energy change <= round-off, and the impacts dissipate some; the
    standard scheme on the same runs gains energy (the check can fail)."""
    runs = {"clamped_bar": dict(nx=80), "disc_drop[degree=1,lift=0.5]": dict(nx=3, T=5.0)}
    for case, kw in runs.items():
        E, _ = _energy_steps(case, scheme, **kw)
        assert np.max(np.diff(E)) <= 1e-12 * abs(E[0]), (case, np.max(np.diff(E)))
        assert E[-1] < E[0] * (1 - 1e-6), (case, E[0], E[-1])
        E_std, _ = _energy_steps(case, "standard", **kw)
        assert np.max(np.diff(E_std)) > 1e-6 * abs(E_std[0]), case


def test_kane_energy_balance_is_the_contact_work() -> None:
    """Kane's per-step balance on the bar, exactly: E^{n+1} - E^n = -lambda^{n+1} u_0^n
    (the obstacle's force, applied over the step, against the gap it closes), with the
    stress -lambda and u_0 = contact_u sampled every step."""
    E, tr = _energy_steps("clamped_bar", "kane", nx=40)
    work = tr.stress[1:] * tr.contact_u[:-1]  # -lambda^{n+1} u_0^n, <= 0
    assert np.max(work) <= 0.0 and np.min(work) < -1e-6
    np.testing.assert_allclose(np.diff(E), work, rtol=0, atol=1e-13)


def test_contact_stabilized_halves_the_standard_stress_error() -> None:
    """The predictor removes the contact stress's oscillations (clamped bar, nx 80)."""
    std = run_one("clamped_bar", "standard", nx=80).row["err_stress_l2"]
    cs = run_one("clamped_bar", "contact_stabilized", nx=80).row["err_stress_l2"]
    kane = run_one("clamped_bar", "kane", nx=80).row["err_stress_l2"]
    assert cs <= 0.5 * std, (cs, std)
    assert cs < kane  # the predictor's own effect, beyond Kane's implicit force


# ------------------------------------------- an independent implementation in scipy


def _lcp(W: np.ndarray, q: np.ndarray) -> np.ndarray:
    """mu >= 0, q + W mu >= 0, complementary: min 1/2 mu.W.mu + q.mu over mu >= 0 as the
    nonnegative least-squares problem |R mu + R^-T q| with W = R^T R (scipy's nnls)."""
    R = np.linalg.cholesky(W).T
    mu, _ = nnls(R, -np.linalg.solve(R.T, q))
    return mu


class _ReferenceStep:
    """The papers' updates in plain scipy, one step from a given state: the M-projection
    predictor (none for Kane), the displacement problem with S = M + dt^2/4 K, the
    velocity update."""

    def __init__(self, p, dt: float, predictor: str) -> None:
        self.p, self.dt, self.predictor = p, dt, predictor
        self.M, self.K = sp.csc_matrix(p.M), sp.csc_matrix(p.K)
        self.cd, self.g0 = np.asarray(p.contact.dofs), np.asarray(p.contact.gap0, float)
        E = np.zeros((p.nfree, self.cd.size))
        E[self.cd, np.arange(self.cd.size)] = 1.0
        self.S = splu(self.M + 0.25 * dt * dt * self.K)
        self.ZS = self.S.solve(E)
        self.ZM = splu(self.M).solve(E)

    def __call__(self, U: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        dt, cd, g0 = self.dt, self.cd, self.g0
        Ut = U + dt * V
        if self.predictor != "none" and np.any(g0 + Ut[cd] < 0):
            Ut = Ut + self.ZM @ _lcp(self.ZM[cd], g0 + Ut[cd])
        rhs = self.M @ Ut - 0.25 * dt * dt * (self.K @ U) + 0.5 * dt * dt * self.p.F
        X = self.S.solve(rhs)
        if np.any(g0 + X[cd] < 0):
            X = X + self.ZS @ _lcp(self.ZS[cd], g0 + X[cd])
        base = (Ut - U) / dt if self.predictor == "klapproth" else V
        return X, base + 2.0 / dt * (X - Ut)


@pytest.mark.parametrize(("spec", "predictor"), [("kane", "none"),
                                                 ("contact_stabilized", "klapproth"),
                                                 ("contact_stabilized[velocity=dke]", "dke")])
def test_each_compiled_step_is_the_scipy_step(spec: str, predictor: str) -> None:
    """The disc (P1, 3 rings) through its impact, sampled every step: from each sampled
    state, the scipy step gives the next sample to round-off. (Whole runs drift apart
    with Kane: its contact dofs' velocities flip every step in contact, and round-off
    grows through the Delassus correction until a status switches, as in `standard`.)"""
    case, scheme = make_case("disc_drop[degree=1,lift=0.5]"), make_scheme(spec)
    p = problem_for(case, scheme, 3)
    dt, nsteps = 0.01, 400  # the impact is at t = 3.2
    tr = scheme.prepare(p, dt).run(nsteps, 1)
    assert tr.extra["contact_steps"] > 10
    step = _ReferenceStep(p, dt, predictor)
    for n in range(nsteps):
        U, V = step(tr.U[n], tr.V[n])
        scale = np.max(np.abs(tr.U[n])) + dt * np.max(np.abs(tr.V[n]))
        np.testing.assert_allclose(tr.U[n + 1], U, rtol=0, atol=1e-12 * scale, err_msg=str(n))
        np.testing.assert_allclose(tr.V[n + 1], V, rtol=0, atol=1e-12 * scale / dt,
                                   err_msg=str(n))


@pytest.mark.parametrize("predictor", ["none", "projected", "projected_klapproth"])
@pytest.mark.parametrize("scene", ["clamped_bar", "dropped_bar"])
def test_the_bar_kernel_is_the_sparse_step(scene: str, predictor: str) -> None:
    """The bar's tridiagonal kernel and the sparse kernel on the bar's CSR matrices take
    the same steps (round-off)."""
    from contact_bench.api.problem import as_problem, banded
    from contact_bench.kernels.kane import prepare_kane, prepare_kane_banded

    p = as_problem(problem_for(make_case(scene), make_scheme("kane"), 20), "consistent")
    dt, nsteps = 0.01, 300
    a = prepare_kane_banded(banded(p), dt, predictor).run(nsteps, 1)
    b = prepare_kane(p, dt, predictor).run(nsteps, 1)
    assert np.min(a.stress) < 0.0  # the runs hold contact
    scale = np.max(np.abs(b.U))
    np.testing.assert_allclose(a.U, b.U, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(a.stress, b.stress, rtol=1e-7, atol=1e-9 * np.max(np.abs(b.stress)))
    np.testing.assert_allclose(a.energy, b.energy, rtol=1e-10)
