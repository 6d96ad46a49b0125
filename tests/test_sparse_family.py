"""hht, ode_verlet and ode_adaptive on the general sparse problem
(`contact_bench.kernels.sparse.newmark_sparse` with alpha,
`contact_bench.kernels.sparse_family`): exact contact and complementarity, the energy
behaviour each declares, the stability limit, the embedded bar and the disc drop."""

from __future__ import annotations

import numpy as np
import pytest
import skfem as fe

from contact_bench.api import fem_nd
from contact_bench.api.problem import BarScale
from contact_bench.api.registry import make_case, make_scheme
from contact_bench.api.sparse import ContactSet, SparseProblem
from contact_bench.harness.runner import run_one
from contact_bench.kernels.sparse_family import massless_ode_omega

SPECS = ("hht", "ode_verlet", "ode_adaptive")


def _disc(mass: str = "redistributed") -> SparseProblem:
    """A small P1 disc (radius 1, E = 50, nu = 0.25) lifted 0.05 above y = 0 and
    falling (g = 1): contact from t ~ 0.32 on, five contact dofs, all massless."""
    body = fem_nd.assemble(fe.MeshTri1.init_circle(2), 50.0, 0.25, 1.0)
    X = body.dof_coordinates
    cs = np.unique(body.scalar.get_dofs(body.boundary_facets(lambda x: x[1] < -0.6)).flatten())
    M = fem_nd.mass_matrix(body, mass, cs)
    F = fem_nd.body_force(M, 2, np.array([0.0, -1.0]))
    U0 = np.zeros(body.ndofs)
    U0[1::2] = 0.05
    return SparseProblem(M=M, K=body.K, F=F, U0=U0, V0=np.zeros(body.ndofs),
                         contact=ContactSet(2 * cs + 1, X[1, cs] + 1.0, np.ones(cs.size)),
                         dim=2, hmin=body.hmin, c_max=body.wave_speed)


def _run(spec: str, p: SparseProblem):
    """(scheme, dt, trajectory sampled at every step over t in [0, 1.5])."""
    scheme = make_scheme(spec)
    dt = 0.01
    limit = scheme.stability_limit(p)
    if limit is not None:
        dt = 0.9 * limit
    return scheme, dt, scheme.integrate(p, dt, int(1.5 / dt), 1)


@pytest.mark.parametrize("spec", SPECS)
def test_exact_contact_complementarity_and_declared_energy(spec):
    p = _disc()
    scheme, dt, tr = _run(spec, p)
    assert tr.blowup_time is None and tr.steps_done >= 100
    assert tr.extra["first_contact_start"] == pytest.approx(0.32, abs=0.02)
    gaps = p.gaps(tr.U)
    assert gaps.min() >= -1e-13 and tr.min_contact_u >= -1e-13  # exact contact
    # the obstacle's force from the massless contact rows (no inertia there), an
    # independent reading of the trajectory: (K U - F) for the ODE, HHT's weighted
    # (1 + alpha) K U1 - alpha K U0 - F at t_{n+1}
    KU = (p.K @ tr.U.T).T
    if spec == "hht":
        a = scheme.alpha
        lam = ((1 + a) * KU[1:] - a * KU[:-1] - p.F)[:, p.contact.dofs]
        g = gaps[1:]
        stress = tr.stress[1:]
    else:  # sample 0 too: the massless dofs start on their quasi-static solution
        lam = (KU - p.F)[:, p.contact.dofs]
        g = gaps
        stress = tr.stress
    scale = np.abs(lam).max()
    assert scale > 1.0  # a real impact
    assert lam.min() > -1e-9 * scale
    assert np.abs(lam * g).max() < 1e-9 * scale * 0.05  # complementarity
    np.testing.assert_allclose(stress, -lam.sum(axis=1) / p.contact.weights.sum(),
                               rtol=0, atol=1e-9 * scale)
    # the declared energy behaviour
    E = tr.energy
    traits = scheme.traits()
    if traits.energy == "dissipated":  # hht: never grows, and loses some
        assert E.max() <= E[0] + 1e-12 * abs(E[0])
        assert E[-1] < E[0] * (1 - 1e-4)
    else:
        assert traits.energy == "conserved"
        bound = scheme.energy_drift_bound(p, dt)
        assert np.abs(E - E[0]).max() <= bound * abs(E[0])


@pytest.mark.parametrize("spec", ["ode_verlet", "ode_adaptive"])
def test_massless_velocity_is_the_derivative_of_the_quasistatic_dofs(spec):
    """v_m solves K_mm v_m = -K_mh v_h off the obstacle and is 0 on it (the 1D v0 =
    -(K01 / K00) v1, or 0), unlike the backward difference of redistributed[beta=0]."""
    p = _disc()
    _, _, tr = _run(spec, p)
    free = p.massless.copy()
    on = p.gaps(tr.U) == 0.0  # on the obstacle (set exactly)
    assert on.any() and (~on).any()
    KV = (p.K @ tr.V.T).T
    scale = np.abs(KV).max()
    for k in range(tr.t.size):
        rows = free.copy()
        rows[p.contact.dofs[on[k]]] = False
        assert np.abs(KV[k, rows]).max() < 1e-9 * scale
        assert np.all(tr.V[k, p.contact.dofs[on[k]]] == 0.0)


