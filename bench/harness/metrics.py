"""Error norms against a reference solution, energy drift, penetration.

Space norms use scikit-fem's Gauss quadrature on each element (4 points). Per block of
elements x samples (bounded size, so memory does not grow with the mesh or the number
of samples beyond the trajectory itself): the exact fields are evaluated at the
quadrature points of all the block's sample times in one compiled or vectorised call
(the exact solution's `fields_into` when it has one, writing in place, else `fields`,
else `u`, `ux`, `ut`), and a compiled kernel interpolates the P1 samples there and
accumulates the squared errors (and, the first time, the exact norms). Time norms over
the sample times: L_inf is the max, L2(0,T) the trapezoidal rule, all seven in one
compiled call with numpy's expressions and summation order (`_time_norms`). Every error is
relative: divided by the same norm of the exact solution (GetFEM's dynamic 1D contact
test); where that norm is 0 over the run the cell stays NaN and the row's notes say why,
with the absolute error (`undefined_errors`).

The contact stress error compares the sampled stress with the exact stress at the sample
times. At the instant contact starts the exact stress jumps; the references here take
the value before the jump (the clamped bar: 0 at t = 1, 4, ..., and 0 at the take-offs
t = 2, 5, ...: contact on the open intervals), GetFEM's demo the value after it (-1/2
at t = 1: its exact stress is -1/2 on [1, 2) mod 3). A sample that falls on a jump
counts with a different exact value in the two, so their stress errors differ by that
sample's share (docs/getfem-comparison.md).

The kernels are explicit SIMD (`contact_bench.core.simd`): the 4 points of an element are one
vector. Summation order of every space norm, per sample: one partial sum per quadrature
point over a leaf of `_LEAF` (64) elements in element order, the leaf's sum (s0 + s1) +
(s2 + s3), the leaves' sums added in order, then the blocks' (so long meshes stay
accurate). The next calls on a grid (values kept, or evaluated again) and the first (values
evaluated, norms summed in the same pass) compute the errors with the same code: the
same bits.

What depends on the mesh, the sample times and the reference only, not on the scheme, is
kept for the next calls on the same (reference, mesh, sample times), the most recent
first, up to `EXACT_CACHE_BYTES` in all: the blocks' quadrature (scikit-fem's), the
exact norms and the exact contact stress, so that the next schemes of a table on that
grid compute the errors only (unless the caller tells that no later call will need
them, `error_metrics(keep=False)`: the harness does for a table's last run on a grid,
so a lone run keeps nothing). The exact values at the quadrature points are kept too
when the reference is slow to evaluate (longer than `KEEP_VALUES_NS` per point on the
first block, and again on its first few sample times if so: one interruption does not
count): a fine characteristics grid evaluated point by point, the d'Alembert solution
(pulse), a numerical reference. A fast one (the closed forms, the characteristics on a
grid of runs) is evaluated again at each call into one block reused from call to call,
which costs less than keeping its values: 24 bytes per point newly touched by the first
scheme (page faults in a fresh process) and read back from memory by the others. The
threshold `KEEP_VALUES_NS` lies between the two kinds; the evaluation costs of every
scene and what keeping the values saves are measured in docs/performance.md
(`benchmarks/eval_cost.py`, `benchmarks/norm_cost.py`).
Either way the errors have the same bits. Entries hold the reference weakly; larger
problems are evaluated block by block every time (memory bounded by the block). With
`fields_into` an entry's values are one allocation, carved into the blocks (one array
per block would be handed back to the system block by block and faulted in again, page
by page, at the next grid).
"""

from __future__ import annotations

import functools
import threading
import time
import weakref
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numba import njit
from skfem import ElementLineP1, MeshLine
from skfem.mapping import MappingAffine
from skfem.quadrature import get_quadrature
from skfem.refdom import RefLine

from contact_bench.api.plugin import Exact, Fields, Semidiscrete, Trajectory
from contact_bench.core.simd import v4bcast, v4hsum, v4load, v4splat, vloadc, vstore

ERROR_COLUMNS = (
    "err_u_linf_l2", "err_u_linf_h1", "err_v_linf_l2",
    "err_u_l2_l2", "err_u_l2_h1", "err_v_l2_l2", "err_stress_l2",
)
#: which reference quantity each error column needs
NEEDS = {
    "err_u_linf_l2": "u", "err_u_linf_h1": "u", "err_u_l2_l2": "u", "err_u_l2_h1": "u",
    "err_v_linf_l2": "v", "err_v_l2_l2": "v", "err_stress_l2": "stress",
}
_CHUNK_POINTS = 131_072  # quadrature points per block (1 MB per field)
_BLOCK_ELEMENTS = 16_384  # elements per block at most
_QUAD_ORDER = 7  # 4 Gauss points per element
#: largest size of what is kept for the next calls on a grid (see the module docstring)
EXACT_CACHE_BYTES = 96 * 2**20
#: the exact values are kept only for a reference that takes longer than this (ns per
#: quadrature point, all its fields, measured on the first block) to evaluate: a faster
#: one is evaluated again into one reused block, which costs less than keeping its
#: values (memory newly touched) and reading them back (see the module docstring)
KEEP_VALUES_NS = 2.5
#: a slow first block is timed again on at most this many points (its first sample times)
_PROBE_POINTS = 16_384
_clock = time.perf_counter


