"""One solve with a scheme's factor of S on test_stepping.py's bar, beside SuperLU's
(`scipy.sparse.linalg.splu`) on the same S: which factor the stepper chose and what one
solve costs with it, best of 5 runs of 50 solves, compiled outside the timing.

    python benchmarks/bar_solve_time.py laursen_love 100000
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.sparse.linalg import splu

sys.path.insert(0, str(Path(__file__).parent))
from test_stepping import _setup  # noqa: E402

from contact_bench.api.problem import as_problem  # noqa: E402
from contact_bench.kernels.linalg import lu  # noqa: E402


@njit
def _solves(fac, b, out, work, k):  # pragma: no cover - compiled
    for _ in range(k):
        lu(fac, b, out, work)


def best_ms(call, repeats: int = 5, k: int = 50) -> float:
    """Best time of one of k calls over `repeats` runs, in ms."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        call(k)
        best = min(best, (time.perf_counter() - t0) / k)
    return best * 1e3


def main(spec: str, n: int) -> None:
    scheme, semi, dt, _ = _setup(spec, n, 1)
    problem = as_problem(semi, scheme.mass_kind())
    stepper = scheme.prepare(problem, dt)
    fac = stepper.ops.fac
    kind = "PARDISO" if fac.ph.size else "SuperLU's LU sweep"
    S = sp.csc_matrix(problem.M + 0.25 * dt * dt * problem.K)
    b = np.random.default_rng(0).random(S.shape[0])
    out, work = np.empty_like(b), np.empty_like(b)
    _solves(fac, b, out, work, 1)
    own = best_ms(lambda k: _solves(fac, b, out, work, k))
    lu_s = splu(S)
    ref = best_ms(lambda k: [lu_s.solve(b) for _ in range(k)])
    print(f"{spec} n{n}: the stepper's factor ({kind}) {own:.3f} ms a solve; "
          f"splu {ref:.3f} ms")


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]))
