"""Coulomb friction: the shared solver's law, the frictional schemes on `sliding_block`,
mu = 0 bit for bit the frictionless run, and the refusal of the schemes without friction.

The solver's answers are checked against the law's conditions themselves (complementarity,
the cone, the slip's direction), not against another run of the solver. The sliding
block's momentum identity d(p_t + mu p_n) = dt m g (sin - mu cos) holds step by step
while every contact point slides (cases/sliding_block.py); with mu > tan(angle) the block
sticks, and its tangential momentum stays within the elastic vibration's bound
sqrt(m F.K_c^-1 F) (K_c: the stiffness with the contact nodes held; the kinetic energy
of a body started at rest under a constant load is at most F.K_c^-1 F / 2), computed here
by scipy, independently of the schemes, over T = 1 (the soft block later hops off the
plane and walks downhill: docs/contact.md).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.harness import run_one
from contact_bench.harness.impacts import tangential_impulse_residual
from contact_bench.kernels.kane import FrictionalKaneStepper
from contact_bench.kernels.solvers import coulomb_solve, penalty_coulomb_solve
from contact_bench.kernels.sparse import FrictionalNewmarkStepper
from contact_bench.kernels.sparse_impact import FrictionalMoreauJeanStepper


def _newmark(sch, p, dt):
    return FrictionalNewmarkStepper(p, dt, sch.beta, sch.gamma)


#: the frictional schemes (Traits.friction) with their frictional stepper forced on a
#: problem: mu = 0 runs it too, beside the frictionless path (None: penalty and nitsche,
#: whose frictional step iterates where the frictionless one solves the active set exactly)
FRICTIONAL = {"moreau_jean": lambda sch, p, dt: FrictionalMoreauJeanStepper(p, dt, sch.e,
                                                                            sch.theta),
              "standard": _newmark, "redistributed": _newmark, "penalty": None, "nitsche": None,
              "contact_stabilized": lambda sch, p, dt: FrictionalKaneStepper(
                  p, dt, "projected_klapproth")}
#: the schemes that hold a stuck contact exactly (the stick bound's clamped nodes);
#: penalty's springs and nitsche's term let the nodes move (docs/contact.md: their
#: stick measurements; tests/test_friction_schemes.py: nitsche's)
EXACT_STICK = ("moreau_jean", "standard", "redistributed", "contact_stabilized")
NX, T = 2, 1.0


def _law_violation(W, q, mu, thr, r, nt):
    """The largest violation of Signorini and Coulomb / Tresca by r (u = q + W r)."""
    nc = mu.size
    u = q + W @ r
    rn, un = r[:nc], u[:nc]
    rt, ut = r[nc:].reshape(nc, nt), u[nc:].reshape(nc, nt)
    bound = thr + mu * rn
    nrt, nut = np.linalg.norm(rt, axis=1), np.linalg.norm(ut, axis=1)
    err = max(np.max(-np.minimum(un, 0)), np.max(-np.minimum(rn, 0)),
              np.max(np.abs(un * rn)), np.max(nrt - bound))
    for j in range(nc):
        if nrt[j] < bound[j] - 1e-9:  # inside the bound: stuck
            err = max(err, nut[j])
        elif nut[j] > 1e-12:  # on it: against the slip
            err = max(err, np.linalg.norm(rt[j] + bound[j] * ut[j] / nut[j]))
    return err


@pytest.mark.parametrize("nt", [1, 2])
@pytest.mark.parametrize("tresca", [False, True])
def test_coulomb_solve_satisfies_the_law(nt, tresca):
    rng = np.random.default_rng(nt + 2 * tresca)
    for _ in range(60):
        nc = int(rng.integers(1, 6))
        n = nc * (nt + 1)
        B = rng.standard_normal((n, n))
        W = B @ B.T + 0.5 * np.eye(n)
        q = rng.standard_normal(n)
        mu = np.zeros(nc) if tresca else rng.uniform(0.0, 1.0, nc)
        thr = rng.uniform(0.0, 1.0, nc) if tresca else np.zeros(nc)
        r, status = np.zeros(n), np.zeros(nc, np.int64)
        assert coulomb_solve(W, q, mu, thr, r, status, 1e-13) > 0
        assert _law_violation(W, q, mu, thr, r, nt) <= 1e-8


@pytest.mark.parametrize("nt", [1, 2])
def test_every_point_is_inside_its_disc_to_round_off(nt):
    """Whatever sweep the solvers stop at, each point's tangential reaction is inside (or
    on) its own disc |r_t| <= mu r_n to round-off (1e-14 of the largest reaction), with
    r_n >= 0: every local solve ends on the bound or inside it, the sum over points then
    obeys the cone too. Ill-conditioned W (ridge down to 1e-8) and stiff springs
    included."""
    rng = np.random.default_rng(11 + nt)
    for _ in range(150):
        nc = int(rng.integers(1, 9))
        n = nc * (nt + 1)
        B = rng.standard_normal((n, n))
        W = B @ B.T + 10.0 ** rng.uniform(-8, 0) * np.eye(n)
        q = rng.standard_normal(n) * 10.0 ** rng.uniform(-3, 3)
        mu = rng.uniform(0.01, 1.0, nc)
        for penalty in (False, True):
            r = np.zeros(n)
            if penalty:
                c = np.full(nc, 10.0 ** rng.uniform(-2, 4))
                penalty_coulomb_solve(W, q, mu, c, np.zeros(n - nc), r)
            else:
                coulomb_solve(W, q, mu, np.zeros(nc), r, np.zeros(nc, np.int64), 1e-13)
            rn, rt = r[:nc], r[nc:].reshape(nc, nt)
            scale = 1e-14 * np.max(np.abs(r))
            assert np.all(rn >= 0.0)
            assert np.all(np.linalg.norm(rt, axis=1) <= mu * rn + scale)


def _block(spec: str, scheme: str):
    case = make_case(spec)
    run = run_one(spec, scheme, nx=NX, T=T)
    p = case.sparse_problem(NX, 1.0, make_scheme(scheme).mass_kind())
    return case, run, p


@pytest.mark.parametrize("scheme", FRICTIONAL)
def test_sliding_block_momentum_identity(scheme):
    case, run, p = _block("sliding_block[angle=30,mu=0.3]", scheme)
    assert run.row["status"] == "ok"
    slides = case.sliding(p, run.trajectory.V)
    assert slides.mean() > 0.5  # the identity is checked on most steps
    assert run.row["err_sliding_momentum"] <= 1e-9
    # the recorded tangential impulse is the tangential momentum's change less gravity's
    assert tangential_impulse_residual(p, run.trajectory) <= 1e-9
    # and it is the sliding law's: the frictionless rate misses it by far
    t = case.tilt.tangent(p)
    p_t = run.trajectory.V @ (p.M @ t)
    assert abs(float(p_t[-1] - p_t[0]) - T * float(t @ p.F)) > 0.1


def _stick_bound(case, p) -> float:
    """sqrt(m F.K_c^-1 F), K_c the stiffness with every contact node's dofs held."""
    G, Tn = p.contact.gap_operator(p.nfree), p.contact.tangents
    held = np.unique(np.concatenate([G.indices, Tn.indices]))
    free = np.setdiff1d(np.arange(p.nfree), held)
    u = spsolve(sp.csc_matrix(p.K[free][:, free]), p.F[free])
    t = case.tilt.tangent(p)
    return float(np.sqrt((t @ (p.M @ t)) * (p.F[free] @ u)))