_LEAF = 64  # elements per partial sum in the kernels (sums stay accurate on long meshes)


# The norm kernels (`_error_sums`, `_error_and_exact_sums`) take the 4 quadrature points
# of an element as one vector of 4 lanes (`contact_bench.core.simd.F64x4`, lane q = point q): the
# exact values u, ux, v (samples, elements, 4) and the weights w (elements, 4) are
# C-contiguous, so that element e of sample k is the 4 doubles at flat index
# 4 (k ne + e). The P1 interpolant there is A p0 + B p1: A, B the values of the element's
# two nodes in all 4 lanes (memory operands broadcast by the arithmetic itself, no
# shuffle), p0, p1 the basis values at the points. The slopes a g0[e] + b g1[e] of a
# sample are computed first, 8 elements per vector, and then broadcast the same way.
# Elements with a node >= nfree (the clamped one) take their node values by a test, in a
# second loop. The terms are the IEEE results of the expressions written below (no fma),
# lane by lane, so the terms are those of the former scalar kernels, and both kernels
# compute the errors with the same code (`_leaf`): the warm and cold paths give the same
# bits.


class Nodal(NamedTuple):
    """A run's nodal samples as the norm kernels read them: U and V (V read if use_v),
    the block's first sample row0 and first node lo, the free nodes nfree (a node >= nfree
    is the clamped one, at u_fixed, velocity 0)."""

    U: np.ndarray
    V: np.ndarray
    use_v: bool
    row0: int
    lo: int
    nfree: int
    u_fixed: float


class Quadrature(NamedTuple):
    """A block's quadrature (`_Geometry`): the basis values p0, p1 at the 4 points (4,),
    the basis slopes g0, g1 (elements,) and the weights w (elements, 4)."""

    p0: np.ndarray
    p1: np.ndarray
    g0: np.ndarray
    g1: np.ndarray
    w: np.ndarray


class SampleSums(NamedTuple):
    """Squared space norms per sample of u, u_x and v (an error's, or the exact
    solution's), added to in place."""

    u: np.ndarray
    ux: np.ndarray
    v: np.ndarray


class Place(NamedTuple):
    """Where a sample's terms are: its row of U, V, the flat indices ub, vb of its node lo
    in U and V, the flat index `base` of its exact values, and nfull, the elements of the
    block with both nodes free."""

    row: int
    ub: int
    vb: int
    base: int
    nfull: int


class UTerms(NamedTuple):
    """The running per-lane sums of u's and u_x's terms: errors su, sx, exact norms mu,
    mx (4-lane vectors)."""

    su: object
    sx: object
    mu: object
    mx: object


class ElementAt(NamedTuple):
    """One element at its 4 quadrature points (4-lane vectors): the values A, B of its
    two nodes in every lane and the weights W."""

    A: object
    B: object
    W: object


@njit(cache=True, inline="always")
def _sq(A, B, P0, P1, E, W):  # pragma: no cover - compiled
    """w (u_h - u)^2 lane by lane, u_h = a p0 + b p1."""
    d = (A * P0 + B * P1) - E
    return W * (d * d)


@njit(cache=True, inline="always")
def _slopes(nod, quad, ub, row, ne, nfull, gx):  # pragma: no cover - compiled
    """gx[e] = a g0[e] + b g1[e] for the ne elements of the block, a, b the values of
    their nodes in row `row` of U (flat index ub: node lo); elements < nfull have both
    nodes free. nod: the `Nodal`; quad: the `Quadrature`."""
    U, lo, nfree, u_fixed = nod.U, nod.lo, nod.nfree, nod.u_fixed
    g0, g1 = quad.g0, quad.g1
    n8 = nfull - nfull % 8
    for e in range(0, n8, 8):
        vstore(gx, e, vloadc(U, ub + e) * vloadc(g0, e) + vloadc(U, ub + e + 1) * vloadc(g1, e))
    for e in range(n8, ne):
        j = lo + e
        a = U[row, j] if j < nfree else u_fixed
        b = U[row, j + 1] if j + 1 < nfree else u_fixed
        gx[e] = a * g0[e] + b * g1[e]


@njit(cache=True, inline="always")
def _add_u(acc, el, P0, P1, E, F, G, norms):  # pragma: no cover - compiled
    """One element's terms of u and u_x (el: the `ElementAt`, slope G, exact values E, F)
    added lane by lane to the `UTerms` acc; the exact norms' terms too if norms."""
    su, sx, mu, mx = acc
    A, B, W = el
    su = su + _sq(A, B, P0, P1, E, W)
    d = F - G  # (u_x - g)^2 is (g - u_x)^2 exactly
    sx = sx + W * (d * d)
    if norms:
        mu = mu + W * (E * E)
        mx = mx + W * (F * F)
    return su, sx, mu, mx


@njit(cache=True, inline="always")
def _add_v(sv, mv, el, P0, P1, E, norms):  # pragma: no cover - compiled
    """One element's terms of v (el: the `ElementAt`) added lane by lane (and of its
    norm if norms)."""
    A, B, W = el
    sv = sv + _sq(A, B, P0, P1, E, W)
    if norms:
        mv = mv + W * (E * E)
    return sv, mv


