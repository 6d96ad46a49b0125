"""restitution, moreau_jean, taylor_flanagan, ode_verlet, ode_adaptive against exact facts."""

from __future__ import annotations

import numpy as np
import pytest

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.cases.clamped_bar import ClampedBar, ClampedBarExact
from contact_bench.core.errors import BenchError
from contact_bench.harness.runner import run_one
from contact_bench.schemes.restitution import run_paoli_schatzman

E0 = 0.125  # clamped_bar's exact energy


def _energy_growth(run) -> float:
    E = run.trajectory.energy
    return float((E.max() - E[0]) / abs(E[0]))


# ----------------------------------------------------------------------- restitution
def test_restitution_e0_inelastic_e1_elastic():
    r0 = run_one("clamped_bar", "restitution", nx=40, dt=0.005)
    r1 = run_one("clamped_bar", "restitution[e=1]", nx=40, dt=0.005)
    for r in (r0, r1):
        assert r.row["status"] == "ok" and r.row["err_u_linf_l2"] < 0.1
    # e = 0: u0 >= 0 exactly, energy never grows and is lost at the impacts
    assert r0.row["penetration_max"] == 0.0
    assert _energy_growth(r0) < 1e-12
    loss0 = E0 - r0.trajectory.energy[-1]
    assert loss0 > 0.01 * E0
    # e = 1 loses nothing at impacts (here it even gains: declared "may grow"), and
    # penetrates by O(dt v) (impact speed v = 1/2), within its declared bound
    assert r1.trajectory.energy[-1] > r0.trajectory.energy[-1] + 0.5 * loss0
    assert 0 < r1.row["penetration_max"] <= 4 * 0.005 * 0.5


def test_restitution_massless_node_is_refused_and_its_blow_up_is_the_scheme():
    with pytest.raises(BenchError, match="needs a contact node with mass"):
        run_one("clamped_bar", "restitution[mass=getfem]")
    blow = {}
    for mass in ("lumped", "getfem"):
        semi = discretise(ClampedBar(), mesh_nodes(1.0, 20), mass)
        blow[mass] = run_paoli_schatzman(semi, 0.002, 3000, 50, 1.0, 0.25).blowup_time
    assert blow["lumped"] is None
    assert blow["getfem"] is not None and blow["getfem"] < 6.0


# ----------------------------------------------------------------------- moreau_jean
def test_moreau_jean_e0_penetration_bounded_and_not_growing():
    dt = 0.005
    r = run_one("clamped_bar", "moreau_jean", nx=40, dt=dt, T=12)
    tr = r.trajectory
    pen_first = -tr.contact_u[tr.t < 2.5].min()
    pen_all = r.row["penetration_max"]
    assert 0 <= pen_all <= 1.5 * dt * 0.5  # O(dt v) with the impact speed 1/2
    assert pen_all <= 2 * pen_first  # four impacts: no accumulation from one to the next
    assert _energy_growth(r) < 1e-10
    assert r.row["err_u_linf_l2"] < 0.1


def test_moreau_jean_e1_theta_half_conserves_energy():
    r = run_one("dropped_bar", "moreau_jean[e=1]", nx=50, dt=0.002)
    E = r.trajectory.energy
    assert np.abs(E - 500.0).max() / 500.0 < 1e-8  # exact energy (with gravity) is 500


# ------------------------------------------------------------------- taylor_flanagan
@pytest.mark.parametrize("mass", ["consistent", "lumped"])
def test_taylor_flanagan_stops_the_contact_node(mass):
    dt = 0.004
    r = run_one("clamped_bar", f"taylor_flanagan[mass={mass}]", nx=40, dt=dt, T=3)
    tr = r.trajectory
    assert r.row["penetration_max"] == 0.0
    # exact: u0 = 0 and v0 = 0 on (1, 2); the node is stopped within a step of t = 1
    inside = (tr.t > 1.1) & (tr.t < 1.9)
    assert np.abs(tr.contact_u[inside]).max() < 0.5 * dt
    step_velocity = np.diff(tr.contact_u) / np.diff(tr.t)
    assert np.abs(step_velocity[inside[1:]]).max() < 0.05  # 0.5 before the impact
    assert r.row["err_stress_l2"] < 0.5
    assert tr.energy.max() <= E0 * (1 + 0.1 * (dt * 40 * np.sqrt(3)) ** 2)


# ------------------------------------------------------------------------ ode_verlet
@pytest.mark.parametrize("nx", [40, 80])
def test_ode_verlet_agrees_with_redistributed_explicit(nx):
    a = run_one("clamped_bar", "ode_verlet", nx=nx, dt=0.5 / nx / np.sqrt(3), T=6)
    b = run_one("clamped_bar", "redistributed[beta=0]", nx=nx, dt=0.5 / nx / np.sqrt(3), T=6)
    # same update; they differ only by the start (ode_verlet relaxes node 0 at t = 0)
    assert np.abs(a.trajectory.U[1:] - b.trajectory.U[1:]).max() < 0.25 / nx
    assert a.row["err_u_linf_l2"] == pytest.approx(b.row["err_u_linf_l2"], rel=0.05)
    assert a.trajectory.contact_u.min() >= 0.0


