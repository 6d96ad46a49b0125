"""The explicit lumped step against one CSR product of its stiffness, measured in the same
run (issue 35's target: the step within 1.5x the product at 5e5 dofs).

    python -m pytest benchmarks/test_explicit_step.py --benchmark-columns=median,rounds

`test_explicit_step`: `taylor_flanagan[mass=lumped]` (central differences with a lumped
mass, the contact by a Taylor-Flanagan stop) on the P1 disc `disc_drop[degree=1]` at
`SIZES` rings, at 0.9 x its declared stability limit, prepared once, then
`run(STEPS, STEPS)` (samples at the first and last steps only) per round;
extra_info["step_us"] is its median time per step. The disc is lifted by 1e-6, so it
touches the plane from the first steps and the contact stop runs in every step.
`test_csr_product`: one product K u with the same K (`kernels.csr.csr_matvec`, the
compiled product the kernels use, on the arrays they are given). extra_info has the dofs of both.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.kernels.csr import csr_arrays, csr_matvec

#: P1 disc rings -> dofs: 160 -> 154,562, 285 -> 489,062
SIZES = {"nx160": 160, "nx285": 285}
STEPS = 50
SCHEME = "taylor_flanagan[mass=lumped]"
_PROBLEMS: dict[int, object] = {}


def problem(nx: int):
    if nx not in _PROBLEMS:
        _PROBLEMS[nx] = make_case("disc_drop[degree=1,lift=1e-06]").sparse_problem(
            nx, 1.0, make_scheme(SCHEME).mass_kind())
    return _PROBLEMS[nx]


@pytest.mark.parametrize("size", list(SIZES))
def test_explicit_step(benchmark, size):
    p = problem(SIZES[size])
    scheme = make_scheme(SCHEME)
    dt = 0.9 * scheme.stability_limit(p)
    stepper = scheme.prepare(p, dt)
    stepper.run(2, 2)  # compiled outside the timing
    benchmark.extra_info["dofs"] = p.nfree
    benchmark.pedantic(stepper.run, args=(STEPS, STEPS), rounds=5, warmup_rounds=1)
    benchmark.extra_info["step_us"] = 1e6 * benchmark.stats.stats.median / STEPS


@pytest.mark.parametrize("size", list(SIZES))
def test_csr_product(benchmark, size):
    K = sp.csr_matrix(problem(SIZES[size]).K)
    u = np.random.default_rng(0).standard_normal(K.shape[0])
    out = np.empty_like(u)
    args = (*csr_arrays(K), u, out)  # the arrays the kernels multiply with
    csr_matvec(*args)
    benchmark.extra_info["dofs"] = K.shape[0]
    benchmark(csr_matvec, *args)