@njit(cache=True, inline="always")
def _leaf(nod, quad, exact, gx, at, c0, norms):  # pragma: no cover - compiled
    """Per-lane (per point) sums, over the elements [c0, c1) (c1 = c0 + `_LEAF` or the
    last) of one sample in element order, of w (u_h - u)^2, w (u_h,x - u_x)^2, w (v_h -
    v)^2 (if use_v) and, if norms, of w u^2, w u_x^2, w v^2. nod: the `Nodal`; quad: the
    `Quadrature`; exact: the exact values (`Fields`); at: the sample's `Place` (row `row`
    of U, V, flat index ub, vb: node lo, its exact values at flat index base); its slopes
    in gx."""
    U, V, use_v, row0, lo, nfree, u_fixed = nod
    w = quad.w
    u, ux, v = exact
    row, ub, vb, base, nfull = at
    P0 = v4load(quad.p0, 0)
    P1 = v4load(quad.p1, 0)
    c1 = min(u.shape[1], c0 + _LEAF)
    su = v4splat(0.0)
    sx = su
    sv = su
    mu = su
    mx = su
    mv = su
    cf = max(c0, min(c1, nfull))  # [c0, cf): both nodes free
    for e in range(c0, cf):
        q = 4 * e
        W = v4load(w, q)
        su, sx, mu, mx = _add_u(UTerms(su, sx, mu, mx),
                                ElementAt(v4bcast(U, ub + e), v4bcast(U, ub + e + 1), W),
                                P0, P1, v4load(u, base + q), v4load(ux, base + q),
                                v4bcast(gx, e), norms)
        if use_v:
            sv, mv = _add_v(sv, mv,
                            ElementAt(v4bcast(V, vb + e), v4bcast(V, vb + e + 1), W), P0,
                            P1, v4load(v, base + q), norms)
    for e in range(cf, c1):  # a node >= nfree: the clamped one (u_fixed, velocity 0)
        j = lo + e
        q = 4 * e
        W = v4load(w, q)
        A = v4splat(U[row, j] if j < nfree else u_fixed)
        B = v4splat(U[row, j + 1] if j + 1 < nfree else u_fixed)
        su, sx, mu, mx = _add_u(UTerms(su, sx, mu, mx), ElementAt(A, B, W), P0, P1,
                                v4load(u, base + q), v4load(ux, base + q), v4bcast(gx, e),
                                norms)
        if use_v:
            A = v4splat(V[row, j] if j < nfree else 0.0)
            B = v4splat(V[row, j + 1] if j + 1 < nfree else 0.0)
            sv, mv = _add_v(sv, mv, ElementAt(A, B, W), P0, P1, v4load(v, base + q), norms)
    return su, sx, sv, mu, mx, mv


@njit(cache=True, inline="always")
def _sums(nod, quad, exact, err, nrm, norms):  # pragma: no cover - compiled
    """The body of both kernels (norms: a constant in each)."""
    U, V, use_v, row0, lo, nfree, u_fixed = nod
    u = exact.u
    eu, eux, ev = err
    nu, nux, nv = nrm
    kb, ne, _ = u.shape
    nfull = min(ne, max(0, nfree - 1 - lo))  # elements with both nodes free
    gx = np.empty(ne)
    for k in range(kb):
        row = row0 + k
        base = 4 * ne * k
        ub = row * U.shape[1] + lo
        vb = row * V.shape[1] + lo
        _slopes(nod, quad, ub, row, ne, nfull, gx)
        at = Place(row, ub, vb, base, nfull)
        tu = 0.0
        tx = 0.0
        tv = 0.0
        mu = 0.0
        mx = 0.0
        mv = 0.0
        for c0 in range(0, ne, _LEAF):
            su, sx, sv, nu_, nx_, nv_ = _leaf(nod, quad, exact, gx, at, c0, norms)
            tu += v4hsum(su)
            tx += v4hsum(sx)
            tv += v4hsum(sv)
            if norms:
                mu += v4hsum(nu_)
                mx += v4hsum(nx_)
                mv += v4hsum(nv_)
        eu[row] += tu
        eux[row] += tx
        if use_v:
            ev[row] += tv
        if norms:
            nu[row] += mu
            nux[row] += mx
            if use_v:
                nv[row] += mv


@njit(cache=True)
def _error_sums(nod, quad, exact, err):  # pragma: no cover - compiled
    """Add sum_e,q w (u_h - u)^2 (and the same for u_x, v) of samples row0.. to the
    `SampleSums` err (eu, eux, ev). nod: the `Nodal`; quad: the `Quadrature`; exact: the
    exact values u, ux, v (`Fields`). u_h is the P1 interpolant of rows of U (V): element e
    of the block has the nodes lo + e and lo + e + 1, nodes >= nfree are the clamped one
    (u_fixed, velocity 0). p0, p1 (4,): basis values at the 4 points; g0, g1 (elements,):
    basis slopes; w (elements, 4): weights; u, ux, v (samples, elements, 4): the exact
    values. Every array C-contiguous float64 (the vector loads are typed for that only: a
    typing error otherwise).

    Summation order, per sample and field: one partial sum per quadrature point q (a
    vector lane) over a leaf of `_LEAF` elements, in element order; the leaf's sum is
    (s0 + s1) + (s2 + s3); the leaves' sums are added in order, then the block's to
    eu, eux, ev. That is the order of the former scalar kernel, and its terms (the IEEE
    results of w ((a p0 + b p1) - u)^2 and w ((a g0 + b g1) - u_x)^2, no fma): the same
    bits."""
    _sums(nod, quad, exact, err, err, False)


