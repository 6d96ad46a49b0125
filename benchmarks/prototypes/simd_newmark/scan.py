"""n scan of ns per dof-step: current kernel (64-byte aligned) against newmark_b, F = 0
and with the load-vector loop forced (B+F); clamped_bar, consistent mass.

    python benchmarks/prototypes/simd_newmark/scan.py

Same method as bench_k.timeit (median of 5). Run it on an otherwise idle machine.
"""
import sys
from functools import partial
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))  # repo root (bench, schemes)

import newmark_b as mod
from bench_k import setup_orig, timeit

from bench.fem import mesh_nodes
from bench.problem import discretise
from bench.registry import make_case
from schemes._newmark import _implicit_kernel


def main():
    case = make_case("clamped_bar")
    for n in (250, 400, 600, 1000, 2000, 5000, 20000, 100000):
        semi = discretise(case, mesh_nodes(case.L, n), "consistent")
        dt = 0.5 * semi.hmin / semi.c_max
        ns = int(0.15 / (1.0e-9 * semi.nfree))
        o = timeit(_implicit_kernel, partial(setup_orig, align=True), semi, dt, ns)[0]
        b = timeit(mod.kernel_a, mod.setup_a, semi, dt, ns)[0]
        bf = timeit(mod.kernel_a, partial(mod.setup_a, force_load=True), semi, dt, ns)[0]
        N = 16 * -(-semi.nfree // 16)
        print(f"n={semi.nfree:6d} arrays {N * 8 / 1024:7.1f} KB each | orig_al64 {o:.3f} | "
              f"B {b:.3f} | B+F {bf:.3f} ns/dof-step")


if __name__ == "__main__":
    main()
