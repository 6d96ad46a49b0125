"""ns per dof-step of the kernels alone (setup excluded), same run; clamped_bar, consistent mass.

    python benchmarks/prototypes/simd_newmark/bench_k.py [newmark_b ...]

Compares schemes._newmark._implicit_kernel (unaligned and 64-byte aligned arrays) with
the prototype kernel(s) (aligned, unaligned, and with the load-vector loop forced),
at n = 1000 and 100000. Each figure: median (and min) over 5 repetitions of the
difference between a full run and a run of a tenth of the steps, so that the setup and
the first-call overheads cancel. Run it on an otherwise idle machine.
"""
import importlib
import inspect
import sys
import time
from functools import partial
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))  # repo root (bench, schemes)

import numpy as np
from newmark_b import aligned

from bench.fem import mesh_nodes
from bench.problem import discretise
from bench.registry import make_case
from schemes._common import allocate, energy_of, initial_acceleration
from schemes._newmark import _implicit_kernel
from schemes._spike import spike_factor


def setup_orig(semi, dt, nsteps, stride, beta=0.25, gamma=0.5, align=False):
    """Arguments of schemes._newmark._implicit_kernel (as run_newmark builds them)."""
    al = aligned if align else (lambda x: np.array(x, float))
    M, K = semi.M, semi.K
    U, V = semi.U0, semi.V0
    out = allocate(semi, nsteps, stride)
    out["U"][0], out["V"][0], out["cu"][0] = U, V, U[0]
    out["E"][0] = energy_of(M.diag, M.off, K.diag, K.off, semi.F, U, V, semi.energy_offset)
    bufs = (out["t"], out["U"], out["V"], out["cu"], out["s"], out["E"])
    bdt2 = beta * dt * dt
    sp = spike_factor(M.diag + bdt2 * K.diag, M.off + bdt2 * K.off)
    A = initial_acceleration(semi)
    Ut = sp.to_lanes(U + dt * V + (0.5 - beta) * dt * dt * A)
    lo, invd, sa, sb, Hrow, Hpos, Hval, ja, jb, m, pos = sp.factors()
    fac = (al(lo), al(invd), al(sa), al(sb), Hrow, Hpos, Hval, ja, jb, m, pos)
    args = (M.diag, M.off, K.diag, K.off, semi.F, al(sp.to_lanes(M.diag)),
            al(sp.lower_to_lanes(M.off)), al(sp.to_lanes(bdt2 * semi.F)), fac, sp.hw, sp.w0,
            al(Ut), al(sp.to_lanes(V)), al(sp.to_lanes(A)), al(np.zeros(sp.lanes * sp.m)),
            np.zeros(2 * sp.lanes + 1), float(U[0]), dt, beta, gamma, bool(semi.massless),
            int(nsteps), int(stride), semi.energy_offset, *bufs)
    return args, out


def timeit(kern, setup, semi, dt, ns, reps=5):
    """(median, min) over reps of ns per dof-step: a run of ns steps minus one of ns // 10."""
    best = []
    for _ in range(reps):
        a1, _out1 = setup(semi, dt, ns, ns)
        a2, _out2 = setup(semi, dt, ns // 10, ns // 10)
        t0 = time.perf_counter()
        kern(*a1)
        t1 = time.perf_counter()
        kern(*a2)
        t2 = time.perf_counter()
        best.append(((t1 - t0) - (t2 - t1)) / (semi.nfree * (ns - ns // 10)) * 1e9)
    return np.median(best), min(best)


def main(mods):
    case = make_case("clamped_bar")
    for n in (1000, 100000):
        semi = discretise(case, mesh_nodes(case.L, n), "consistent")
        dt = 0.5 * semi.hmin / semi.c_max
        ns = int(0.15 / (1.5e-9 * semi.nfree))

        res = {}
        res["orig"] = timeit(_implicit_kernel, setup_orig, semi, dt, ns)
        res["orig_al64"] = timeit(_implicit_kernel, partial(setup_orig, align=True), semi, dt, ns)
        for mn in mods:
            mod = importlib.import_module(mn)
            res[mn] = timeit(mod.kernel_a, mod.setup_a, semi, dt, ns)
            res[mn + "_unal"] = timeit(mod.kernel_a, partial(mod.setup_a, align=False),
                                       semi, dt, ns)
            if "force_load" in inspect.signature(mod.setup_a).parameters:
                res[mn + "_withF"] = timeit(mod.kernel_a, partial(mod.setup_a, force_load=True),
                                            semi, dt, ns)
        o = res["orig"][0]
        for k, (med, mn_) in res.items():
            print(f"n={semi.nfree:6d} steps={ns} {k:22s} median {med:.3f} min {mn_:.3f} "
                  f"ns/dof-step  ratio {med / o:.3f}")


if __name__ == "__main__":
    main(sys.argv[1:] or ["newmark_b"])
