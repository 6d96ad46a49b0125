"""The disc and the ball of today with Coulomb friction on the plane (`mu` on disc_drop and
sphere_drop, GetFEM's dynamic friction setting), and so the disc or ball bouncing down a
slope with friction (`slanted_drop[tilt_gravity=0]` of such a base).

- mu = 0 is today's scene: the same spec, a problem without tangent rows, and every
  frictional scheme's run bit for bit equal to its run on the mu > 0 problem with every
  coefficient set to zero (tangent rows given: the frictionless path itself).
- With mu = 0.3 on the slope (disc P1 nx 5, ball nx 8), every frictional scheme, at every
  sample: the momentum balance along the plane's normal, n.M (V_k - V_0) = t_k n.F + J_n
  with J_n the normal impulse the loop accumulates (`Trajectory.extra["impulse"]`, kept
  apart from the velocities); the tangential impulse the balance leaves, J_t = T_d M (V_k
  - V_0) - t_k T_d F (T_d the plane's tangent translations), within Coulomb's bound |J_t|
  <= mu J_n to round-off, and not zero (without friction it is round-off);
  the friction work <= 0.
- A scheme without friction refuses the scene in one line.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.harness import run_one

FRICTIONAL = sorted(n for n in schemes().names() if make_scheme(n).traits().friction)
MU = 0.3
#: (base, nx, T): the disc P1 lifted 0.5 (impact at t = 3.16), the ball lifted 0.1 (1.41)
BASES = {"disc": ("disc_drop[degree=1,lift=0.5{mu}]", 5, 5.0),
         "ball": ("sphere_drop[lift=0.1{mu}]", 8, 2.5)}


def _spec(base: str, mu: str) -> str:
    return f"slanted_drop[of={BASES[base][0].format(mu=mu)},tilt_gravity=0]"


@functools.cache
def _run(base: str, scheme: str):
    spec = _spec(base, f",mu={MU}")
    _, nx, T = BASES[base]
    case = make_case(spec)
    assert make_scheme(scheme).cannot_run(case) is None
    run = run_one(spec, scheme, nx=nx, T=T)
    assert run.row["status"] == "ok", run.row["notes"]
    return case, run, case.sparse_problem(nx, 1.0, make_scheme(scheme).mass_kind())


def test_mu_zero_is_todays_scene():
    for base in BASES:
        zero, today = make_case(_spec(base, ",mu=0")), make_case(_spec(base, ""))
        assert zero.base.spec == today.base.spec and zero.friction() == 0.0
        p = zero.sparse_problem(2 if base == "disc" else 4, 1.0, "consistent")
        assert p.contact.tangents is None and p.tangential_stress is None
        q = make_case(_spec(base, f",mu={MU}")).sparse_problem(
            2 if base == "disc" else 4, 1.0, "consistent")
        d = p.dim
        assert q.contact.frictional and q.contact.tangents.shape[0] == (d - 1) * q.contact.size
        assert np.array_equal(p.contact.gap_operator(p.nfree).toarray(),
                              q.contact.gap_operator(q.nfree).toarray())


@pytest.mark.parametrize("scheme", FRICTIONAL)
def test_mu_zero_runs_the_frictionless_path_bit_for_bit(scheme):
    spec, nx, dt, steps = _spec("disc", ",mu=0"), 3, 0.01, 350
    sch = make_scheme(scheme)
    p = make_case(spec).sparse_problem(nx, 1.0, sch.mass_kind())
    q = make_case(_spec("disc", f",mu={MU}")).sparse_problem(nx, 1.0, sch.mass_kind())
    q = dataclasses.replace(q, contact=dataclasses.replace(
        q.contact, friction=np.zeros(q.contact.size)))
    a, b = sch.prepare(p, dt).run(steps, 1), sch.prepare(q, dt).run(steps, 1)
    assert np.min(a.stress) < 0  # the disc has hit the slope
    for name in ("U", "V", "stress", "energy"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


def _balance(case, run, p):
    """(J_n from the momentum, J_n recorded, J_t from the momentum (samples x dim-1),
    the normal impulse's scale)."""
    tr = run.trajectory
    d = p.dim
    R = case.rotation(d)
    dV = tr.V - tr.V[0]
    t = tr.t
    n = np.tile(R[:, case.vertical], p.nfree // d)  # the plane's normal translation
    Jn = dV @ (p.M @ n) - t * float(n @ p.F)
    tangents = [np.tile(R[:, k], p.nfree // d) for k in range(d) if k != case.vertical]
    Jt = np.stack([dV @ (p.M @ e) - t * float(e @ p.F) for e in tangents], axis=1)
    rec = np.asarray(tr.extra["impulse"], float)
    return Jn, rec, Jt


@pytest.mark.parametrize("base", list(BASES))
@pytest.mark.parametrize("scheme", FRICTIONAL)
def test_impulses_obey_the_momentum_balance_and_coulomb(scheme, base):
    case, run, p = _run(base, scheme)
    Jn, rec, Jt = _balance(case, run, p)
    scale = float(np.max(np.abs(Jn)))
    assert scale > 0 and rec.shape == Jn.shape
    # the loop's normal impulse against the momentum's (independent books)
    assert np.max(np.abs(np.abs(rec) - Jn)) <= 1e-9 * scale, np.max(np.abs(np.abs(rec) - Jn))
    assert np.min(Jn) >= -1e-9 * scale
    # Coulomb on the accumulated impulses, at every sample
    slack = np.linalg.norm(Jt, axis=1) - MU * Jn
    assert np.max(slack) <= 1e-9 * scale, np.max(slack)
    assert np.linalg.norm(Jt[-1]) > 1e-3 * scale  # friction acted (without: round-off)
    W = run.trajectory.extra["friction_work"]
    assert W[0] == 0.0 and np.max(W) <= 1e-12 * np.max(np.abs(W)) and W[-1] < 0.0


def test_a_scheme_without_friction_refuses_in_one_line():
    case = make_case(_spec("disc", f",mu={MU}"))
    lazy = next(n for n in sorted(schemes().names()) if not make_scheme(n).traits().friction)
    reason = case.cannot_run(make_scheme(lazy))
    assert reason and "\n" not in reason and "mu = 0.3" in reason
    assert make_case(f"disc_drop[mu={MU}]").cannot_run(make_scheme(lazy)) == reason
