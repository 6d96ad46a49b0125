"""Cost of a step on the general sparse problem (issue 24), at about 1e4 and 1e5 dofs.

The body: a P1 plane-strain disc (radius 1, E = 50, nu = 0.25, rho = 1) resting on the
plane y = -1 under gravity, contact zone y < -0.8 of its boundary (so the contact
subproblem is solved at every step); `MeshTri1.init_circle(r)` with r = 6 (16,642 dofs)
and r = 7 (66,050 dofs).

Pairs measured in the same run (median of rounds):
- `explicit_step` (one step of `central_sparse` with the lumped mass, the marginal cost
  between two run lengths) against `csr_product` (one K @ u, the same numba CSR loop);
- `implicit_step` (one step of `newmark_sparse`, marginal, so the factorisation and the
  Delassus matrix are not in it) against `solve_pair` (the two triangular solves of the
  factor) plus `contact_subproblem` (the LCP on the Delassus matrix of the active set
  and the correction X += Z mu).

    python -m pytest benchmarks/test_sparse.py --benchmark-columns=median,iqr,rounds

Also `test_assembly`: scikit-fem assembly of a P1 disc at 66,050 and 263,170 dofs.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
import skfem as fe
from numba import njit

from contact_bench.api import fem_nd
from contact_bench.api.sparse import ContactSet, SparseProblem
from contact_bench.kernels.contact import contact_ops
from contact_bench.kernels.sparse import (
    Factor,
    central_sparse,
    csr_arrays,
    csr_matvec,
    lcp_solve,
    lu_solve,
    newmark_sparse,
)


@njit(cache=True)
def correct(Z, mu, X):  # the kernel's correction loop (`_newmark_kernel`)
    on = np.flatnonzero(mu)
    for i in range(X.size):
        acc = 0.0
        for j in on:
            acc += Z[i, j] * mu[j]
        X[i] += acc


SIZES = {"1e4": 6, "1e5": 7}  # init_circle refinements: 16,642 and 66,050 dofs
_PROBLEMS: dict[tuple[int, str], SparseProblem] = {}


def disc(refine: int, mass: str) -> SparseProblem:
    key = (refine, mass)
    if key not in _PROBLEMS:
        body = fem_nd.assemble(fe.MeshTri1.init_circle(refine), 50.0, 0.25, 1.0)
        X = body.dof_coordinates
        zone = body.boundary_facets(lambda x: x[1] < -0.8)
        cs = np.unique(body.scalar.get_dofs(zone).flatten())
        M = fem_nd.mass_matrix(body, mass, cs)
        F = fem_nd.body_force(M, 2, np.array([0.0, -1.0]))
        n = body.ndofs
        _PROBLEMS[key] = SparseProblem(
            M=M, K=body.K, F=F, U0=np.zeros(n), V0=np.zeros(n),
            contact=ContactSet(2 * cs + 1, X[1, cs] + 1.0, np.ones(cs.size)), dim=2,
            hmin=body.hmin, c_max=body.wave_speed)
    return _PROBLEMS[key]


def marginal(run, n1: int, n2: int, out: list[float]) -> None:
    """Append the seconds per step (time of n2 steps - time of n1 steps) / (n2 - n1)
    to `out`: the benchmark's own time is that of both runs; the step's is the median
    of `out`, kept in extra_info["step_us"]."""
    t = []
    for n in (n1, n2):
        start = time.perf_counter()
        run(n)
        t.append(time.perf_counter() - start)
    out.append((t[1] - t[0]) / (n2 - n1))


@pytest.mark.parametrize("size", list(SIZES))
def test_explicit_step(benchmark, size):
    p = disc(SIZES[size], "lumped")
    dt = 0.5 * p.hmin / p.c_max
    central_sparse(p, dt, 2, 2)  # compiled outside the timing
    benchmark.extra_info["dofs"] = p.nfree
    steps: list[float] = []
    benchmark.pedantic(marginal, args=(lambda n: central_sparse(p, dt, n, n), 20, 1020, steps),
                       rounds=5)
    benchmark.extra_info["step_us"] = 1e6 * float(np.median(steps))


@pytest.mark.parametrize("size", list(SIZES))
def test_csr_product(benchmark, size):
    p = disc(SIZES[size], "lumped")
    Kp, Ki, Kx = csr_arrays(p.K)
    u, out = np.random.default_rng(0).standard_normal(p.nfree), np.empty(p.nfree)
    csr_matvec(Kp, Ki, Kx, u, out)
    benchmark.extra_info["dofs"] = p.nfree
    benchmark(csr_matvec, Kp, Ki, Kx, u, out)


@pytest.mark.parametrize("size", list(SIZES))
def test_implicit_step(benchmark, size):
    p = disc(SIZES[size], "consistent")
    dt = 10 * p.hmin / p.c_max
    newmark_sparse(p, dt, 2, 2, 0.25, 0.5)
    benchmark.extra_info["dofs"] = p.nfree
    benchmark.extra_info["contact_dofs"] = p.contact.size
    steps: list[float] = []
    benchmark.pedantic(marginal, args=(
        lambda n: newmark_sparse(p, dt, n, n, 0.25, 0.5), 5, 45, steps), rounds=3)
    benchmark.extra_info["step_us"] = 1e6 * float(np.median(steps))


@pytest.mark.parametrize("size", list(SIZES))
def test_solve_pair(benchmark, size):
    p = disc(SIZES[size], "consistent")
    dt = 10 * p.hmin / p.c_max
    fac = Factor.of(p.M + 0.25 * dt * dt * p.K)
    b = np.random.default_rng(0).standard_normal(p.nfree)
    out, work = np.empty(p.nfree), np.empty(p.nfree)
    lu_solve(fac.arrays, b, out, work)
    benchmark.extra_info["dofs"] = p.nfree
    benchmark(lu_solve, fac.arrays, b, out, work)


@pytest.mark.parametrize("warm", [True, False], ids=["warm", "cold"])
@pytest.mark.parametrize("size", list(SIZES))
def test_contact_subproblem(benchmark, size, warm):
    """The LCP of an in-contact step (the free solution penetrating at the lowest third
    of the contact dofs) and the correction of the whole state (X += Z mu, as the
    kernel does it); warm: started from the previous step's active set, as the kernel
    does while in contact; cold: from {q < 0}, as at a first contact."""
    p = disc(SIZES[size], "consistent")
    dt = 10 * p.hmin / p.c_max
    fac = Factor.of(p.M + 0.25 * dt * dt * p.K)
    cd = np.asarray(p.contact.dofs, np.int64)
    ct = contact_ops(fac, p.contact.gap_operator(p.nfree), p.contact.gap0, keep=True)
    Z, W = ct.Z, ct.W
    g0 = np.asarray(p.contact.gap0, float)
    q = g0 - np.quantile(g0, 1 / 3)
    mu, active = np.zeros(cd.size), np.zeros(cd.size, bool)
    X = np.zeros(p.nfree)

    def subproblem():
        lcp_solve(W, q, mu, active, 1e-14, warm)
        correct(Z, mu, X)

    subproblem()
    benchmark.extra_info["dofs"] = p.nfree
    benchmark.extra_info["contact_dofs"] = int(cd.size)
    benchmark.extra_info["active"] = int(active.sum())
    benchmark(subproblem)


@pytest.mark.parametrize("refine", [7, 8], ids=["66050", "263170"])
def test_assembly(benchmark, refine):
    """scikit-fem assembly of K and the scalar mass of a P1 disc (`fem_nd.assemble`)."""
    mesh = fe.MeshTri1.init_circle(refine)
    body = benchmark.pedantic(fem_nd.assemble, args=(mesh, 50.0, 0.25, 1.0), rounds=3)
    benchmark.extra_info["dofs"] = body.ndofs
