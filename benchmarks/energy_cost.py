"""What the energy costs a run: the scheme's stepper, prepared once outside the timing
(`scheme.prepare`), run at stride 100 (one energy per 100 steps) and at stride = nsteps
(two), in ns per dof-step, median of rounds; and with
`--alone`, `energy_of` itself against the sums it replaced, in ns per dof, all timed in
this process (one load for all): the plain sum (d u^2 + 2 e u u', F.U in one chain each)
and the first cancellation-free form (`tri_quad` twice and F.U, each in four scalar
partial sums per block, row sums computed as it goes), which the vectorised fused pass
replaced: `energy_rows` with the row sums computed once (as the kernels call it in
their step loops) and `energy_of` (row sums computed in every call).

    python benchmarks/energy_cost.py [--n 1000 100000] [--rounds 7] [--alone] [scheme ...]

Run it in two checkouts to compare an energy change (the kernels compile energy_of in).
"""

from __future__ import annotations

import argparse
import statistics
import time

from numba import njit

from contact_bench.api import as_problem
from contact_bench.api.fem import mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core.sampling import energy_of, energy_rows, row_sums
from contact_bench.core.tridiag import QUAD_BLOCK, tri_quad

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


@njit(cache=True)
def scalar_energy(Md, Me, Kd, Ke, F, U, V, offset):
    """The first cancellation-free energy_of: `tri_quad` twice (scalar partial sums, row
    sums computed as it goes) and F.U in blocks of four scalar partial sums."""
    n = U.size
    s = 0.0
    i = 0
    while i < n:
        end = min(i + QUAD_BLOCK, n)
        s0 = s1 = s2 = s3 = 0.0
        while i + 4 <= end:
            s0 += F[i] * U[i]
            s1 += F[i + 1] * U[i + 1]
            s2 += F[i + 2] * U[i + 2]
            s3 += F[i + 3] * U[i + 3]
            i += 4
        while i < end:
            s0 += F[i] * U[i]
            i += 1
        s += (s0 + s1) + (s2 + s3)
    return 0.5 * tri_quad(Md, Me, V) + 0.5 * tri_quad(Kd, Ke, U) - s + offset


@njit(cache=True)
def _repeat(f, Md, Me, Kd, Ke, F, U, V, reps):
    """f reps times in compiled code (no interpreter call per energy); U[0] moves by 1e-300
    each time, so that no call can be hoisted out of the loop."""
    s = 0.0
    for _ in range(reps):
        U[0] += 1e-300
        s += f(Md, Me, Kd, Ke, F, U, V, 0.0)
    return s


@njit(cache=True)
def _repeat_rows(f, Md, Me, Kd, Ke, F, U, V, reps):
    """`energy_rows` as a kernel's step loop calls it: the row sums computed once, before
    the loop (f is unused: the signature of `_repeat`)."""
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)
    s = 0.0
    for _ in range(reps):
        U[0] += 1e-300
        s += energy_rows(rM, Me, rK, Ke, F, U, V, 0.0)
    return s


def alone(ns: list[int], rounds: int) -> None:
    print(f"{'energy':<16} {'n':>7} {'ns per dof (median, min)':>26}")
    for n in ns:
        semi = discretise(make_case("clamped_bar"), mesh_nodes(1.0, n), "consistent")
        args = (semi.M.diag, semi.M.off, semi.K.diag, semi.K.off, semi.F, semi.U0.copy(),
                0.3 * semi.U0)
        reps = max(3, int(2e7 / n))
        fs = (("plain", plain_energy, _repeat), ("scalar blocks", scalar_energy, _repeat),
              ("energy_of", energy_of, _repeat), ("energy_rows", energy_of, _repeat_rows))
        times: dict[str, list[float]] = {name: [] for name, _, _ in fs}
        for _name, f, rep in fs:
            rep(f, *args, 1)
        for _ in range(rounds):  # interleaved: a load change hits every variant alike
            for name, f, rep in fs:
                start = time.perf_counter()
                rep(f, *args, reps)
                times[name].append((time.perf_counter() - start) / reps / n * 1e9)
        for name, _, _ in fs:
            t = times[name]
            print(f"{name:<16} {n:>7} {statistics.median(t):>17.3f} {min(t):>8.3f}")


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
            limit = scheme.stability_limit(semi)
            if limit is not None:
                dt = min(dt, 0.9 * limit)
            nsteps = max(200, int(args.work / semi.nfree) // 100 * 100)
            stepper = scheme.prepare(as_problem(semi, scheme.mass_kind()), dt)  # set-up
            stepper.run(1, 1)  # JIT compilation
            out = []
            for stride in (100, nsteps):
                stepper.run(nsteps, stride)
                times = []
                for _ in range(args.rounds):
                    start = time.perf_counter()
                    stepper.run(nsteps, stride)
                    times.append(time.perf_counter() - start)
                out.append(statistics.median(times) / (semi.nfree * nsteps) * 1e9)
            print(f"{spec:<16} {n:>7} {nsteps:>7} {out[0]:>11.3f} {out[1]:>14.3f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
