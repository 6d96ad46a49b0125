"""The quiet run: clamped_bar, 10 steps of dt = 1e-7, every sample kept, at large nx.

Over 1e-6 the bar hardly moves: a test of how the energy is summed, not of a scheme.
Prints, per scheme and nx:

- E(0) - 1/8: the discrete energy of the interpolated data. 0 (1/8 exactly: u0 is
  linear) except where the scheme's energy holds more than the bar's: nitsche samples
  E_theta = ... - (theta/2gam) sigma^2 (-h/40 here), ode_adaptive and ode_verlet start
  from the relaxed massless node (-h/8, the first element's strain energy).
- max |E - 1/8| / (1/8) over the samples: also the release of h/8 by the massless
  contact node at the first step (hht, redistributed: 1e-5 at nx = 1e5) and the
  O((omega dt)^2) oscillation of explicit schemes' sampled energy.
- max |E - E_ref| / (1/8): the sampled energy against `reference_energy` of the same
  sampled (U, V): the summation error alone, the figure to hold to 1e-10.
- the row's energy_drift_max (`contact_bench.harness.metrics.energy_metrics`).

    python benchmarks/quiet_energy.py [--nx 100000 1000000] [scheme ...]

The output of the default run is kept in results/energy/quiet_energy.txt.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from contact_bench.api.plugin import Semidiscrete
from contact_bench.api.registry import make_scheme, schemes
from contact_bench.harness import run_one

EXACT = 0.125
DT, STEPS = 1e-7, 10


def reference_energy(semi: Semidiscrete, U: np.ndarray, V: np.ndarray,
                     nitsche: tuple[float, float] | None = None) -> float:
    """1/2 V.M.V + 1/2 U.K.U - F.U + offset summed exactly (math.fsum of the terms):
    the strain energy as the bar's, sum over elements k_e (u_{i+1} - u_i)^2 with
    k_e = -K[i, i+1], plus the eliminated clamped element's k u_{m-1}^2 (the only row
    of K whose sum is not 0); the kinetic energy from M's entries. `nitsche` = (theta,
    gamma0): Nitsche's inactive term -(theta/2) E/(gamma0 h) (u1 - u0)^2 (the quiet
    run never touches the obstacle)."""
    U, V = np.asarray(U, float), np.asarray(V, float)
    Md, Me, Kd, Ke = semi.M.diag, semi.M.off, semi.K.diag, semi.K.off
    du = np.diff(U)
    terms = [*(0.5 * Md * V * V), *(Me * V[:-1] * V[1:]), *(-0.5 * Ke * du * du)]
    if semi.u_fixed is not None:  # clamped far end: the last row keeps its element
        terms.append(0.5 * (Kd[-1] + Ke[-1]) * U[-1] * U[-1])
    terms += [*(-semi.F * U), semi.energy_offset]
    if nitsche is not None:
        theta, gamma0 = nitsche
        h = float(semi.x[1] - semi.x[0])
        terms.append(-0.5 * theta * semi.E_contact / (gamma0 * h) * (U[1] - U[0]) ** 2)
    return math.fsum(terms)


def quiet_run(spec: str, nx: int) -> dict[str, float | str]:
    """One quiet run and its energy figures (see the module docstring)."""
    run = run_one("clamped_bar", spec, nx=nx, dt=DT, T=DT * STEPS, stride=1)
    row, tr = run.row, run.trajectory
    out: dict[str, float | str] = {"status": row["status"], "notes": row["notes"] or ""}
    if tr is None:
        return out
    scheme = make_scheme(spec)
    nit = ((float(scheme.theta), float(scheme.gamma0)) if scheme.name == "nitsche" else None)
    E = np.asarray(tr.energy, float)
    ref = np.array([reference_energy(run.semi, tr.U[k], tr.V[k], nit) for k in range(E.size)])
    out.update(E0_minus_exact=float(E[0] - EXACT),
               max_dev_exact=float(np.max(np.abs(E - EXACT)) / EXACT),
               max_dev_ref=float(np.max(np.abs(E - ref)) / EXACT),
               drift=float(row["energy_drift_max"]), samples=float(E.size))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nx", type=int, nargs="+", default=[100_000, 1_000_000])
    ap.add_argument("schemes", nargs="*", help="scheme specs (default: every scheme)")
    args = ap.parse_args(argv)
    specs = args.schemes or schemes().names()
    print(f"clamped_bar, dt = {DT:g}, {STEPS} steps, stride 1; exact energy {EXACT}")
    print(f"{'scheme':<18} {'nx':>8} {'status':<7} {'E(0) - 1/8':>11} "
          f"{'max|E-1/8|/(1/8)':>17} {'max|E-E_ref|/(1/8)':>19} {'energy_drift_max':>17}")
    for nx in args.nx:
        for spec in specs:
            r = quiet_run(spec, nx)
            if "drift" not in r:
                print(f"{spec:<18} {nx:>8} {r['status']:<7} {r['notes']}")
                continue
            print(f"{spec:<18} {nx:>8} {r['status']:<7} {r['E0_minus_exact']:>11.3e} "
                  f"{r['max_dev_exact']:>17.3e} {r['max_dev_ref']:>19.3e} {r['drift']:>17.3e}",
                  flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
