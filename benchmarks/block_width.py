"""The width of `Factor.solve_many`'s blocks: seconds per right-hand side of SuperLU's
block solve (`lu_solve_many`, the set-up's Delassus and Schur columns) against the number
of columns solved at once, on the implicit schemes' S = M + dt^2/4 K of a scene (the
`redistributed` scheme's mass, the scene's dt), the columns being the contact dofs' unit
vectors. Each time is the minimum of `REPEATS` calls after one warm-up.

    python benchmarks/block_width.py > results/cholesky/block_width.md
    python benchmarks/block_width.py --matrix 'disc_drop[degree=2]:40' --width 16 --width 64
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np
import pandas as pd
import scipy.sparse as sp

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core.errors import BenchError
from contact_bench.kernels.linalg import Factor, lu_solve_many

REPEATS = 3
MATRICES = ("sphere_drop:16", "disc_drop[degree=2]:40")
WIDTHS = (8, 16, 32, 64, 128, 256)


def per_column(arrays: tuple, B: np.ndarray) -> float:
    """The best of `REPEATS` block solves of B, per column (seconds)."""
    X, W = np.empty(B.shape), np.empty(B.shape)
    lu_solve_many(arrays, B, X, W)
    best = np.inf
    for _ in range(REPEATS):
        start = time.perf_counter()
        lu_solve_many(arrays, B, X, W)
        best = min(best, time.perf_counter() - start)
    return best / B.shape[1]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--matrix", action="append", metavar="SPEC:NX",
                    help="scene spec and nx (repeatable; default: MATRICES)")
    ap.add_argument("--width", action="append", type=int, metavar="K",
                    help="columns per block (repeatable; default: WIDTHS)")
    args = ap.parse_args(argv)
    bad = [k for k in args.width or () if k < 1]
    if bad:
        ap.error(f"--width must be >= 1, got {bad[0]}")
    matrices = []
    for m in args.matrix or MATRICES:
        spec, _, nx = m.rpartition(":")
        if not spec or not nx.isdigit() or int(nx) < 1:
            ap.error(f"--matrix {m!r}: expected SPEC:NX with NX >= 1 (e.g. sphere_drop:16)")
        try:  # the registry's own check: a one-line error naming the bad scene
            matrices.append((spec, int(nx), make_case(spec)))
        except BenchError as exc:
            ap.error(str(exc))
    rows = []
    for spec, nx, case in matrices:
        p = case.sparse_problem(nx, 1.0, make_scheme("redistributed").mass_kind())
        fac = Factor.of(sp.csr_matrix(p.M + 0.25 * case.dt ** 2 * p.K))
        cd = np.asarray(p.contact.dofs, np.int64)
        for k in args.width or WIDTHS:
            k = min(k, cd.size)
            B = np.zeros((p.nfree, k))
            B[cd[:k], np.arange(k)] = 1.0
            rows.append({"matrix": f"{spec} nx {nx}", "dofs": p.nfree,
                         "L+U nnz": f"{fac.arrays[2].size + fac.arrays[5].size:,}",
                         "columns per block": k, "ms per column": per_column(fac.arrays, B)
                         * 1e3})
    cmd = "python benchmarks/block_width.py" + "".join(
        f" --matrix '{m}'" for m in args.matrix or ()) + "".join(
        f" --width {k}" for k in args.width or ())
    print("# SuperLU's block solve: time per column against the block's width\n")
    print(f"`{cmd}`; python {platform.python_version()}, {platform.machine()}, "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the end.\n")
    df = pd.DataFrame(rows)
    print(df.to_markdown(index=False, floatfmt=".2f"))


if __name__ == "__main__":
    main()