@njit(cache=True)
def _error_and_exact_sums(nod, quad, exact, err, nrm):  # pragma: no cover - compiled
    """`_error_sums` and, in the same pass over the exact values, sum_e,q w u^2 (and the same
    for u_x, v) of samples row0.. added to the `SampleSums` nrm (nu, nux, nv): what the
    first scheme on a grid needs. The error sums are those of `_error_sums`, bit for bit
    (the same code). The norms are summed in the same order: one partial sum per point over
    a leaf, (s0 + s1) + (s2 + s3), the leaves in order (the former kernel had one serial sum
    per leaf in the order (element, point): the norms differ from it in the last bits)."""
    _sums(nod, quad, exact, err, nrm, True)


_P1 = ElementLineP1()  # the element of the norms' quadrature (its reference basis)


@dataclass(frozen=True)
class _Geometry:
    """Quadrature of one block of elements, from scikit-fem: the affine mapping of a
    MeshLine of the block's nodes and the reference basis of its P1 element at the
    Gauss points (4 per element).

    These are the expressions of scikit-fem's `Basis` (its `global_coordinates`, `dx`
    and `gbasis`, called one by one: the same arrays, bit for bit,
    tests/test_perf_memory_norms.py),
    without the rest of what a `Basis` builds (its dofs, its per-point tables), which a
    lone run would pay inside its norm time (both costs: docs/performance.md)."""

    lo: int  # first node of the block
    X: np.ndarray  # (elements, 4) quadrature points
    w: np.ndarray  # (elements, 4) weights (dx)
    p0: np.ndarray  # (4,) values of the left / right basis function at the points
    p1: np.ndarray
    g0: np.ndarray  # (elements,) slopes of the left / right basis function
    g1: np.ndarray

    @classmethod
    def of(cls, x: np.ndarray, e0: int, e1: int) -> _Geometry:
        mesh = MeshLine(x[e0 : e1 + 1])
        Xr, W = _quadrature()
        mapping = MappingAffine(mesh)
        ne = e1 - e0
        p0, d0 = _P1.lbasis(Xr, 0)
        p1, d1 = _P1.lbasis(Xr, 1)
        invDF = mapping.invDF(Xr)
        g0, g1 = (np.einsum("ijkl,il->jkl", invDF, d)[0] for d in (d0, d1))  # gbasis's
        dx = np.abs(mapping.detDF(Xr)) * np.broadcast_to(W, (ne, W.shape[-1]))  # Basis.dx
        # P1 on straight elements: the same values on every element, slopes constant in
        # each, element e on nodes e, e + 1 (what the kernel assumes)
        t = mesh.t
        if not (p0.shape == p1.shape == (4,) and g0.shape == dx.shape == (ne, 4)
                and np.array_equal(t[0], np.arange(ne)) and np.array_equal(t[1], t[0] + 1)
                and np.all(g0 == g0[:, :1])
                and np.all(g1 == g1[:, :1])):  # pragma: no cover - scikit-fem's layout
            raise RuntimeError("unexpected scikit-fem P1 mapping layout")
        c = np.ascontiguousarray
        return cls(e0, c(mapping.F(Xr)[0]), c(dx), c(p0), c(p1), c(g0[:, 0]), c(g1[:, 0]))



@functools.cache
def _quadrature() -> tuple[np.ndarray, np.ndarray]:
    """scikit-fem's rule of order `_QUAD_ORDER` on the reference line (what `intorder`
    computes for each basis: computed once)."""
    return get_quadrature(RefLine, _QUAD_ORDER)