def test_ode_verlet_converges_to_the_exact_solution():
    errs = [run_one("clamped_bar", "ode_verlet[variant=getfem]", nx=nx,
                    dt=0.5 / nx / np.sqrt(3), T=6, stride=2).row for nx in (20, 40, 80)]
    for key in ("err_u_linf_l2", "err_v_l2_l2", "err_stress_l2"):
        e = [r[key] for r in errs]
        assert e[0] > e[1] > e[2], (key, e)


def test_ode_verlet_is_second_order_in_time_against_dop853():
    ref = run_one("clamped_bar", "ode_adaptive[rtol=1e-11]", nx=20, dt=0.00125, T=3).trajectory
    diffs = []
    for dt in (0.005, 0.0025, 0.00125):
        tr = run_one("clamped_bar", "ode_verlet", nx=20, dt=dt, T=3).trajectory
        idx = np.rint(tr.t / 0.00125).astype(int)
        assert np.allclose(ref.t[idx], tr.t)
        diffs.append(np.abs(tr.U - ref.U[idx]).max())
    assert diffs[0] / diffs[1] > 3 and diffs[1] / diffs[2] > 3.5, diffs


def _cfl_of_largest_mode(semi, in_contact: bool) -> float:
    """2 / omega_max as a CFL number, omega_max^2 the largest generalized eigenvalue of
    (K_bar, M_bar) on the nodes 1.. with u0 = 0 (in contact) or u0 = u0(u1) (free: the
    Schur complement of K00); sparse, independent of the declared formula."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import eigsh

    M = semi.M.to_sparse().tocsr()[1:, 1:]
    K = semi.K.to_sparse().tolil()
    if not in_contact:
        K[1, 1] = K[1, 1] - K[0, 1] ** 2 / K[0, 0]
    K = sp.csr_matrix(K)[1:, 1:]
    lam = eigsh(K.tocsc(), k=1, M=M.tocsc(), which="LA", tol=1e-12)[0][0]
    return float(2.0 / np.sqrt(lam) * semi.c_max / semi.hmin)


@pytest.mark.parametrize("spec", ["ode_verlet", "ode_verlet[variant=getfem]",
                                  "ode_verlet[variant=conservative]",
                                  "redistributed[beta=0]"])
def test_massless_explicit_limit_is_below_both_contact_states(spec):
    """The declared CFL limit holds in contact and off it; for the seed mass the
    contact state binds (0.556, not the consistent mass's 0.577)."""
    from contact_bench.api.registry import make_scheme

    scheme = make_scheme(spec)
    semi = discretise(ClampedBar(), mesh_nodes(1.0, 40), scheme.mass_kind())
    declared = scheme.stability_limit(semi) * semi.c_max / semi.hmin
    true = min(_cfl_of_largest_mode(semi, True), _cfl_of_largest_mode(semi, False))
    assert declared <= true
    assert declared > 0.99 * true  # and it is the limit, not a loose bound


def test_ode_verlet_seed_stable_below_and_blows_up_above_its_limit():
    """The published study's contradiction: CFL 0.574 blew up at t = 9.77 while 0.577
    was declared. With the seed mass's limit 0.556: 0.98 x stays stable over the
    stability study's long run (T = 36), 1.03 x blows up."""
    nx = 40
    scheme = "ode_verlet"
    case = ClampedBar()
    from contact_bench.api.registry import make_scheme

    sch = make_scheme(scheme)
    semi = discretise(case, mesh_nodes(1.0, nx), sch.mass_kind())
    limit = sch.stability_limit(semi)
    assert limit * semi.c_max / semi.hmin == pytest.approx(0.5562, abs=2e-4)
    below = run_one("clamped_bar", scheme, nx=nx, dt=0.98 * limit, T=36, stride=50)
    assert below.row["status"] == "ok"
    assert _energy_growth(below) < 0.1
    above = run_one("clamped_bar", scheme, nx=nx, dt=1.03 * limit, T=36, stride=50,
                    allow_unstable=True)
    assert above.row["status"] == "unstable"


# ---------------------------------------------------------------------- ode_adaptive
def test_ode_adaptive_is_the_time_reference():
    nx = 40
    dt = 0.9 / nx / np.sqrt(3)  # ode_verlet at 0.9 x its stability limit
    v = run_one("clamped_bar", "ode_verlet", nx=nx, dt=dt, T=6)
    r = run_one("clamped_bar", "ode_adaptive[rtol=1e-10]", nx=nx, dt=dt, T=6)
    assert r.row["steps"] == v.row["steps"]  # dt is only the sampling interval
    assert r.trajectory.extra["nfev"] > 0
    # errors are dominated by space; the time error of DOP853 is negligible
    assert r.row["err_u_linf_l2"] < v.row["err_u_linf_l2"]
    assert r.row["err_stress_l2"] < v.row["err_stress_l2"]
    assert r.row["energy_drift_max"] < 1e-7
    # and it is exact at the sample times: u(0, t) against the closed form before the impact
    ex = ClampedBarExact()
    early = r.trajectory.t < 0.9
    np.testing.assert_allclose(r.trajectory.contact_u[early], ex.u(0.0, r.trajectory.t[early]),
                               atol=0.6 / nx)
