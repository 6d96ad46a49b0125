"""Impact laws on the sparse problem (`contact_bench.kernels.sparse_impact`): restitution
(Paoli-Schatzman) and moreau_jean. Each law is checked on the trajectory itself: the
per-step contact force or impulse is recovered from the scheme's equation of motion
(an independent computation from U and V) and must sit on the contact dofs, be >= 0
and be complementary to the constrained quantity. The embedded bar's rows against 1D
are in tests/test_sparse.py (`SCHEMES`)."""

from __future__ import annotations

import numpy as np
import pytest

from contact_bench.api.problem import BarScale
from contact_bench.api.registry import make_case
from contact_bench.harness.runner import run_one
from contact_bench.kernels.sparse_impact import moreau_jean_sparse, paoli_schatzman_sparse

DT = 0.01  # disc_drop's default; the impact is at t = 10 (lift 5, g 0.1)


def _disc(degree: int, mass: str, lift: float = 0.2):
    """A small disc (2 rings) dropped from `lift`: impact at sqrt(2 lift / g)."""
    return make_case(f"disc_drop[degree={degree},lift={lift}]").sparse_problem(2, 1.0, mass)


def _off_contact(p, r: np.ndarray) -> np.ndarray:
    mask = np.ones(p.nfree, bool)
    mask[p.contact.dofs] = False
    return r[:, mask]


@pytest.mark.parametrize(("degree", "mass", "e"), [(1, "lumped", 0.0), (1, "lumped", 0.5),
                                                   (2, "consistent", 0.0),
                                                   (2, "consistent", 0.5)])
def test_paoli_schatzman_law_holds_on_every_contact_dof(degree, mass, e):
    p = _disc(degree, mass)
    nsteps = 600  # impact at t = 2, contact over until t = 6
    tr = paoli_schatzman_sparse(p, DT, nsteps, 1, e, 0.0)
    assert tr.blowup_time is None and tr.steps_done == nsteps
    assert tr.extra["first_contact_start"] < 3.0
    U = tr.U
    g = p.gaps(U)
    scale = float(np.max(np.abs(U)))
    # the force r^n from M (U^{n+1} - 2 U^n + U^{n-1}) / dt^2 + K U^n - F = C^T r^n
    acc = (U[2:] - 2.0 * U[1:-1] + U[:-2]) / DT**2
    r = (p.M @ acc.T).T + (p.K @ U[1:-1].T).T - p.F
    rscale = float(np.max(np.abs(r[:, p.contact.dofs])))
    assert rscale > 0.0
    assert np.max(np.abs(_off_contact(p, r))) < 1e-6 * rscale
    rc = r[:, p.contact.dofs]
    comb = g[2:] + e * g[:-2]  # the constrained combination, levels n + 1 and n - 1
    assert comb.min() >= -1e-12 * scale
    assert rc.min() >= -1e-6 * rscale
    pushed = rc > 1e-6 * rscale  # complementarity: a force only on the constraint
    assert pushed.any() and np.abs(comb[pushed]).max() <= 1e-12 * scale
    assert np.abs(rc[comb > 1e-9 * scale]).max() <= 1e-6 * rscale
    if e == 0.0:
        assert g.min() >= -1e-12 * scale  # the gaps themselves at every step
    # the sampled stress is -r^n over the contact area
    area = float(np.sum(p.contact.weights))
    assert np.allclose(-tr.stress[1:-1] * area, rc.sum(axis=1), rtol=1e-6, atol=1e-6 * rscale)


@pytest.mark.parametrize("e", [0.0, 0.5])
def test_moreau_jean_newton_law_on_velocities(e):
    p = _disc(2, "consistent")
    theta, nsteps = 0.5, 600
    tr = moreau_jean_sparse(p, DT, nsteps, 1, e, theta)
    assert tr.blowup_time is None
    U, V = tr.U, tr.V
    # the impulse P^{n+1} = M (V^{n+1} - V^n) - dt (F - K (theta U^{n+1} + (1-theta) U^n))
    Um = theta * U[1:] + (1.0 - theta) * U[:-1]
    P = (p.M @ (V[1:] - V[:-1]).T).T - DT * (p.F - (p.K @ Um.T).T)
    pc = P[:, p.contact.dofs]
    pscale = float(np.max(np.abs(pc)))
    assert pscale > 0.0
    assert np.max(np.abs(_off_contact(p, P))) < 1e-8 * pscale
    assert pc.min() >= -1e-8 * pscale
    vd = V[:, p.contact.dofs]
    law = vd[1:] + e * vd[:-1]
    predicted = (p.gaps(U) + 0.5 * DT * vd)[:-1] <= 0.0  # the index set of each step
    vscale = float(np.max(np.abs(vd)))
    assert law[predicted].min() >= -1e-10 * vscale
    assert np.max(np.abs(pc * law)) < 1e-8 * pscale * vscale
    assert np.all(np.abs(pc[~predicted]) < 1e-8 * pscale)
    # velocity level: the penetration is O(dt v), v = sqrt(2 g lift) = 0.2 (the 1D
    # scheme's declared bound: 4 dt v)
    assert 0.0 < -p.gaps(U).min() <= 4.0 * DT * 0.2
    # the sampled stress is the impulse over dt
    area = float(np.sum(p.contact.weights))
    assert np.allclose(-tr.stress[1:] * area, pc.sum(axis=1) / DT, rtol=1e-6,
                       atol=1e-6 * pscale / DT)
    # theta = 1/2: the step conserves the energy but for the impulse's work,
    # E^{n+1} - E^n = P.(V^{n+1} + V^n) / 2 exactly; that work is <= 0 on a dof moving
    # in (v^n <= 0) and may be > 0 on one in the index set moving out, so single steps
    # can gain a little (measured: 7e-6 E0 at e = 0.5): the run dissipates, E <= E0
    E = tr.energy
    work = np.sum(P * (V[1:] + V[:-1]), axis=1) / 2.0
    assert np.max(np.abs(np.diff(E) - work)) < 1e-12 * E[0]
    assert E.max() <= E[0] * (1.0 + 1e-12)
    assert E[-1] < E[0] * (1.0 - 1e-3)


