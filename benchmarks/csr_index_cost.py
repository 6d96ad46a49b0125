"""The loops' CSR product (`contact_bench.kernels.csr.csr_matvec`) over 32-bit and 64-bit
indices on the same stiffness matrix, alternated in one process, best of 5 rounds of
`--calls` products each, compiled outside the timing: why `csr.INDEX` is 64-bit.

    python benchmarks/csr_index_cost.py                  # disc_drop[degree=2] nx 6 and 24
    python benchmarks/csr_index_cost.py --nx 6,24,96 --calls 2000
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def best_us(call, args, calls: int, rounds: int = 5) -> float:
    """Best time of one call over `rounds` rounds of `calls` calls, in microseconds."""
    best = float("inf")
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(calls):
            call(*args)
        best = min(best, (time.perf_counter() - t0) / calls)
    return best * 1e6


def main() -> None:
    from contact_bench.api.registry import make_case, make_scheme
    from contact_bench.kernels.csr import csr_matvec

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="disc_drop[degree=2]")
    ap.add_argument("--nx", default="6,24")
    ap.add_argument("--calls", type=int, default=5000)
    a = ap.parse_args()
    print("| scene | dofs | K entries | 32-bit us | 64-bit us | 32-bit / 64-bit |")
    print("|---|---|---|---|---|---|")
    for nx in (int(v) for v in a.nx.split(",")):
        K = make_case(a.case).sparse_problem(nx, 1.0, make_scheme("standard").mass_kind()).K
        x = np.random.default_rng(0).random(K.shape[0])
        out = np.empty_like(x)
        times = {}
        for ix in (np.int32, np.int64):
            args = (K.indptr.astype(ix), K.indices.astype(ix), K.data, x, out)
            csr_matvec(*args)  # compiles this index type's version
            times[ix] = args
        t32 = t64 = float("inf")
        for _ in range(3):  # alternated
            t32 = min(t32, best_us(csr_matvec, times[np.int32], a.calls))
            t64 = min(t64, best_us(csr_matvec, times[np.int64], a.calls))
        print(f"| {a.case} nx {nx} | {K.shape[0]:,} | {K.nnz:,} | {t32:.2f} | {t64:.2f} "
              f"| {t32 / t64:.2f} |")


if __name__ == "__main__":
    main()