def test_the_frictional_schemes_are_those_declaring_it():
    assert {n for n in schemes().names() if make_scheme(n).traits().friction} == set(FRICTIONAL)


@pytest.mark.parametrize("scheme", EXACT_STICK)
def test_sliding_block_sticks_above_tan_angle(scheme):
    case, run, p = _block("sliding_block[angle=30,mu=0.8,speed=0]", scheme)
    assert run.row["status"] == "ok"
    t = case.tilt.tangent(p)
    p_t = run.trajectory.V @ (p.M @ t)
    bound = _stick_bound(case, p)
    assert np.max(np.abs(p_t)) <= bound
    # the bound is tight enough to fail: the block sliding at mu 0.3 leaves it
    _, slide, _ = _block("sliding_block[angle=30,mu=0.3,speed=0]", scheme)
    assert np.max(np.abs(slide.trajectory.V @ (p.M @ t))) > 1.5 * bound


@pytest.mark.parametrize("scheme", FRICTIONAL)
def test_mu_zero_is_the_frictionless_run_bit_for_bit(scheme):
    case = make_case("disc_drop[degree=1,lift=0.5]")
    sch = make_scheme(scheme)
    p = case.sparse_problem(3, 1.0, sch.mass_kind())
    c = p.contact
    nc, n = c.size, p.nfree
    tangents = sp.csr_matrix((np.ones(nc), (np.arange(nc), np.asarray(c.dofs) - 1)),
                             shape=(nc, n))  # each contact node's x dof
    q = dataclasses.replace(p, contact=dataclasses.replace(c, tangents=tangents,
                                                           friction=np.zeros(nc)))
    q.check()
    a = sch.prepare(p, 0.05).run(80, 1)
    b = sch.prepare(q, 0.05).run(80, 1)  # mu = 0: the frictionless path itself
    forced = FRICTIONAL[scheme]
    c = forced(sch, q, 0.05).run(80, 1) if forced else b  # the frictional step, mu = 0
    assert np.min(a.stress) < 0  # the disc has hit the plane
    for name in ("U", "V", "stress", "energy"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
        assert np.array_equal(getattr(a, name), getattr(c, name)), name


def test_a_scheme_without_friction_is_refused_in_one_line():
    run = run_one("sliding_block[mu=0.3]", "kane", nx=2, T=0.05)
    assert run.row["status"] == "not applicable"
    assert "Traits.friction" in run.row["notes"] and "\n" not in run.row["notes"]
    assert run_one("sliding_block[mu=0]", "kane", nx=2, T=0.05).row["status"] == "ok"
