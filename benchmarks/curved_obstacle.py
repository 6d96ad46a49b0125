"""The numbers of docs/contact.md's curved obstacle: `curved_drop` against the plane, Hertz
and its own linearisation (tests/test_curved_drop.py asserts bounds on them).

    python benchmarks/curved_obstacle.py

(a) hertz_sphere (nx 3, 800 steps) against curved_drop[R_o] for R_o = 1e6, 1e5, 1e4: the
largest displacement difference over delta = max x_t^2 / (2 R_o), and the relative
differences of the peak force, the impulse and the stress column;
(b) curved_drop[R_o=1] and hertz_sphere at nx 8 (redistributed) against Hertz (R* = 1/2
and R = 1): contact time and peak force;
(c) the exact minus the linearised gap at the points the obstacle pushes after each step
(ball on R_o = 1, nx 3, 6 time units), Kane's exact contact and the redistributed mass,
dt 0.02, 0.01, 0.005;
(d) the disc (lift 5, nx 5) centred over a circle of its radius: the largest sideways
contact force sum_j lambda_j |n_j,x| (redistributed) and each scheme's largest sideways
momentum over the impact's momentum;
(e) the energy drift of the schemes conserving it on a fixed G (the scene's small grid),
and the ball's vertical momentum change over the stress column's impulse (nx 8);
(f) the massless-contact schemes near their stability limit: redistributed[beta=0]'s
largest energy drift on curved_drop[R_o=1] and on the plane (hertz_sphere) at nx 2 and 3
for dt / limit = 0.50, 0.51, ..., 1.00 (the largest below 0.9, from 0.9 to 0.95, above,
and the ratios where it passes 1 E0); at nx 2, dt = 0.01 (the scene's), the steps at which
the pole comes on the obstacle and the top frequency of the contact state it leaves.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.core.obstacle import sphere_gaps
from contact_bench.harness import run_one
from contact_bench.kernels.kane import kane_step
from contact_bench.kernels.sparse import newmark_step, quasistatic_step


def large_radius() -> None:
    for spec in ("redistributed", "penalty"):
        scheme = make_scheme(spec)
        flat = scheme.integrate(make_case("hertz_sphere").sparse_problem(
            3, 1.0, scheme.mass_kind()), 0.01, 800, 1)
        for Ro in (1e6, 1e5, 1e4):
            p = make_case(f"curved_drop[R_o={Ro:g}]").sparse_problem(3, 1.0,
                                                                     scheme.mass_kind())
            delta = float(np.max(p.contact.obstacle.points[:, 0] ** 2)) / (2 * Ro)
            tr = scheme.integrate(p, 0.01, 800, 1)
            rel = [abs(tr.extra[k] / flat.extra[k] - 1)
                   for k in ("peak_contact_force", "contact_impulse")]
            stress = np.abs(tr.stress - flat.stress).max() / np.abs(flat.stress).max()
            print(f"(a) {spec:<14} R_o {Ro:7.0e}  delta {delta:.2e}  max|dU|/delta "
                  f"{np.abs(tr.U - flat.U).max() / delta:.3f}  peak {rel[0]:.1e}  "
                  f"impulse {rel[1]:.1e}  stress {stress:.1e}")


def hertz() -> None:
    scheme = make_scheme("redistributed")
    for spec in ("curved_drop[R_o=1]", "hertz_sphere"):
        case = make_case(spec)
        p = case.sparse_problem(case.nx, 1.0, scheme.mass_kind())
        tr = scheme.integrate(p, case.dt, int(round(case.T / case.dt)), 1)
        force = -tr.stress * p.contact.weights.sum()
        tc = tr.extra["first_contact_end"] - tr.extra["first_contact_start"] + case.dt
        h = case.hertz()
        print(f"(b) {spec:<20} R {h.R:.2f}  contact time {tc:.3f} (Hertz {h.contact_time:.3f},"
              f" {tc / h.contact_time - 1:+.1%})  peak force {force.max():.5f} (Hertz "
              f"{h.peak_force:.5f}, {force.max() / h.peak_force - 1:+.1%})")


def gap_defects(spec: str, dt: float) -> tuple[float, float]:
    """(largest, smallest) exact minus linearised gap at the points the obstacle pushes,
    after each step of the ball's first 6 time units on a sphere of radius 1 (nx 3):
    (c), and the bounds tests/test_curved_drop.py asserts on it."""
    scheme = make_scheme(spec)
    p = make_case("curved_drop").sparse_problem(3, 1.0, scheme.mass_kind())
    st = scheme.prepare(p, dt)
    state, ct = st.new_state(), st.ops.ct
    step = kane_step if spec == "kane" else newmark_step
    hi, lo = 0.0, np.inf
    for n in range(1, int(round(6.0 / dt)) + 1):
        step(st.ops, state, n)
        on = state.force > 0
        if on.any():
            G = sp.csr_matrix((ct.G.data, ct.G.indices, ct.G.indptr),
                              shape=(ct.gap0.size, p.nfree))
            d = (sphere_gaps(p.contact.obstacle, state.U) - (ct.gap0 + G @ state.U))[on]
            hi, lo = max(hi, float(d.max())), min(lo, float(d.min()))
    return hi, lo


def defects() -> None:
    for spec in ("kane", "redistributed"):
        for dt in (0.02, 0.01, 0.005):
            hi, lo = gap_defects(spec, dt)
            print(f"(c) {spec:<14} dt {dt:<6} exact - linearised gap: max {hi:.2e}, "
                  f"min {lo:.1e}")


DISC = "curved_drop[of=disc_drop[degree=1,lift=5],R_o=20]"


def symmetry() -> None:
    scheme = make_scheme("redistributed")
    p = make_case(DISC).sparse_problem(5, 1.0, scheme.mass_kind())
    st = scheme.prepare(p, 0.01)
    state, ct = st.new_state(), st.ops.ct
    side = total = 0.0
    for n in range(1, 1151):
        newmark_step(st.ops, state, n)
        side = max(side, float(np.sum(state.force * np.abs(ct.cv.nrm[:, 0]))))
        total = max(total, float(state.force.sum()))
    print(f"(d) sideways contact force up to {side:.1f} of a total up to {total:.1f}")
    case = make_case(DISC)
    for spec in schemes().names():
        scheme = make_scheme(spec)
        if case.cannot_run(scheme) is not None:
            print(f"(d) {spec:<20} not applicable")
            continue
        p = case.sparse_problem(5, 1.0, scheme.mass_kind())
        tr = scheme.integrate(p, 0.01, 1150, 1)
        mom = np.max(np.abs(tr.V @ (p.M @ (1.0 - p.vertical))))
        print(f"(d) {spec:<20} sideways momentum / impact's {mom / (p.body_mass * 1.0):.1e}")


def claims() -> None:
    case = make_case("curved_drop")
    for spec in ("armero_petocz", "laursen_chawla", "laursen_love", "ode_adaptive"):
        row = run_one(case, spec, nx=case.study.small_nx[0], T=case.study.small_T).row
        print(f"(e) {spec:<16} energy drift {row['energy_drift_max']:.1e}")
    scheme = make_scheme("redistributed")
    c = make_case("curved_drop[R_o=1]")
    p = c.sparse_problem(c.nx, 1.0, scheme.mass_kind())
    tr = scheme.integrate(p, c.dt, int(round(c.T / c.dt)), 1)
    mom = tr.V @ (p.M @ p.vertical)
    ratio = (mom[-1] - mom[0]) / tr.extra["contact_impulse"]
    print(f"(e) vertical momentum change / impulse {ratio:.4f}")


def top_omega(p, rows: tuple[int, ...]) -> float:
    """omega_max of the massless-contact ODE with the contact points `rows` held on their
    rows of G (the reference tangent): the Schur complement on the dofs with mass of K
    with the massless dofs solved under G_A u_m = 0 (dense: the small grid)."""
    mv, hv = np.flatnonzero(p.massless), np.flatnonzero(~p.massless)
    K, M = p.K.toarray(), p.M.toarray()
    GA = sp.csr_matrix(p.contact.gap_operator(p.nfree)).toarray()[list(rows)][:, mv]
    k = GA.shape[0]
    kkt = np.block([[K[np.ix_(mv, mv)], GA.T], [GA, np.zeros((k, k))]])
    X = np.linalg.solve(kkt, np.vstack([K[np.ix_(mv, hv)], np.zeros((k, hv.size))]))
    S = K[np.ix_(hv, hv)] - K[np.ix_(mv, hv)].T @ X[:mv.size]
    return float(np.sqrt(np.max(np.linalg.eigvals(np.linalg.solve(M[np.ix_(hv, hv)],
                                                                   S)).real)))


def near_the_limit() -> None:
    scheme = make_scheme("redistributed[beta=0]")
    ratios = np.round(np.arange(0.50, 1.0001, 0.01), 2)
    for spec in ("curved_drop[R_o=1]", "hertz_sphere"):
        for nx in (2, 3):
            p = make_case(spec).sparse_problem(nx, 1.0, scheme.mass_kind())
            limit = scheme.stability_limit(p)
            drift = []
            for r in ratios:
                E = scheme.integrate(p, r * limit, int(round(17.7 / (r * limit))), 1).energy
                drift.append(float(np.abs(E - E[0]).max() / abs(E[0])))
            drift = np.array(drift)
            bands = [float(drift[m].max()) for m in (ratios < 0.9, (ratios >= 0.9)
                                                     & (ratios < 0.95), ratios >= 0.95)]
            jumps = ", ".join(f"{r:.2f}" for r in ratios[drift > 1.0])
            print(f"(f) {spec:<18} nx {nx} limit {limit:.5f}: largest drift "
                  f"{bands[0]:.1e} (< 0.9), {bands[1]:.1e} (0.9-0.95), {bands[2]:.1e} "
                  f"(>= 0.95); over 1 E0 at dt / limit = {jumps or 'none'}")
    p = make_case("curved_drop[R_o=1]").sparse_problem(2, 1.0, scheme.mass_kind())
    st = scheme.prepare(p, 0.01)
    state, onsets, was = st.new_state(), [], False
    for n in range(1, 1111):
        quasistatic_step(st.ops, state, n)
        on = bool(state.force[0] > 0.0)
        if on and not was and n >= 1060:
            onsets.append(n)
        was = on
    w = top_omega(p, (6,))
    print(f"(f) dt 0.01: the pole comes on at steps {onsets} (spacing "
          f"{sorted(set(np.diff(onsets).tolist()))}); the state with point 6 alone: "
          f"omega_max dt = {w * 0.01:.3f}, a discrete period of "
          f"{2 * np.pi / (2 * np.arcsin(w * 0.01 / 2)):.2f} steps")


if __name__ == "__main__":
    large_radius()
    hertz()
    defects()
    symmetry()
    claims()
    near_the_limit()
