"""Where an implicit run's resident memory is at its peak (issue 48): one configuration of
benchmarks/solver_floor.py (`redistributed`, PARDISO for every SPD factor), built,
prepared and stepped twice (`--steps` each, compiling first), then its resident set
(VmRSS) split by owner, GB:

    python benchmarks/peak_breakdown.py "disc_drop[degree=2,lift=1e-6]:96"

Each part is the bytes of its owner's arrays (an array counted once, however many
owners share it), PARDISO's factor its own report (iparm[15] + iparm[16]), the contact
patch only its filled rows (the rest is untouched `np.zeros` pages). The process before
building is its VmRSS after the imports; "the rest" is the difference: compiled code,
pages the allocator keeps after a free, Python objects.
"""

from __future__ import annotations

import argparse
import gc
from typing import Any

import numpy as np
import scipy.sparse as sp


def array_bytes(x: Any, seen: set[int]) -> int:
    """The bytes of the arrays reachable from x (arrays, sparse matrices, tuples and
    objects' attributes), each counted once across calls sharing `seen` (a view as its
    root array: two views of one buffer count it once)."""
    if id(x) in seen:
        return 0
    seen.add(id(x))
    if isinstance(x, np.ndarray):  # a view counts its root array's bytes, once
        root = x
        while isinstance(root.base, np.ndarray):
            root = root.base
        if root is not x:
            if id(root) in seen:
                return 0
            seen.add(id(root))
        return int(root.nbytes)
    if sp.issparse(x):
        return sum(array_bytes(getattr(x, a), seen) for a in ("data", "indices", "indptr")
                   if hasattr(x, a))
    if isinstance(x, tuple | list):
        return sum(array_bytes(v, seen) for v in x)
    if hasattr(x, "__dict__"):
        return sum(array_bytes(v, seen) for v in vars(x).values())
    return 0


def breakdown(config: str, steps: int) -> dict[str, float]:
    """The parts of the resident set at the end of the run, GB (module docstring)."""
    from scale import rss_mib

    from contact_bench.api.registry import make_case, make_scheme
    from contact_bench.core import ordering
    from contact_bench.kernels import linalg

    linalg.PARDISO_MIN_DOFS = ordering.pardiso.PARDISO_MIN_DOFS = 0
    spec, nx = config.rsplit(":", 1)
    case, sch = make_case(spec), make_scheme("redistributed")
    before = rss_mib() / 1024
    p = case.sparse_problem(int(nx), 1.0, sch.mass_kind())
    st = sch.prepare(p, float(case.dt))
    st.run(steps, steps)
    st.run(steps, steps)
    gc.collect()
    rss = rss_mib() / 1024
    seen: set[int] = set()
    fac, ops = st.factor, st.ops
    body = case.body(int(nx))
    ct = ops.ct
    zcol = np.asarray(ct.zcol)
    filled = int(np.count_nonzero(zcol >= 0)) * p.nfree * 8 if zcol.size > 1 else 0
    parts = {"the process before building (imports)": before * 2**30,
             "M and K (the problem's CSR)": array_bytes(p.M, seen) + array_bytes(p.K, seen),
             "the factor (PARDISO's iparm[15] + iparm[16], or the loops' arrays)": fac.nbytes}
    if fac.pardiso is not None:
        pa = fac.pardiso
        parts["the factor's copy of S's upper triangle"] = sum(
            array_bytes(a, seen) for a in (pa.a, pa.ia, pa.ja))
    parts["the loops' CSR copies of M and K"] = (array_bytes(ops.M, seen)
                                                 + array_bytes(ops.K, seen))
    seen.add(id(getattr(ct, "Z", None)))  # the patch: its filled rows only, below
    parts["the body, the other operators, the problem's vectors"] = (
        array_bytes(body, seen) + array_bytes(ops, seen) + filled + array_bytes(p, seen))
    out = {k: v / 2**30 for k, v in parts.items()}
    out["the rest: compiled code, freed but resident pages, Python objects"] = (
        rss - sum(out.values()))
    mk = sum(m.data.nbytes + m.indices.nbytes + m.indptr.nbytes
             for m in (sp.csr_matrix(p.M), sp.csr_matrix(p.K)))
    out["resident at the end"] = rss
    out["M K factor"] = (mk + fac.nbytes) / 2**30
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config", help="scene:nx, as benchmarks/solver_floor.py")
    ap.add_argument("--steps", type=int, default=20, help="steps a run (two runs)")
    a = ap.parse_args(argv)
    print("| part | GB |\n|---|---|")
    for k, v in breakdown(a.config, a.steps).items():
        print(f"| {k} | {v:.3f} |")


if __name__ == "__main__":
    main()