def test_moreau_jean_elastic_conserves_the_energy():
    p = _disc(2, "consistent")
    tr = moreau_jean_sparse(p, DT, 600, 1, 1.0, 0.5)
    assert tr.extra["chatter"] > 0
    assert np.max(np.abs(tr.energy - tr.energy[0])) < 1e-8 * tr.energy[0]  # declared bound


COLUMNS = ("status", "err_free_fall", "impulse_residual", "energy_initial", "energy_final",
           "energy_drift_max", "penetration_max", "first_contact_start")


@pytest.mark.parametrize("scheme", ["restitution[mass=consistent]", "moreau_jean",
                                    "moreau_jean[e=1]"])
def test_disc_drop_rows(scheme):
    row = run_one("disc_drop", scheme, nx=3, T=40.0).row
    r = {c: row[c] for c in COLUMNS}
    assert r["status"] == "ok", row["notes"]
    assert r["err_free_fall"] < 1e-10, r
    assert r["first_contact_start"] == pytest.approx(10.0, abs=0.011)
    if scheme.startswith("restitution"):  # position level: exact contact, exact impulse
        assert r["impulse_residual"] < 1e-8 and r["penetration_max"] == 0.0, r
    else:  # velocity level: O(dt v) penetration, v = 1 (declared in 1D: 4 dt v)
        assert 0.0 < r["penetration_max"] <= 4.0 * DT, r
    if scheme == "moreau_jean[e=1]":
        assert r["energy_drift_max"] < 1e-8, r
    else:  # inelastic impact: dissipated
        assert r["energy_final"] < r["energy_initial"] * (1 - 1e-3), r


def test_what_cannot_run_says_why():
    for case in ("disc_drop", "hertz_sphere", "sphere_drop[degree=2]"):
        row = run_one(case, "restitution", nx=3, T=1.0).row  # lumped by default
        assert row["status"] == "not applicable" and "P2" in row["notes"], case
    # explicit on the axisymmetric P2 mesh: unstable at 0.9 x the 1D formula's limit, a
    # blow-up row rather than NaNs handed to the contact solver; the declared (mesh's)
    # limit lowers the default dt below it
    from contact_bench.api.registry import make_scheme

    spec = "restitution[mass=consistent]"
    p = make_case("hertz_sphere").sparse_problem(8, 1.0, "consistent")
    dt1 = 0.9 * make_scheme(spec).stability_limit(BarScale(p.hmin, p.c_max))
    row = run_one("hertz_sphere", spec, T=1.0, dt=dt1, allow_unstable=True).row
    assert row["status"] == "unstable" and row["blowup_time"] < 1.0, row["notes"]
    row = run_one("hertz_sphere", spec, T=1.0).row
    assert row["status"] == "ok" and row["dt"] < dt1 and "lowered" in row["notes"]
    with pytest.raises(ValueError, match="massless"):
        paoli_schatzman_sparse(_disc(2, "redistributed"), DT, 2, 1, 0.0, 0.0)
    with pytest.raises(ValueError, match="massless"):
        moreau_jean_sparse(_disc(2, "redistributed"), DT, 2, 1, 0.0, 0.5)


@pytest.mark.parametrize(("case", "spec", "nx", "T"), [
    ("hertz_sphere", "restitution[mass=consistent]", 4, 20.0),  # the LCP path, P2
    ("disc_drop[degree=1]", "restitution", 3, 80.0),  # the per-dof projection, lumped P1
])
def test_restitution_sparse_stability_limit_is_the_meshs(case, spec, nx, T):
    """The explicit two-step scheme's declared limit on the sparse problem, from the
    mesh's largest eigenvalue: stable at 0.95 x, blown up at 1.05 x (the 1D formula at the
    problem's hmin is above the blow-up); beta = 0.1 scales it by 1 / sqrt(1 - 4 beta),
    beta = 1/4 has none, as in 1D."""
    from contact_bench.api.registry import make_scheme

    scheme = make_scheme(spec)
    p = make_case(case).sparse_problem(nx, 1.0, scheme.mass_kind())
    limit = scheme.stability_limit(p)
    assert scheme.stability_limit(BarScale(p.hmin, p.c_max)) > 1.3 * limit
    stable = run_one(case, spec, nx=nx, T=T, dt=0.95 * limit).row
    assert stable["status"] == "ok" and stable["energy_drift_max"] < 0.1
    blown = run_one(case, spec, nx=nx, T=T, dt=1.05 * limit, allow_unstable=True).row
    assert blown["status"] == "unstable"
    beta = make_scheme(spec.replace("]", ",beta=0.1]") if "[" in spec else spec + "[beta=0.1]")
    assert beta.stability_limit(p) == pytest.approx(limit / np.sqrt(0.6), rel=1e-6)
    assert make_scheme(spec.replace("]", ",beta=0.25]") if "[" in spec
                       else spec + "[beta=0.25]").stability_limit(p) is None