def test_hht_momentum_balance_with_its_gamma():
    """The vertical momentum p = 1_y.M.V changes by dt ((1 - gamma) f_n + gamma f_{n+1}),
    f = the load's resultant plus the contact force (K's kernel holds translations):
    HHT's balance, to round-off (as the row's impulse_residual, from the kernel's impulse)."""
    p = _disc()
    scheme, dt, tr = _run("hht", p)
    up = np.tile([0.0, 1.0], p.nfree // 2)
    mom = tr.V @ (p.M @ up)
    f = (p.F @ up) - tr.stress * p.contact.weights.sum()
    g = scheme.gamma
    res = np.diff(mom) - dt * ((1 - g) * f[:-1] + g * f[1:])
    assert np.abs(res).max() < 1e-10 * dt * np.abs(f).max()


@pytest.mark.parametrize("spec", ["ode_verlet", "redistributed[beta=0]"])
def test_explicit_massless_stability_limit_is_the_sparse_problems(spec):
    """The declared limit on the sparse problem: stable at 0.95 x, blown up at 1.05 x
    (the 1D formula at the problem's hmin is 3.5 x too large on the P2 disc)."""
    scheme = make_scheme(spec)
    p = make_case("disc_drop").sparse_problem(3, 1.0, scheme.mass_kind())
    limit = scheme.stability_limit(p)
    assert scheme.stability_limit(BarScale(p.hmin, p.c_max)) > 3 * limit
    stable = run_one("disc_drop", spec, nx=3, T=40, dt=0.95 * limit).row
    assert stable["status"] == "ok"
    blown = run_one("disc_drop", spec, nx=3, T=40, dt=1.05 * limit, allow_unstable=True).row
    assert blown["status"] == "unstable"


def test_massless_ode_omega_against_dense_eigenvalues():
    """omega_max against a dense generalized eigenproblem of both contact states on a
    small disc: the pinned state's (every contact dof on the obstacle) is the larger."""
    import scipy.linalg as sl

    p = _disc()
    K, M = p.K.toarray(), p.M.toarray()
    hv = np.flatnonzero(~p.massless)

    def omega(kept):
        S = K[np.ix_(hv, hv)] - K[np.ix_(hv, kept)] @ np.linalg.solve(
            K[np.ix_(kept, kept)], K[np.ix_(kept, hv)])
        return np.sqrt(sl.eigh(S, M[np.ix_(hv, hv)], eigvals_only=True).max())

    pinned = omega(np.setdiff1d(np.flatnonzero(p.massless), p.contact.dofs))
    assert massless_ode_omega(p) == pytest.approx(pinned, rel=1e-8)
    assert omega(np.flatnonzero(p.massless)) < pinned


def test_massless_ode_omega_is_the_same_at_every_call():
    """A declared limit, and the dt taken from it, must not move between calls or runs:
    ARPACK's own random start vector moved omega_max in its last digits from one call to
    the next (the 3D Hertz ball's limit took three values in four calls)."""
    p = make_case("hertz_sphere").sparse_problem(4, 1.0, "first_element_massless")
    first = massless_ode_omega(p)
    assert all(massless_ode_omega(p) == first for _ in range(4))


@pytest.mark.parametrize("spec, free_fall, impulse", [
    ("hht", 1e-10, 1e-8),  # the kernel's impulse, with HHT's gamma
    ("ode_verlet", 1e-10, 1e-10),
    # the impulse integrated with the state; the free fall to DOP853's global error, a
    # few ten times rtol (2.2e-10 with the local redistribution)
    ("ode_adaptive[rtol=1e-11]", 1e-9, 1e-10),
])
def test_disc_drop_runs(spec, free_fall, impulse):
    row = run_one("disc_drop", spec, nx=3, T=40).row
    assert row["status"] == "ok", row["notes"]
    assert row["err_free_fall"] < free_fall
    assert 0.0 < row["impulse_residual"] < impulse
    assert row["penetration_max"] == 0.0 and row["symmetry_defect"] < 1e-6


def test_ode_adaptive_embedded_bar_reproduces_the_1d_row():
    """At a tight tolerance (the error norms of DOP853 differ with the number of
    components, so the steps differ: agreement at the tolerance's level)."""
    spec = "ode_adaptive[rtol=1e-12]"
    a = run_one("dropped_bar", spec, nx=16, T=2.0, dt=2.1e-3).row
    b = run_one("embedded_bar[of=dropped_bar,dim=2]", spec, nx=16, T=2.0, dt=2.1e-3).row
    assert a["status"] == b["status"] == "ok"
    for col in ("err_u_linf_l2", "err_u_l2_h1", "err_v_l2_l2", "err_stress_l2"):
        assert b[col] == pytest.approx(a[col], rel=1e-9), col
    assert b["energy_drift_max"] == pytest.approx(a["energy_drift_max"], abs=1e-10)
    assert b["penetration_max"] <= 1e-12


def test_the_massless_ode_needs_massless_contact_dofs():
    with pytest.raises(ValueError, match="massless"):
        make_scheme("ode_verlet").integrate(_disc("consistent"), 0.01, 2, 1)
