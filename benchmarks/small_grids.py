"""Stepping and recording cost on the grids the study plots, in ns per dof-step, in one run.

    python benchmarks/small_grids.py [--nx 20 40 80 160 320 640 1000] [--repeats 7]

For each nx (clamped bar, dt = 0.5 h or 0.9 x a lower stability limit, nsteps =
dof-steps / nfree, or T / dt with
`--T`: the study's runs; a bar's band factorisation is inside each call) and each
scheme it prints the minimum over `repeats` calls (after a warm-up call) of the
scheme's stepper, prepared once outside the timing (`stepper.run`), with stride =
nsteps (stepping: two samples) and with stride 1 (every step recorded, as the error
norms need), per dof-step; `rec` is their difference. `spec@serial` and `spec@spike`
force one form of the Newmark kernels (`contact_bench.kernels.newmark.kernel_form`), or
of ode_verlet and taylor_flanagan (`fast`: serial = their natural-order kernels),
the plain rows use the form chosen by size: the crossover `SERIAL_BELOW` is where the
two forced rows cross. All timings of one nx are taken interleaved (scheme by scheme in
every repeat), so a load change of the shared machine hits them alike; ratios within a
line are what to read. A scheme whose run at stride 1 stopped early (a blow-up of the
energy, which only sampled steps detect) is marked `blew up` and its rec1 is not a cost.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from contact_bench.api import as_problem  # noqa: E402
from contact_bench.api.fem import mesh_nodes  # noqa: E402
from contact_bench.api.problem import discretise  # noqa: E402
from contact_bench.api.registry import make_case, make_scheme  # noqa: E402
from contact_bench.kernels import newmark  # noqa: E402
from contact_bench.schemes import ode_verlet, taylor_flanagan  # noqa: E402

SPECS = ["redistributed", "redistributed@serial", "redistributed@spike", "standard",
         "standard@serial", "standard@spike", "redistributed[beta=0]",
         "redistributed[beta=0]@serial", "redistributed[beta=0]@spike", "nitsche",
         "restitution", "ode_verlet", "ode_verlet@serial", "ode_verlet@spike",
         "taylor_flanagan", "taylor_flanagan@serial", "taylor_flanagan@spike"]
DOF_STEPS = 4e6  # dof-steps per call: ~4-40 ms, far above the per-call set-up


def _runner(spec: str, nx: int, dof_steps: float = DOF_STEPS, T: float | None = None):
    """(call(stride) -> None, nfree, nsteps) for one scheme, form forced if asked."""
    name, _, form = spec.partition("@")
    form = form or None
    case = make_case("clamped_bar")
    scheme = make_scheme(name)
    semi = discretise(case, mesh_nodes(case.L, nx), scheme.mass_kind())
    dt = 0.5 * semi.hmin / semi.c_max
    limit = scheme.stability_limit(semi)
    if limit is not None:
        dt = min(dt, 0.9 * limit)
    nsteps = (max(100, int(dof_steps / semi.nfree)) if T is None
              else max(1, math.ceil(T / dt - 1e-9)))
    scheme.integrate(semi, 1e-3 * semi.hmin / semi.c_max, 1, 1)
    stepper = scheme.prepare(as_problem(semi, scheme.mass_kind()), dt)  # set-up, untimed

    def call(stride: int) -> int:
        if form is None:
            traj = stepper.run(nsteps, stride)
        elif scheme.name == "ode_verlet":
            traj = ode_verlet.run_ode_verlet(semi, dt, nsteps, stride, form == "spike")
        elif scheme.name == "taylor_flanagan":
            traj = taylor_flanagan.run_taylor_flanagan(semi, dt, nsteps, stride,
                                                       form == "spike")
        else:
            traj = newmark.run_newmark(semi, dt, nsteps, stride, scheme.beta, scheme.gamma,
                                       form)
        return traj.steps_done

    return call, semi.nfree, nsteps


def recording_parts(nxs: list[int], repeats: int, dof_steps: float = DOF_STEPS) -> None:
    """What a recorded step costs beyond stepping, part by part, in ns per dof-step: the
    shared `energy_rows` (row sums computed once, as the kernels do) and `record_sample`
    of `contact_bench.core.sampling` in a compiled loop (sample buffers already written
    once), and the first write of fresh sample
    buffers (`np.zeros`, as `contact_bench.kernels.common.allocate` makes them: the page
    faults). Minimum of `repeats`."""
    import numpy as np
    from numba import njit

    from contact_bench.core.sampling import Samples, energy_rows, record_sample, row_sums

    @njit
    def energies(Md, Me, Kd, Ke, F, U, V, reps):
        rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)
        s = 0.0
        for _ in range(reps):
            U[0] += 1e-300
            s += energy_rows(rM, Me, rK, Ke, F, U, V, 0.0)
        return s

    @njit
    def records(U, V, reps, out):
        for r in range(reps):
            record_sample(r, 0.1, U, V, 0.0, 1.0, out)

    print("| nx | energy_rows | record_sample (warm) | fresh buffers (first write) |")
    print("|---|---|---|---|")
    rng = np.random.default_rng(0)
    for nx in nxs:
        a = [rng.random(nx) for _ in range(7)]
        reps = max(100, int(dof_steps / nx))
        bufs = Samples(np.zeros(reps), np.zeros((reps, nx)), np.zeros((reps, nx)),
                       np.zeros(reps), np.zeros(reps), np.zeros(reps))
        energies(*a, 2)
        records(a[0], a[1], 2, bufs)
        best = [np.inf, np.inf, np.inf]
        for _ in range(repeats):
            t0 = time.perf_counter()
            energies(*a, reps)
            t1 = time.perf_counter()
            records(a[0], a[1], reps, bufs)
            t2 = time.perf_counter()
            U, V = np.zeros((reps, nx)), np.zeros((reps, nx))
            U[:] = 1.0
            V[:] = 1.0
            t3 = time.perf_counter()
            del U, V
            for j, el in enumerate((t1 - t0, t2 - t1, t3 - t2)):
                best[j] = min(best[j], el)
        e, r, f = (b / (reps * nx) * 1e9 for b in best)
        print(f"| {nx} | {e:.2f} | {r:.2f} | {f:.2f} |")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nx", type=int, nargs="+", default=[20, 40, 80, 160, 320, 640, 1000])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--specs", nargs="+", default=SPECS)
    ap.add_argument("--dof-steps", type=float, default=DOF_STEPS,
                    help="dof-steps per call (steps = this / nfree, at least 100)")
    ap.add_argument("--T", type=float, default=None,
                    help="instead: one run of the scene to time T (the study's run: the "
                         "per-call set-up, factors and buffers, counts in every dof-step)")
    ap.add_argument("--recording-parts", action="store_true",
                    help="time the parts of recording (energy_rows, record_sample, fresh "
                         "buffers) instead of the schemes")
    args = ap.parse_args(argv)
    if args.recording_parts:
        recording_parts(args.nx, args.repeats, args.dof_steps)
        return 0
    work = (f"T = {args.T:g} per call" if args.T is not None
            else f"{args.dof_steps:g} dof-steps per call")
    print(f"SERIAL_BELOW = {newmark.SERIAL_BELOW}; {work}; min of {args.repeats} calls; "
          "ns per dof-step: step (stride = nsteps), rec1 (stride 1), rec = rec1 - step")
    print("| nx | scheme | step | rec1 | rec |")
    print("|---|---|---|---|---|")
    for nx in args.nx:
        runs = {spec: _runner(spec, nx, args.dof_steps, args.T) for spec in args.specs}
        best: dict[tuple[str, int], float] = {}
        blew: set[str] = set()
        for spec, (call, _, nsteps) in runs.items():
            call(nsteps)
            if call(1) < nsteps:
                blew.add(spec)
        for _ in range(args.repeats):
            for spec, (call, _, nsteps) in runs.items():
                for stride in (nsteps, 1):
                    start = time.perf_counter()
                    call(stride)
                    el = time.perf_counter() - start
                    key = (spec, stride)
                    best[key] = min(best.get(key, el), el)
        for spec, (_, nfree, nsteps) in runs.items():
            step = best[(spec, nsteps)] / (nfree * nsteps) * 1e9
            rec1 = best[(spec, 1)] / (nfree * nsteps) * 1e9
            rec = "blew up" if spec in blew else f"{rec1 - step:.2f}"
            print(f"| {nx} | {spec} | {step:.2f} | {rec1:.2f} | {rec} |")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
