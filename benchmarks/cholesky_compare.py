"""Direct solvers for the implicit schemes' SPD systems S = M + beta dt^2 K, measured on
the project's own matrices (the `redistributed` scheme's mass, beta = 1/4, the scene's dt):
factor time, one solve, and one solve with n_c right-hand sides (the Delassus matrix's
columns), for SuperLU (`contact_bench.kernels.linalg.Factor`, as the loops use it:
symmetric mode, the triangular solves in numba) under both of its orderings (minimum
degree on A^T + A, METIS's nested dissection), CHOLMOD (`cholespy`) and Pardiso
(`pypardiso`, MKL), whichever is installed.

    python benchmarks/cholesky_compare.py > results/cholesky_compare.md
    python benchmarks/cholesky_compare.py --matrix sphere_drop:16   # one matrix

SuperLU's n_c-RHS solve is `lu_solve_many` (its factor on a block of columns); its
"n_c x one solve" (how the set-up computed the Delassus matrix before) is computed. Each
time is the minimum of `REPEATS` calls (after one warm-up for the solves); the residual
is max |S x - b| / max |b| of the single solve. Times are perturbed by whatever
else runs on the machine.
"""

from __future__ import annotations

import os
import platform
import sys
import time

import numpy as np
import scipy
import scipy.sparse as sp

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core.ordering import forced_ordering
from contact_bench.kernels import linalg
from contact_bench.kernels.linalg import lu_solve, lu_solve_many

REPEATS = 3
#: (scene spec, nx): the sizes issue 35 asks about
MATRICES = (("sphere_drop", 16), ("disc_drop[degree=2]", 20), ("disc_drop[degree=2]", 40))


def best(fn, repeats: int = REPEATS) -> float:
    out = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        out = min(out, time.perf_counter() - start)
    return out


def superlu(S, b, B, nested: bool):
    """`Factor.of(S)` with nested dissection (`nested`) or minimum degree, whatever S's
    size (`forced_ordering`)."""
    with forced_ordering(nested):
        t_f = best(lambda: linalg.Factor.of(S), 1)
        arrays = linalg.Factor.of(S).arrays
    n = S.shape[0]
    x, w = np.empty(n), np.empty(n)
    lu_solve(arrays, b, x, w)
    t_1 = best(lambda: lu_solve(arrays, b, x, w))
    X, W = np.empty(B.shape), np.empty(B.shape)
    lu_solve_many(arrays, B, X, W)
    t_m = best(lambda: lu_solve_many(arrays, B, X, W), 1)
    t_cols = B.shape[1] * t_1  # the former set-up's way: one compiled solve per column
    nnz = arrays[2].size + arrays[5].size
    return {"factor_s": t_f, "solve_s": t_1, "multi_s": t_m,
            "columns_s": t_cols, "factor_nnz": nnz}, x


def cholmod(S, b, B):
    from cholespy import CholeskySolverD, MatrixType
    C = sp.csc_matrix(S)
    n = S.shape[0]

    def factor():
        return CholeskySolverD(n, C.indptr.astype(np.int32), C.indices.astype(np.int32),
                               C.data, MatrixType.CSC)
    t_f = best(factor, 1)
    ch = factor()
    x = np.empty(n)
    ch.solve(b, x)
    t_1 = best(lambda: ch.solve(b, x))
    X = np.empty_like(B)
    t_m = best(lambda: ch.solve(B, X), 1)
    return {"factor_s": t_f, "solve_s": t_1, "multi_s": t_m}, x


def pardiso(S, b, B):
    import pypardiso
    C = sp.csr_matrix(S)

    def factor():
        ps = pypardiso.PyPardisoSolver(mtype=2)  # real SPD
        ps.factorize(sp.triu(C, format="csr"))
        return ps
    t_f = best(factor, 1)
    ps = factor()
    U = sp.triu(C, format="csr")
    x = ps.solve(U, b)
    t_1 = best(lambda: ps.solve(U, b))
    t_m = best(lambda: ps.solve(U, B), 1)
    return {"factor_s": t_f, "solve_s": t_1, "multi_s": t_m}, x


def main(argv: list[str] | None = None) -> None:
    import argparse
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--matrix", action="append", metavar="SPEC:NX",
                    help="scene spec and nx (repeatable; default: MATRICES)")
    args = ap.parse_args(argv)
    matrices = ([(m.rsplit(":", 1)[0], int(m.rsplit(":", 1)[1])) for m in args.matrix]
                if args.matrix else MATRICES)
    cmd = " ".join(["python benchmarks/cholesky_compare.py",
                    *(f"--matrix '{m}'" for m in args.matrix or ())])
    print("# Direct solvers on the implicit schemes' S = M + dt^2/4 K\n")
    print(f"`{cmd}`; "
          f"python {platform.python_version()}, scipy {scipy.__version__}, "
          f"{platform.machine()}, {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.1f} at the start.\n")
    rows = []
    for spec, nx in matrices:
        case, scheme = make_case(spec), make_scheme("redistributed")
        p = case.sparse_problem(nx, 1.0, scheme.mass_kind())
        S = sp.csr_matrix(p.M + 0.25 * case.dt ** 2 * p.K)
        n, nc = S.shape[0], p.contact.size
        rng = np.random.default_rng(0)
        b = rng.standard_normal(n)
        B = np.zeros((n, nc))
        B[np.asarray(p.contact.dofs), np.arange(nc)] = 1.0
        for name, fn in (("SuperLU, minimum degree", lambda *a: superlu(*a, False)),
                         ("SuperLU, nested dissection", lambda *a: superlu(*a, True)),
                         ("CHOLMOD (cholespy)", cholmod),
                         ("Pardiso (pypardiso)", pardiso)):
            try:
                res, x = fn(S, b, B)
            except ImportError as exc:
                print(f"{name}: not installed ({exc})", file=sys.stderr)
                continue
            res["residual"] = float(np.max(np.abs(S @ x - b)) / np.max(np.abs(b)))
            rows.append({"matrix": f"{spec} nx {nx}", "dofs": n, "n_c": nc, "solver": name,
                         **res})
            print(rows[-1], file=sys.stderr, flush=True)
    import pandas as pd
    df = pd.DataFrame(rows)
    for c in ("factor_s", "solve_s", "multi_s", "columns_s"):
        df[c] = df[c].map(lambda v: "" if pd.isna(v) else f"{v * 1e3:.1f}")
    df = df.rename(columns={"factor_s": "factor ms", "solve_s": "one solve ms",
                            "multi_s": "n_c-RHS solve ms",
                            "columns_s": "n_c x one solve ms", "factor_nnz": "L+U nnz"})
    df["L+U nnz"] = df["L+U nnz"].map(lambda v: "" if pd.isna(v) else f"{int(v):,}")
    df["residual"] = df["residual"].map(lambda v: f"{v:.1e}")
    print(df.to_markdown(index=False))
    print("\nSuperLU's 'one solve' is the numba triangular solves of its L and U "
          "(`lu_solve`, what the stepping loops do); its n_c-RHS solve is `lu_solve_many` "
          "(the factor on a block of columns); 'n_c x one solve' (the former set-up's "
          "way) is computed, not measured.")


if __name__ == "__main__":
    main()
