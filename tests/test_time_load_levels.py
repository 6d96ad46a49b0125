"""Every scheme adds a time-dependent load (`SparseProblem.load`) at the time level of its
own discretisation, and so runs the manufactured solution (cases/manufactured.py).

* Time levels: on the manufactured box (P1, nx 2) with the obstacle moved out of reach,
  three steps of each scheme's compiled stepper satisfy the scheme's defining equations
  written out here with scipy (the theta-method, the trapezoidal rule, the central
  difference's three-level form, Paoli-Schatzman's weighted three levels) with the load
  of `TimeLoad.at` at the claimed time to round-off, and miss them by far with the load
  half a step off (the check can fail).
* Accuracy: on the manufactured solution with its moving contact zone (nx 4 and 8 at a
  fixed CFL), each scheme's displacement error is below a bound that the same run
  without the load exceeds several times over, and halves at least from nx 4 to 8.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.harness.runner import problem_for, run_one

DT = 0.02
STEPS = 3

#: (scheme, its defining equation, its parameter): "theta" (the theta-method, the load
#: at t_n + theta dt), "trapezoid" (the mean of the loads at t_n and t_{n+1}), "central"
#: (M (U_{n+1} - 2 U_n + U_{n-1}) = dt^2 (F(t_n) - K U_n), massless rows included),
#: "three_level" (Paoli-Schatzman with stiffness weight beta), "static" (the massless
#: rows K_m U(t) = F_m(t) at every sample: ode_adaptive's stages are its own)
LEVELS = (
    ("armero_petocz", "theta", 0.5),
    ("laursen_chawla", "theta", 0.5),
    ("laursen_love", "theta", 0.5),
    ("moreau_jean", "theta", 0.5),
    ("moreau_jean[theta=0.75]", "theta", 0.75),
    ("kane", "trapezoid", None),
    ("contact_stabilized", "trapezoid", None),
    ("standard", "trapezoid", None),
    ("redistributed", "trapezoid", None),
    ("taylor_flanagan", "central", None),
    ("taylor_flanagan[mass=lumped]", "central", None),
    ("penalty[beta=0]", "central", None),
    ("penalty[beta=0,mass=lumped]", "central", None),
    ("redistributed[beta=0]", "central", None),
    ("ode_verlet", "central", None),
    ("semi_explicit", "central", None),
    ("restitution", "central", None),
    ("restitution[beta=0.25,mass=consistent]", "three_level", 0.25),
    ("ode_adaptive", "static", None),
)


def far_run(spec: str):
    """(problem, U, V samples) of three steps of `spec` on the manufactured box with the
    obstacle out of reach."""
    case, scheme = make_case("manufactured"), make_scheme(spec)
    p = problem_for(case, scheme, 2)
    p = replace(p, contact=replace(p.contact, gap0=np.full(p.contact.size, 10.0)))
    traj = scheme.prepare(p, DT).run(STEPS, 1)
    return p, np.asarray(traj.U), np.asarray(traj.V)


def residual(p, U, V, kind: str, a: float | None, shift: float) -> tuple[float, float]:
    """The largest residual of the scheme's equations over the steps, with the load
    evaluated `shift` after the claimed time, and the size of their terms."""
    M, K, F = p.M, p.K, p.load.at
    worst, scale = 0.0, 0.0
    for n in range(STEPS):
        t = n * DT + shift
        if kind == "theta":  # M (V1 - V0) = dt (F(t_n + a dt) - K (U0 + a (U1 - U0)))
            terms = (M @ (V[n + 1] - V[n]), DT * F(t + a * DT),
                     DT * (K @ (U[n] + a * (U[n + 1] - U[n]))))
            r = terms[0] - terms[1] + terms[2]
            kin = U[n + 1] - U[n] - DT * ((1 - a) * V[n] + a * V[n + 1])
            r = np.concatenate([r, kin * np.abs(M).max()])
        elif kind == "trapezoid":  # M (V1 - V0) = dt/2 (F0 + F1 - K (U0 + U1))
            terms = (M @ (V[n + 1] - V[n]), 0.5 * DT * (F(t) + F(t + DT)),
                     0.5 * DT * (K @ (U[n] + U[n + 1])))
            r = terms[0] - terms[1] + terms[2]
            if n == 0:  # the data U0 leave the massless rows out of equilibrium
                r = r[~p.massless]
        elif kind == "static":  # the massless rows: K_m U = F_m(t)
            m = p.massless
            terms = ((K @ U[n])[m], F(t)[m])
            r = terms[0] - terms[1]
        else:
            if n == 0:
                continue
            b = 0.0 if kind == "central" else a
            load = b * (F(t - DT) + F(t + DT)) + (1 - 2 * b) * F(t)
            stiff = K @ (b * (U[n - 1] + U[n + 1]) + (1 - 2 * b) * U[n])
            terms = (M @ (U[n + 1] - 2 * U[n] + U[n - 1]), DT * DT * load, DT * DT * stiff)
            r = terms[0] - terms[1] + terms[2]
        worst = max(worst, float(np.abs(r).max()))
        scale = max([scale] + [float(np.abs(x).max()) for x in terms])
    return worst, scale


@pytest.mark.parametrize("spec,kind,a", LEVELS, ids=[s for s, _, _ in LEVELS])
def test_each_scheme_adds_the_load_at_its_own_time_level(spec: str, kind: str, a) -> None:
    p, U, V = far_run(spec)
    assert p.load is not None and np.all(np.isfinite(U))
    good, scale = residual(p, U, V, kind, a, 0.0)
    off, _ = residual(p, U, V, kind, a, 0.5 * DT)
    tol = 1e-9 if kind != "static" else 1e-7  # ode_adaptive: its samples' solves
    assert good <= tol * scale, (good, scale)
    assert off > 1e3 * tol * scale, (off, scale)


def test_every_scheme_runs_the_manufactured_solution() -> None:
    """No scheme is refused for the time-dependent load, in 2D and 3D, P1 and P2 (with a
    mass that P2 allows); the explicit and massless variants neither."""
    names = sorted(schemes().names())
    assert len(names) >= 16
    for dim in (2, 3):
        for spec in names + ["redistributed[beta=0]", "penalty[beta=0]", "nitsche[beta=0]"]:
            scheme = make_scheme(spec)
            for case in (make_case(f"manufactured[dim={dim}]"),
                         make_case(f"manufactured[dim={dim},degree=2]")):
                reason = case.cannot_run(scheme)
                assert reason is None or "P2" in reason, (spec, case.name, reason)
                assert scheme.adds_time_load(), spec


@pytest.mark.parametrize("spec", sorted(schemes().names()))
def test_the_load_makes_the_manufactured_error_small(spec: str) -> None:
    """nx 4 and 8 at CFL 0.3, T = 0.5: err_u_l2_l2 is below 0.3 with the load (about
    0.17-0.22 at nx 4) and above 1 without it (about 1.6), and it falls by a factor of
    at least 2 from nx 4 to nx 8 (order >= 1; the schemes measure about 1.4 there).
    ode_adaptive at rtol 1e-4: its default 1e-8 changes the errors in the fifth digit
    and triples the time."""
    spec = "ode_adaptive[rtol=1e-4]" if spec == "ode_adaptive" else spec
    case, scheme = make_case("manufactured"), make_scheme(spec)
    errs = []
    for nx in (4, 8):
        p = problem_for(case, scheme, nx)
        dt = 0.3 / (nx * math.sqrt(3.0))
        row = run_one(case, scheme, nx=nx, dt=dt, T=0.5, problem=p).row
        assert row["status"] == "ok", row.get("notes")
        errs.append(row["err_u_l2_l2"])
        if nx == 4:
            bare = run_one(case, scheme, nx=nx, dt=dt, T=0.5, problem=replace(p, load=None)).row
            assert errs[0] < 0.3 < 1.0 < bare["err_u_l2_l2"], (errs[0], bare["err_u_l2_l2"])
    assert errs[1] < errs[0] / 2.0, errs
