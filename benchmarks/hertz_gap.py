"""The hertz_sphere scene against Hertz's contact time and peak force: the relative gaps
at two impact speeds and two meshes, beside the same sphere's quasi-static answer.

    python benchmarks/hertz_gap.py [--scheme redistributed] [--nx 8 16] [--v 0.01 0.001]
                                   [--pole 0.6 0] [--quasi-static-only]

Contact time: the row's first_contact_end less its first_contact_start, both
interpolated within their steps from the smallest gap (`contact_bench.core.contact_stats`);
peak force: the largest total contact force of a step.

The quasi-static columns separate the finite sphere from Hertz's half-space: the same
mesh, statically pressed on the plane by a uniform body force b (the impact's inertia,
m b = F) for a range of F, gives its own force against the approach of its centre of
mass, F_s(d); integrating m d'' = -F_s(d) from d' = v gives the contact time and peak
force of a quasi-static impact of that sphere. Hertz's law is the limit of F_s as the
contact radius a = sqrt(R d) / R shrinks (a is 0.2 R at v = 0.01, 0.08 R at v = 0.001).
"""

from __future__ import annotations

import argparse

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from contact_bench.api.registry import make_case
from contact_bench.harness.runner import run_one


def static_approach(problem, forces: np.ndarray) -> np.ndarray:
    """The centre-of-mass approach d of the body pressed on the plane by a uniform body
    force of total F (each of `forces`), with frictionless unilateral contact at the
    problem's contact dofs (an active-set iteration of sparse solves: for the active set
    A, K w = -F/m M e + sum_A R_i e_i, w_i - d = -gap0_i on A, the centre of mass of w at
    0; drop negative reactions, add penetrating dofs). The problem's M must be the
    consistent mass and its rigid modes the vertical translation only."""
    K = problem.K.tocsr()
    n = K.shape[0]
    Me = problem.M @ problem.vertical
    m = float(problem.vertical @ Me)
    dofs, z = problem.contact.dofs, problem.contact.gap0
    active = np.array([int(np.argmin(z))])
    out = []
    for F in forces:
        for _ in range(500):
            k = active.size
            E = sp.csr_matrix((np.ones(k), (dofs[active], np.arange(k))), shape=(n, k))
            S = sp.bmat([[K, -E, None], [E.T, None, -np.ones((k, 1))],
                         [sp.csr_matrix(Me / m), None, None]], format="csc")
            x = spsolve(S, np.r_[-(F / m) * Me, -z[active], 0.0])
            w, R, d = x[:n], x[n:n + k], x[-1]
            pen = z - d + w[dofs] < -1e-12 * d
            pen[active] = False
            if not (R < 0).any() and not pen.any():
                break
            active = np.union1d(active[R >= 0], np.flatnonzero(pen))
        else:
            raise RuntimeError(f"no contact set found at F = {F!r}")
        out.append(d)
    return np.asarray(out)


def quasi_static_impact(forces: np.ndarray, approach: np.ndarray, m: float,
                        v: float) -> tuple[float, float]:
    """Contact time and peak force of m d'' = -F(d), d(0) = 0, d'(0) = v, with F the
    interpolation of (approach, forces) linear in log F against log d (exact for a power
    law; below the first point, the first segment's power law): the work W(d) by the
    trapezoidal rule on a fine grid, d_max from W(d_max) = m v^2 / 2, then T_c = 2
    int_0^d_max dd / d'(d), with d = d_max (1 - s^2) to remove the end singularity
    (midpoint rule in s on 20000 cells)."""
    ld, lf = np.log(approach), np.log(forces)
    slope0 = (lf[1] - lf[0]) / (ld[1] - ld[0])

    def force(x: np.ndarray) -> np.ndarray:
        lx = np.log(np.maximum(x, 1e-300))
        return np.where(x < approach[0], np.exp(lf[0] + slope0 * (lx - ld[0])),
                        np.exp(np.interp(lx, ld, lf)))

    grid = approach[-1] * np.r_[0.0, (np.arange(1, 200001) / 200000.0) ** 2]
    Fg = np.where(grid > 0, force(grid), 0.0)
    W = np.r_[0.0, np.cumsum(0.5 * (Fg[1:] + Fg[:-1]) * np.diff(grid))]
    K0 = 0.5 * m * v * v
    if W[-1] < K0:
        raise ValueError("the force range does not stop the body: raise the largest force")
    d_max = float(np.interp(K0, W, grid))
    s = (np.arange(20000) + 0.5) / 20000
    speed = np.sqrt(np.maximum(2 * (K0 - np.interp(d_max * (1 - s * s), grid, W)) / m,
                               1e-300))
    tc = 2 * float(np.sum(2 * d_max * s / speed)) / s.size
    return tc, float(force(np.array([d_max]))[0])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scheme", default="redistributed")
    ap.add_argument("--nx", type=int, nargs="+", default=[8, 16])
    ap.add_argument("--v", type=float, nargs="+", default=[0.01, 0.001])
    ap.add_argument("--pole", type=float, nargs="+", default=[0.6, 0.0],
                    help="the scene's pole zoom s (0.6 the default mesh, 0 the plain one)")
    ap.add_argument("--quasi-static-only", action="store_true",
                    help="skip the dynamic runs (their columns empty): the static answers")
    args = ap.parse_args(argv)
    print("| v | nx | pole | dofs | T_c Hertz | T_c FE | gap | T_c quasi-static | gap |"
          " F_max Hertz | F_max FE | gap | F_max quasi-static | gap | energy drift |"
          " switches | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for v in args.v:
        for pole in args.pole:
            for nx in args.nx:
                spec = f"hertz_sphere[v={v!r},pole={pole!r}]"
                case = make_case(spec)
                h = case.hertz()
                forces = h.peak_force * np.linspace(0.05, 1.3, 26)
                p = case.sparse_problem(nx, 1.0, "consistent")
                qtc, qfm = quasi_static_impact(forces, static_approach(p, forces),
                                               p.body_mass, v)
                c = [""] * 7  # the dynamic run's columns
                if not args.quasi_static_only:
                    row = run_one(spec, args.scheme, nx=nx).row
                    tc = row["first_contact_end"] - row["first_contact_start"]
                    fm = row["peak_contact_force"]
                    c = [f"{tc:.4g}", f"{tc / h.contact_time - 1:+.1%}", f"{fm:.4g}",
                         f"{fm / h.peak_force - 1:+.1%}", f"{row['energy_drift_max']:.2g}",
                         f"{row['chatter']:.0f}", f"{row['wall_s']:.2f}"]
                print(f"| {v:g} | {nx} | {pole:g} | {p.nfree} | {h.contact_time:.4g} | "
                      f"{c[0]} | {c[1]} | {qtc:.4g} | {qtc / h.contact_time - 1:+.1%} | "
                      f"{h.peak_force:.4g} | {c[2]} | {c[3]} | {qfm:.4g} | "
                      f"{qfm / h.peak_force - 1:+.1%} | {c[4]} | {c[5]} | {c[6]} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
