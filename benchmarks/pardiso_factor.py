"""PARDISO's factor of a scene's S = M + dt^2/4 K alone (issue 48, item 4): the dofs, L's
entries, the factor's memory (iparm[15] + iparm[16]), the assembly and factorisation
times, one solve, and the process's peak memory. For estimating a larger size's factor
from smaller ones without running it.

    python benchmarks/pardiso_factor.py "sphere_drop[degree=1,lift=1e-6,ball=lattice]" 24
"""

from __future__ import annotations

import argparse
import json
import resource
import time

import numpy as np


def main(argv: list[str] | None = None) -> None:
    from contact_bench.api.registry import make_case, make_scheme
    from contact_bench.kernels import linalg

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("nx", type=int)
    a = ap.parse_args(argv)
    case, sch = make_case(a.scene), make_scheme("redistributed")
    t0 = time.perf_counter()
    p = case.sparse_problem(a.nx, 1.0, sch.mass_kind())
    t_asm = time.perf_counter() - t0
    dt = float(case.dt)
    S = p.M + 0.25 * dt * dt * p.K
    t0 = time.perf_counter()
    f = linalg.Factor.of(S, pardiso=True)
    t_fac = time.perf_counter() - t0
    b, x, w = np.ones(p.nfree), np.empty(p.nfree), np.empty(p.nfree)
    linalg.lu_solve(f.arrays, b, x, w)
    solve = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        linalg.lu_solve(f.arrays, b, x, w)
        solve = min(solve, time.perf_counter() - t0)
    mk = sum(m.data.nbytes + m.indices.nbytes + m.indptr.nbytes
             for m in (p.M.tocsr(), p.K.tocsr()))
    print(json.dumps({
        "scene": a.scene, "nx": a.nx, "dofs": p.nfree, "kind": f.kind, "fallback": f.fallback,
        "L entries": f.entries, "factor GB": round(f.nbytes / 2**30, 3),
        "M K GB": round(mk / 2**30, 3), "assembly s": round(t_asm, 1),
        "factor s": round(t_fac, 1), "solve ms": round(1e3 * solve, 1),
        "peak GB": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20, 2)}))


if __name__ == "__main__":
    main()
