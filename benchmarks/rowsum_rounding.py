"""How far the assembled stiffness is from zero row sums, and what that does to U.K.U.

For clamped_bar (u0 linear) and dropped_bar (a rigid translation, u0 = 5), at each nx:
the number of interior rows whose float row sum d_i + e_{i-1} + e_i is not 0, the
largest |r_i| / d_i, and U.K.U three ways: the plain sum (d u^2 + 2 e u u'), the float
matrix's exact form (math.fsum of r_i u_i^2 - e_i (u_{i+1} - u_i)^2) and the bar's
(`contact_bench.core.tridiag.tri_quad`: rounding-level row sums taken as 0). The exact
values: 1/4 (clamped_bar, E = 1/8) and 0 (a translation strains nothing).

    python benchmarks/rowsum_rounding.py      # output in results/energy/rowsum_rounding.txt
"""

from __future__ import annotations

import math

import numpy as np

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case
from contact_bench.core.tridiag import tri_quad


def plain(d: np.ndarray, e: np.ndarray, x: np.ndarray) -> float:
    s = 0.0
    for i in range(d.size):
        s += d[i] * x[i] * x[i]
    for i in range(d.size - 1):
        s += 2.0 * e[i] * x[i] * x[i + 1]
    return s


def main() -> int:
    print(f"{'case':<12} {'nx':>8} {'rows r!=0':>10} {'max|r|/d':>9} {'plain U.K.U':>13} "
          f"{'float K exact':>14} {'bar (tri_quad)':>15}")
    for name in ("clamped_bar", "dropped_bar"):
        for nx in (1_000, 100_000, 1_000_000):
            case = make_case(name)
            semi = discretise(case, mesh_nodes(case.L, nx))
            d, e, U = semi.K.diag, semi.K.off, semi.U0
            r = d.copy()
            r[1:] += e
            r[:-1] += e
            du = np.diff(U)
            exact_float = math.fsum(r * U * U) - math.fsum(e * du * du)
            inner = r[1:-1]
            print(f"{name:<12} {nx:>8} {np.count_nonzero(inner):>10} "
                  f"{np.max(np.abs(inner) / d[1:-1]):>9.2e} {plain(d, e, U):>13.6g} "
                  f"{exact_float:>14.10g} {tri_quad(d, e, U):>15.12g}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