def _blocks(nel: int) -> tuple[int, int]:
    """Elements and samples per block (about _CHUNK_POINTS quadrature points, at most
    _BLOCK_ELEMENTS elements: the temporaries of a block's scikit-fem mapping)."""
    ec = min(nel, _BLOCK_ELEMENTS, max(1, _CHUNK_POINTS // 4))
    return ec, max(1, _CHUNK_POINTS // (ec * 4))


def _field(value: Any, shape: tuple[int, ...]) -> np.ndarray:
    """A writeable C-contiguous float array of the shape (the kernels are compiled for
    that type only, `warm_up`)."""
    arr = np.asarray(value, dtype=float)
    if arr.shape != shape:
        arr = np.broadcast_to(arr, shape)
    return arr if arr.flags.c_contiguous and arr.flags.writeable else np.array(arr)


def _exact_values(exact: Exact, X: np.ndarray, t: np.ndarray, need_v: bool
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """u, u_x (and u_t) at the points X (elements, 4) for the times t (kb, 1, 1)."""
    shape = (t.shape[0], *X.shape)
    fields = getattr(exact, "fields", None)
    if fields is not None:
        u, ux, v = fields(X, t, velocity=need_v)
    else:
        u, ux = exact.u(X, t), exact.ux(X, t)
        v = exact.ut(X, t) if need_v else None
    return _field(u, shape), _field(ux, shape), (_field(v, shape) if need_v else None)


@dataclass
class _Entry:
    """What the error norms need of the reference on one (mesh, sample times): the
    quadrature of the blocks, the exact norms and stress, and the exact values at the
    quadrature points when the reference is slow to evaluate (None otherwise)."""

    ref: Any  # weakref to the reference
    x: np.ndarray
    t: np.ndarray
    need_v: bool
    geometry: list[_Geometry]
    values: list[tuple[np.ndarray, np.ndarray, np.ndarray | None]] | None  # per block
    norms: dict[str, np.ndarray]
    stress: dict[str, np.ndarray] = field(default_factory=dict)  # "s": exact stress at t

    @property
    def nbytes(self) -> int:
        held = [a for vals in self.values or () for a in vals if a is not None]
        held += [a for g in self.geometry for a in (g.X, g.w, g.g0, g.g1)]
        return sum(a.nbytes for a in held)

    def matches(self, exact: Exact, x: np.ndarray, t: np.ndarray, need_v: bool) -> bool:
        return (self.ref() is exact and need_v <= self.need_v
                and np.array_equal(self.x, x) and np.array_equal(self.t, t))


_cache: list[_Entry] = []  # most recent first
_cache_lock = threading.Lock()


def clear_cache() -> None:
    """Forget the kept exact values (see the module docstring)."""
    with _cache_lock:
        _cache.clear()


def _lookup(exact: Exact, x: np.ndarray, t: np.ndarray, need_v: bool) -> _Entry | None:
    with _cache_lock:
        for i, entry in enumerate(_cache):
            if entry.matches(exact, x, t, need_v):
                _cache.insert(0, _cache.pop(i))
                return entry
    return None


def _store(entry: _Entry) -> None:
    with _cache_lock:
        _cache.insert(0, entry)
        total = 0
        for i, e in enumerate(_cache):
            total += e.nbytes
            if total > EXACT_CACHE_BYTES or e.ref() is None:
                del _cache[i:]
                break


def _make_room(nbytes: int) -> None:
    """Drop the oldest entries so that nbytes more fit (before they are made)."""
    with _cache_lock:
        while _cache and sum(e.nbytes for e in _cache) + nbytes > EXACT_CACHE_BYTES:
            _cache.pop()


_scratch = threading.local()  # per thread: one block's values when they are not kept


def _scratch_block(size: int) -> np.ndarray:
    """A reused array of at least `size` doubles (the same pages from call to call)."""
    buf = getattr(_scratch, "buf", None)
    if buf is None or buf.size < size:
        buf = _scratch.buf = np.full(size, 0.0)  # its pages touched now, not in the
        # timing of the first block's evaluation
    return buf[:size]


def _evaluate(exact: Exact, g: _Geometry, t: np.ndarray, need_v: bool,
              out: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """u, u_x (and u_t) at the block's points for the times t: written into out
    (fields, samples, elements, 4) by the reference's `fields_into`, or made by
    `_exact_values` when out is None."""
    if out is None:
        return _exact_values(exact, g.X, t[:, None, None], need_v)
    vals = (out[0], out[1], out[2] if need_v else None)
    n = g.X.size
    exact.fields_into(g.X.reshape(-1), t,
                      *(None if f is None else f.reshape(t.size, n) for f in vals))
    return vals


def _space_norms(semi: Semidiscrete, traj: Trajectory, exact: Exact, need_v: bool,
                 keep: bool = True) -> tuple[dict[str, np.ndarray], _Entry | None]:
    """Squared space norms per sample, accumulated over blocks of elements x samples,
    and the cache entry used or made (None when it is too large to keep, or when `keep`
    is False: no later call will need it)."""
    x, t = semi.x, traj.t
    nel, K = x.size - 1, t.size
    err = {k: np.zeros(K) for k in ("eu", "eux", "ev")}
    norms = {k: np.zeros(K) for k in ("nu", "nux", "nv")}
    u_fixed = float(semi.u_fixed) if semi.u_fixed is not None else 0.0
    U = np.ascontiguousarray(traj.U, dtype=float)  # the kernels load rows as vectors
    V = np.ascontiguousarray(traj.V, dtype=float) if need_v else U
    ec, step = _blocks(nel)
    nf = 3 if need_v else 2
    into = getattr(exact, "fields_into", None) is not None
    # one block's values, reused from block to block (and from call to call) when they
    # are not kept: `fields_into` writes there
    block = _scratch_block(nf * min(step, K) * min(ec, nel) * 4) if into else None

    def out(ne: int, kb: int, where: np.ndarray | None) -> np.ndarray | None:
        return None if where is None else where[: nf * kb * ne * 4].reshape(nf, kb, ne, 4)

    def add(g: _Geometry, a: int, vals: tuple, with_norms: bool) -> None:
        u, ux, v = vals
        args = (Nodal(U, V, need_v, a, g.lo, semi.nfree, u_fixed),
                Quadrature(g.p0, g.p1, g.g0, g.g1, g.w), Fields(u, ux, u if v is None else v),
                SampleSums(err["eu"], err["eux"], err["ev"]))
        if with_norms:
            _error_and_exact_sums(*args, SampleSums(norms["nu"], norms["nux"], norms["nv"]))
        else:
            _error_sums(*args)

    hit = _lookup(exact, x, t, need_v)
    if hit is not None:
        kept = iter(hit.values) if hit.values is not None else None
        for g in hit.geometry:
            for a in range(0, K, step):
                kb = min(step, K - a)
                vals = next(kept) if kept is not None else _evaluate(
                    exact, g, t[a : a + kb], need_v, out(g.X.shape[0], kb, block))
                add(g, a, vals, False)
        return {**err, **hit.norms}, hit

    ref = None
    if keep:
        try:
            ref = weakref.ref(exact)
        except TypeError:  # not weakly referable: nothing is kept
            pass
    quadrature = 80 * nel  # bytes of the blocks' X, w (4 per element), g0, g1
    size = 8 * nf * K * nel * 4  # bytes of the values
    keep = ref is not None and quadrature <= EXACT_CACHE_BYTES
    fits = keep and size + quadrature <= EXACT_CACHE_BYTES
    keep_values: bool | None = None  # decided on the first block's evaluation
    pool, at = None, 0  # with `fields_into`: the kept values, one allocation
    geometry: list[_Geometry] = []
    values: list[tuple] = []
    for e0 in range(0, nel, ec):
        g = _Geometry.of(x, e0, min(nel, e0 + ec))
        ne = g.X.shape[0]
        for a in range(0, K, step):
            kb = min(step, K - a)
            n = nf * kb * ne * 4
            dest = out(ne, kb, pool[at:] if keep_values and into else block)
            start = _clock()
            vals = _evaluate(exact, g, t[a : a + kb], need_v, dest)
            if keep_values is None:
                cost = (_clock() - start) * 1e9 / (kb * ne * 4)
                if fits and cost > KEEP_VALUES_NS:  # slow, or interrupted: once more,
                    # on the first few sample times only (at most _PROBE_POINTS points:
                    # the whole block again doubled a slow reference's first call)
                    kp = min(kb, max(1, _PROBE_POINTS // (ne * 4)))
                    probe = out(ne, kp, np.empty(nf * kp * ne * 4)) if into else None
                    start = _clock()
                    _evaluate(exact, g, t[a : a + kp], need_v, probe)
                    cost = min(cost, (_clock() - start) * 1e9 / (kp * ne * 4))
                keep_values = fits and cost > KEEP_VALUES_NS
                if keep_values:
                    _make_room(size + quadrature)
                    if into:  # one allocation for all the values: not one per block,
                        # whose pages would go back to the system and fault in again
                        pool = np.empty(size // 8)
                        first = out(ne, kb, pool)
                        first[...] = block[:n].reshape(first.shape)
                        vals = (first[0], first[1], first[2] if need_v else None)
            if keep_values and into:
                at += n
            add(g, a, vals, True)
            if keep_values:
                values.append(vals)
        if keep:
            geometry.append(g)
    if not keep:
        return {**err, **norms}, None
    for arr in norms.values():
        arr.flags.writeable = False
    entry = _Entry(ref, x.copy(), t.copy(), need_v, geometry,
                   values if keep_values else None, norms)
    _store(entry)
    return {**err, **norms}, entry


@njit(cache=True, inline="always")
def _pairwise_leaf(a, lo, n):  # pragma: no cover - compiled
    """numpy's pairwise sum of at most 128 terms a[lo : lo + n] (`_pairwise`)."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    for i in range(lo + 8, lo + n - n % 8, 8):
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for i in range(lo + n - n % 8, lo + n):
        res += a[i]
    return res


@njit(cache=True)
def _pairwise(a, lo, n):  # pragma: no cover - compiled
    """numpy's pairwise summation of a[lo : lo + n] (`DOUBLE_pairwise_sum`, numpy/_core/
    src/umath/loops_utils.h.src): below 8 terms one by one, up to 128 eight partial sums
    ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7)) and the rest one by one, above that
    the two halves (the first a multiple of 8) summed apart and added. np.add.reduce of
    a contiguous float64 array is 0.0 + this, bit for bit (tests/test_norm_sums.py).

    numpy recurses; this walks the same tree with a stack of its own (a cached numba
    function calling itself fails to link when another cached function calls it)."""
    if n <= 128:
        return _pairwise_leaf(a, lo, n)
    los = np.empty(130, np.int64)  # pending halves (depth < 64: 2 per level)
    ns = np.empty(130, np.int64)
    done = np.zeros(130, np.bool_)  # its two halves are summed (their sums on vals)
    vals = np.empty(130)
    sp, vp = 1, 0
    los[0], ns[0] = lo, n
    while sp > 0:
        top = sp - 1
        m = ns[top]
        if m <= 128:
            vals[vp] = _pairwise_leaf(a, los[top], m)
            vp += 1
            sp -= 1
        elif done[top]:  # the sum of its halves (addition commutes: order is free)
            vals[vp - 2] = vals[vp - 2] + vals[vp - 1]
            vp -= 1
            sp -= 1
        else:
            done[top] = True
            n2 = m // 2
            n2 -= n2 % 8
            los[sp], ns[sp], done[sp] = los[top], n2, False
            los[sp + 1], ns[sp + 1], done[sp + 1] = los[top] + n2, m - n2, False
            sp += 2
    return vals[0]


# the series of `_time_norms`: y, y + z, (y - z)^2, y^2 (numpy's terms: y ** 2 is y * y)
_PLAIN, _SUM, _DIFF2, _SQUARE = 0, 1, 2, 3


@njit(cache=True, inline="always")
def _term(y, z, mode, i):  # pragma: no cover - compiled
    if mode == _SUM:
        return y[i] + z[i]
    if mode == _DIFF2:
        d = y[i] - z[i]
        return d * d
    if mode == _SQUARE:
        return y[i] * y[i]
    return y[i]


@njit(cache=True)
def _trapezoid(t, y, z, mode, buf):  # pragma: no cover - compiled
    """np.trapezoid(f, t) of the series f = _term(y, z, mode): its expression,
    add.reduce(diff(t) * (f[1:] + f[:-1]) / 2.0), the same operations in the same order."""
    m = t.size - 1
    for i in range(m):
        buf[i] = ((t[i + 1] - t[i]) * (_term(y, z, mode, i + 1) + _term(y, z, mode, i))) / 2.0
    return 0.0 + _pairwise(buf, 0, m)


@njit(cache=True)
def _peak(y, z, mode):  # pragma: no cover - compiled
    """np.max of the series (nan if it holds a nan)."""
    m = -np.inf
    for i in range(y.size):
        v = _term(y, z, mode, i)
        if v != v:
            return v
        if v > m:
            m = v
    return m


@njit(cache=True)
def _l2_ratio(t, e, ez, emode, n, nz, nmode, buf):  # pragma: no cover - compiled
    """sqrt(int e2 dt) / sqrt(int n2 dt), nan below two samples or for a zero norm."""
    if t.size < 2:
        return np.nan
    den = np.sqrt(_trapezoid(t, n, nz, nmode, buf))
    return np.sqrt(_trapezoid(t, e, ez, emode, buf)) / den if den > 0 else np.nan


@njit(cache=True)
def _linf_ratio(e, ez, emode, n, nz, nmode):  # pragma: no cover - compiled
    den = np.sqrt(_peak(n, nz, nmode))
    return np.sqrt(_peak(e, ez, emode)) / den if den > 0 else np.nan


@njit(cache=True)
def _time_norms(t, err, nrm, use_u, use_v, a, s, use_s):  # pragma: no cover - compiled
    """The 7 relative errors of `ERROR_COLUMNS` (nan where not asked) from the squared
    space norms per sample (the `SampleSums` err: eu, eux, ev errors, nrm: nu, nux, nv
    exact), and from the
    contact stress a against the exact s: L_inf(0,T) the max, L2(0,T) the trapezoidal
    rule, with numpy's expressions and summation order (the bits of np.max,
    np.trapezoid and the elementwise sums and squares of the former numpy code), in one
    call instead of some sixty numpy calls (a quarter of a millisecond of Python in a
    lone run's norm time)."""
    eu, eux, ev = err
    nu, nux, nv = nrm
    out = np.full(7, np.nan)
    buf = np.empty(max(t.size - 1, 0))
    if use_u:
        out[0] = _linf_ratio(eu, eu, _PLAIN, nu, nu, _PLAIN)
        out[1] = _linf_ratio(eu, eux, _SUM, nu, nux, _SUM)
        out[3] = _l2_ratio(t, eu, eu, _PLAIN, nu, nu, _PLAIN, buf)
        out[4] = _l2_ratio(t, eu, eux, _SUM, nu, nux, _SUM, buf)
        if use_v:
            out[2] = _linf_ratio(ev, ev, _PLAIN, nv, nv, _PLAIN)
            out[5] = _l2_ratio(t, ev, ev, _PLAIN, nv, nv, _PLAIN, buf)
    if use_s:
        out[6] = _l2_ratio(t, a, s, _DIFF2, s, s, _SQUARE, buf)
    return out


def error_metrics(semi: Semidiscrete, traj: Trajectory, exact: Exact,
                  provides: frozenset[str], keep: bool = True,
                  notes: list[str] | None = None) -> dict[str, float | None]:
    """The relative error columns that the reference provides (None for the others).

    A relative error whose exact norm is 0 over the run (the clamped bar's contact
    stress before the first impact at t = 1, a short run of a scene still in flight) is
    0/0: its cell stays NaN, and `notes` (when given) gets the reason and the absolute
    error (`undefined_errors`).

    `keep`: keep what depends on the grid only (quadrature, exact norms and stress, slow
    references' values) for the next calls on the same (reference, mesh, sample times);
    False when no later call will need them (the last run of a table on its grid), so
    that a lone run holds no more than its own blocks (80 bytes per element of
    quadrature otherwise: 80 MB at n = 1e6)."""
    row: dict[str, float | None] = dict.fromkeys(ERROR_COLUMNS)
    t = np.ascontiguousarray(traj.t, dtype=float)
    use_u, use_s = "u" in provides, "stress" in provides
    use_v = use_u and "v" in provides  # v columns come with the u norms only
    entry = None
    z = np.zeros(1)  # what a kernel argument is when its column is not asked
    n = dict.fromkeys(("eu", "eux", "ev", "nu", "nux", "nv"), z)
    if use_u:
        n, entry = _space_norms(semi, traj, exact, use_v, keep)
    a = s = z
    if use_s:
        s = entry.stress.get("s") if entry is not None else None
        if s is None:
            s = np.ascontiguousarray(np.broadcast_to(np.asarray(exact.stress(t), float),
                                                     t.shape))
            if entry is not None:
                s.flags.writeable = False
                entry.stress["s"] = s
        a = np.ascontiguousarray(traj.stress, dtype=float)
    out = _time_norms(t, SampleSums(n["eu"], n["eux"], n["ev"]),
                      SampleSums(n["nu"], n["nux"], n["nv"]), use_u, use_v, a, s, use_s)
    asked = {"u": use_u, "v": use_v, "stress": use_s}
    for col, value in zip(ERROR_COLUMNS, out, strict=True):
        if asked[NEEDS[col]]:
            row[col] = float(value)
    if notes is not None:
        notes.extend(undefined_errors(row, t, n, a, s))
    return row


#: (series, time norm) of each column: e the squared error per sample (stress: a - s)
_COLUMN_PARTS = {
    "err_u_linf_l2": (("eu",), "linf"), "err_u_linf_h1": (("eu", "eux"), "linf"),
    "err_v_linf_l2": (("ev",), "linf"), "err_u_l2_l2": (("eu",), "l2"),
    "err_u_l2_h1": (("eu", "eux"), "l2"), "err_v_l2_l2": (("ev",), "l2"),
}


def undefined_errors(row: dict[str, float | None], t: np.ndarray, n: dict[str, np.ndarray],
                     a: np.ndarray, s: np.ndarray) -> list[str]:
    """One note per asked error column that is NaN: why (the exact norm is 0 over the
    run, fewer than two samples for an L2(0, T) norm, or a non-finite value) and, when
    the error itself is finite, its absolute value."""
    out = []
    for col, value in row.items():
        if value is None or np.isfinite(value):
            continue
        if col == "err_stress_l2":
            err2 = (np.asarray(a, float) - s) ** 2
            ref2 = np.asarray(s, float) ** 2
            kind, what = "l2", "contact stress"
        else:
            parts, kind = _COLUMN_PARTS[col]
            err2 = sum(np.asarray(n[p], float) for p in parts)
            ref2 = sum(np.asarray(n[p.replace("e", "n", 1)], float) for p in parts)
            what = "velocity" if col.startswith("err_v") else "displacement"
        if kind == "l2" and t.size < 2:
            out.append(f"{col} undefined: an L2(0,T) norm needs two samples")
            continue
        if kind == "l2":
            err = float(np.sqrt(np.trapezoid(err2, t)))
            ref = float(np.sqrt(np.trapezoid(ref2, t)))
        else:
            err, ref = float(np.sqrt(np.max(err2))), float(np.sqrt(np.max(ref2)))
        if ref == 0.0 and np.isfinite(err):
            out.append(f"{col} undefined: the exact {what} is 0 over the run "
                       f"(absolute error {err:.3g})")
        else:
            out.append(f"{col} undefined: not finite (error {err:.3g}, exact norm {ref:.3g})")
    return out


def warm_up() -> None:
    """Compile the norm kernels (or load them from numba's cache) outside any timing."""
    z1, z2, z4, zq, z3 = np.zeros(1), np.zeros((1, 2)), np.zeros(4), np.zeros((1, 4)), \
        np.zeros((1, 1, 4))
    nod, quad = Nodal(z2, z2, True, 0, 0, 2, 0.0), Quadrature(z4, z4, z1, z1, zq)
    sums = SampleSums(z1, z1, z1)
    _error_sums(nod, quad, Fields(z3, z3, z3), sums)
    _error_and_exact_sums(nod, quad, Fields(z3, z3, z3), sums, sums)
    _time_norms(z1, sums, sums, True, True, z1, z1, True)
    _scratch_block(3 * _CHUNK_POINTS)  # the block of values not kept: allocated once


def warm_up_reference(exact: Exact, x: np.ndarray, t: np.ndarray,
                      provides: frozenset[str]) -> None:
    """Load (or compile) the reference's own compiled code outside any timing: one call
    of each method that `error_metrics` uses, the same way (the quadrature points of the
    first block of elements of the mesh x, as the norms pass them, so that a reference
    choosing its algorithm by the points takes the same one; the first sample time)."""
    t1 = np.asarray(t, float)[:1]
    if "u" in provides:
        need_v = "v" in provides
        x = np.asarray(x, float)
        g = _Geometry.of(x, 0, _blocks(x.size - 1)[0])
        into = getattr(exact, "fields_into", None) is not None
        _evaluate(exact, g, t1, need_v, np.empty((3, 1, *g.X.shape)) if into else None)
    if "stress" in provides:
        exact.stress(t1)


def energy_metrics(traj: Trajectory) -> dict[str, float]:
    E = traj.energy
    E0 = float(E[0])
    scale = abs(E0) if E0 != 0 else 1.0
    return {
        "energy_initial": E0,
        "energy_final": float(E[-1]),
        "energy_drift_max": float(np.max(np.abs(E - E0)) / scale),
    }


def penetration(traj: Trajectory) -> float:
    """Largest penetration max(-u(0, t_n)) over every step, 0 if none."""
    return float(max(0.0, -traj.min_contact_u))
