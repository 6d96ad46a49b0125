"""What the energy costs a run: `scheme.integrate` at stride 100 (one energy per 100
steps) and at stride = nsteps (two), in ns per dof-step, median of rounds; and with
`--alone`, `energy_of` itself against the plain sum it replaced (d u^2 + 2 e u u', F.U
in one chain each), in ns per dof, both timed in this process (one load for both).

    python benchmarks/energy_cost.py [--n 1000 100000] [--rounds 7] [--alone] [scheme ...]

Run it in two checkouts to compare an energy change (the kernels compile energy_of in).
"""

from __future__ import annotations

import argparse
import statistics
import time

from numba import njit

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core.sampling import energy_of

SPECS = ["redistributed", "standard", "restitution", "taylor_flanagan", "ode_verlet",
         "penalty"]


@njit(cache=True)
def plain_energy(Md, Me, Kd, Ke, F, U, V, offset):
    """The former energy_of: each form as diagonal then off-diagonal terms, one chain."""
    s = 0.0
    for i in range(U.size):
        s -= F[i] * U[i]
    q = 0.0
    for i in range(V.size):
        q += Md[i] * V[i] * V[i]
    for i in range(V.size - 1):
        q += 2.0 * Me[i] * V[i] * V[i + 1]
    k = 0.0
    for i in range(U.size):
        k += Kd[i] * U[i] * U[i]
    for i in range(U.size - 1):
        k += 2.0 * Ke[i] * U[i] * U[i + 1]
    return 0.5 * q + 0.5 * k + s + offset


def alone(ns: list[int], rounds: int) -> None:
    print(f"{'energy':<16} {'n':>7} {'ns per dof (median, min)':>26}")
    for n in ns:
        semi = discretise(make_case("clamped_bar"), mesh_nodes(1.0, n), "consistent")
        args = (semi.M.diag, semi.M.off, semi.K.diag, semi.K.off, semi.F, semi.U0,
                0.3 * semi.U0, 0.0)
        reps = max(3, int(2e7 / n))
        for name, f in (("plain (before)", plain_energy), ("energy_of", energy_of)):
            f(*args)
            times = []
            for _ in range(rounds):
                start = time.perf_counter()
                for _ in range(reps):
                    f(*args)
                times.append((time.perf_counter() - start) / reps / n * 1e9)
            print(f"{name:<16} {n:>7} {statistics.median(times):>17.3f} {min(times):>8.3f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[1_000, 100_000])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--work", type=float, default=2e7, help="dof-steps per round")
    ap.add_argument("--alone", action="store_true", help="time energy_of alone (A/B)")
    ap.add_argument("schemes", nargs="*")
    args = ap.parse_args(argv)
    if args.alone:
        alone(args.n, args.rounds)
        return 0
    print(f"{'scheme':<16} {'n':>7} {'nsteps':>7} {'stride 100':>11} {'stride nsteps':>14}"
          "  (ns per dof-step, median)")
    for n in args.n:
        for spec in args.schemes or SPECS:
            scheme = make_scheme(spec)
            case = make_case("clamped_bar")
            semi = discretise(case, mesh_nodes(1.0, n), scheme.mass_kind())
            dt = 0.5 * semi.hmin / semi.c_max
            limit = scheme.stability_limit(semi.hmin, semi.c_max)
            if limit is not None:
                dt = min(dt, 0.9 * limit)
            nsteps = max(200, int(args.work / semi.nfree) // 100 * 100)
            scheme.warm_up(semi)
            out = []
            for stride in (100, nsteps):
                scheme.integrate(semi, dt, nsteps, stride)
                times = []
                for _ in range(args.rounds):
                    start = time.perf_counter()
                    scheme.integrate(semi, dt, nsteps, stride)
                    times.append(time.perf_counter() - start)
                out.append(statistics.median(times) / (semi.nfree * nsteps) * 1e9)
            print(f"{spec:<16} {n:>7} {nsteps:>7} {out[0]:>11.3f} {out[1]:>14.3f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
