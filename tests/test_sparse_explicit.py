"""The explicit sparse paths: penalty and nitsche with beta = 0, taylor_flanagan
with a consistent mass, their declared stability limit on the mesh, and the peak contact
force of the law paths against the sampled stress."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case, make_scheme
from contact_bench.harness.runner import run_one
from contact_bench.kernels.sparse import central_sparse
from contact_bench.kernels.sparse_explicit import (
    SMALL_DENSE,
    omega_max_squared,
    penalty_law,
    taylor_flanagan_sparse,
)

DISC = "disc_drop[degree=1]"


def _problem(case: str, scheme: str, nx: int):
    sch = make_scheme(scheme)
    p = make_case(case).sparse_problem(nx, 1.0, sch.mass_kind())
    p.check()
    return sch, p


@pytest.mark.parametrize("case", [DISC, "embedded_bar[of=dropped_bar,dim=2]"])
@pytest.mark.parametrize("scheme", ["penalty", "penalty[beta=0]", "nitsche",
                                    "nitsche[beta=0,theta=-1]", "penalty[beta=0,mass=getfem]"])
def test_peak_contact_force_is_the_largest_sampled_force(case, scheme):
    """Every step sampled: the peak force (from the per-step forces) is the largest
    -stress x area of the samples (the stress from the state after the step)."""
    sch, p = _problem(case, scheme, 3 if case == DISC else 8)
    T, dt = (14.0, 0.01) if case == DISC else (2.0, 2.1e-3)
    tr = sch.integrate(p, dt, int(round(T / dt)), 1)
    assert tr.steps_done == int(round(T / dt)) and np.all(np.isfinite(tr.energy))
    sampled = float(np.max(-tr.stress * np.sum(p.contact.weights)))
    assert sampled > 0.0  # the body hit the obstacle
    assert tr.extra["peak_contact_force"] == pytest.approx(sampled, rel=1e-12)


#: (scheme, largest relative energy drift over the disc's impact: the declared
#: `Energy.CONSERVED` ones only)
DISC_SCHEMES = ["penalty[beta=0]", "penalty[beta=0,mass=lumped]", "penalty[beta=0,mass=getfem]",
                "nitsche[beta=0]", "nitsche[beta=0,theta=0]", "nitsche[beta=0,theta=-1]",
                "taylor_flanagan", "taylor_flanagan[mass=lumped]"]


@pytest.mark.parametrize("scheme", DISC_SCHEMES)
def test_explicit_sparse_paths_on_the_disc(scheme):
    """No NaN; the penalty's penetration within its energy bound (1D's, with the
    smallest spring of the zone, the weight of the disc and twice the initial energy);
    exact contact where declared; no drift where conservation is declared."""
    row = run_one(DISC, scheme, nx=3, T=20.0, step_repeats=1).row
    assert row["status"] == "ok", row["notes"]
    sch, p = _problem(DISC, scheme, 3)
    traits = sch.traits()
    assert np.isfinite(row["energy_drift_max"]) and row["peak_contact_force"] > 0
    if traits.contact.value == "exact":
        assert row["penetration_max"] <= 1e-12 * 5.0
    if scheme.startswith("penalty"):
        kappa = sch.gamma_p * p.E_contact / p.h_contact * np.min(p.contact.weights)
        W, gm = 2.0 * abs(p.energy(p.U0, p.V0)), abs(float(np.sum(p.F)))
        bound = (gm + np.sqrt(gm * gm + 2.0 * kappa * W)) / kappa
        assert 0.0 < row["penetration_max"] <= bound
    if traits.energy.value == "conserved":
        assert row["energy_drift_max"] < 1e-4


def test_taylor_flanagan_sparse_with_a_diagonal_mass_is_central_sparse():
    """With a lumped M the Delassus matrix is diagonal: each dof is stopped on its own,
    the LCP's answer is central_sparse's (the same trajectory up to round-off)."""
    _, p = _problem(DISC, "taylor_flanagan[mass=lumped]", 3)
    a = central_sparse(p, 0.01, 1400, 7)
    b = taylor_flanagan_sparse(p, 0.01, 1400, 7)
    assert b.extra["chatter"] == a.extra["chatter"] > 0
    scale = float(np.max(np.abs(a.U)))
    assert np.max(np.abs(a.U - b.U)) <= 1e-9 * scale
    assert b.min_contact_u >= -1e-12 * scale


def test_the_eigenvalue_limit_is_the_dense_one():
    """ARPACK's omega_max^2 (massless dofs eliminated, springs all active) against a
    dense generalized eigensolver on a small embedded bar."""
    for scheme in ("penalty[beta=0]", "penalty[beta=0,mass=getfem]"):
        sch, p = _problem("embedded_bar[of=clamped_bar,dim=2]", scheme, 16)
        assert np.count_nonzero(~p.massless) > SMALL_DENSE  # ARPACK, not the dense path
        law = penalty_law(p, sch.gamma_p * p.E_contact / p.h_contact * p.contact.weights)
        K = (p.K + law.Q.T @ sp.diags(law.c) @ law.P).toarray()
        M = p.M.toarray()
        m = p.massless
        h = ~m
        Ks = K[np.ix_(h, h)]
        if m.any():
            Ks = Ks - K[np.ix_(h, m)] @ np.linalg.solve(K[np.ix_(m, m)], K[np.ix_(m, h)])
        dense = float(np.max(sla.eigh(Ks, M[np.ix_(h, h)], eigvals_only=True)))
        assert omega_max_squared(p, law) == pytest.approx(dense, rel=1e-6), scheme


#: (scene, nx, T): stable at 0.95 x the declared limit, growing at 1.05 x (drift over 100 %)
STABILITY = [("embedded_bar[of=clamped_bar,dim=2]", 16, 10.0, "penalty[beta=0]"),
             ("embedded_bar[of=clamped_bar,dim=2]", 16, 10.0, "nitsche[beta=0,theta=-1]"),
             ("embedded_bar[of=clamped_bar,dim=2]", 16, 10.0, "taylor_flanagan"),
             (DISC, 3, 40.0, "penalty[beta=0]"), (DISC, 3, 40.0, "penalty[beta=0,mass=getfem]"),
             (DISC, 3, 40.0, "taylor_flanagan[mass=lumped]"),
             ("disc_drop", 3, 40.0, "taylor_flanagan")]


@pytest.mark.parametrize(("case", "nx", "T", "scheme"), STABILITY)
def test_declared_sparse_limit_is_the_stability_edge(case, nx, T, scheme):
    sch, p = _problem(case, scheme, nx)
    limit = sch.stability_limit(p)
    below = run_one(case, scheme, nx=nx, T=T, dt=0.95 * limit, step_repeats=1).row
    above = run_one(case, scheme, nx=nx, T=T, dt=1.05 * limit, allow_unstable=True,
                    step_repeats=1).row
    assert below["status"] == "ok" and below["energy_drift_max"] < 0.2
    assert above["status"] == "unstable" or above["energy_drift_max"] > 1.0


NEW_1D_SCHEMES = ["penalty[beta=0]", "penalty[beta=0,mass=getfem]", "nitsche[beta=0,theta=1]",
                  "nitsche[beta=0,theta=0]", "nitsche[beta=0,theta=-1]",
                  "nitsche[beta=0,mass=getfem]", "taylor_flanagan"]


@pytest.mark.parametrize("scheme", NEW_1D_SCHEMES)
def test_embedded_bar_keeps_the_1d_declared_bounds(scheme):
    """On the embedded dropped bar (2D) the new explicit paths stay within the bounds the
    scheme declares for the 1D bar (`penetration_bound`, `energy_drift_bound`)."""
    nx, T, dt = 16, 2.0, 2.1e-3
    row = run_one("embedded_bar[of=dropped_bar,dim=2]", scheme, nx=nx, T=T, dt=dt,
                  step_repeats=1).row
    assert row["status"] == "ok", row["notes"]
    sch, bar = make_scheme(scheme), make_case("dropped_bar")
    semi = discretise(bar, mesh_nodes(float(bar.L), nx), sch.mass_kind())
    slack = 1e-12 * float(np.max(np.abs(semi.U0)))
    assert row["penetration_max"] <= sch.penetration_bound(semi, dt) + slack
    drift = sch.energy_drift_bound(semi, dt)
    if drift is not None:
        assert row["energy_drift_max"] <= drift


def test_taylor_flanagan_blowing_up_between_samples_is_an_unstable_row():
    """At twice its limit on the graded sphere the consistent Taylor-Flanagan step goes
    non-finite between samples: the row says unstable (it raised in the LCP before)."""
    row = run_one("hertz_sphere", "taylor_flanagan", nx=2, dt=0.0131, allow_unstable=True).row
    assert row["status"] == "unstable", row["notes"]
