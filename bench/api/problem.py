"""From a case and a mesh to the space-discrete problem a scheme integrates.

Every scene gives a scheme one problem form: the general `SparseProblem` contract (sparse
M and K, a gap operator, loads and initial data). The bar's `BarProblem` is that contract
built on its tridiagonal form (`Semidiscrete`, kept as `banded`): M and K as CSR are made
when first read, so that the 1D kernels, which take the bands, pay nothing for them.
"""

from __future__ import annotations

import math
from functools import cached_property
from typing import Any

import numpy as np
import scipy.sparse as sp

from contact_bench.api.fem import MASSLESS_KINDS, assemble, canonical_mass, mass_variant
from contact_bench.api.plugin import Case, Semidiscrete
from contact_bench.api.recorder import discrete_energy
from contact_bench.api.sparse import AxisView, ContactSet, SparseProblem
from contact_bench.core.errors import BenchError


def _number(case: Case, name: str, value: object, allowed: str, ok) -> None:
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise BenchError(f"case {case.spec}: {name} = {value!r}; allowed: {allowed}") from None
    if not (math.isfinite(v) and ok(v)):
        raise BenchError(f"case {case.spec}: {name} = {value!r}; allowed: {allowed}")


def check_case(case: Case) -> None:
    """The bar's constants: L, E, rho > 0, g >= 0, u_L finite, a known far end.

    A case with declared parameters checks their ranges itself (`Param`); this is
    the last line for values a case computes. x-dependent E and rho (callables) are
    checked at the quadrature points by `contact_bench.api.fem.assemble`.
    """
    _number(case, "L", case.L, "a finite number > 0", lambda v: v > 0)
    for name in ("E", "rho"):
        value = getattr(case, name)
        if not callable(value):
            _number(case, name, value, "a finite number > 0", lambda v: v > 0)
    _number(case, "g", case.g, "a finite number >= 0", lambda v: v >= 0)
    _number(case, "u_L", case.u_L, "a finite number", lambda v: True)
    if case.far_end not in ("clamped", "free"):
        raise BenchError(f"case {case.spec}: far_end = {case.far_end!r}; "
                         f"allowed: 'clamped' or 'free'")


def discretise(case: Case, x: np.ndarray, mass_kind: str = "consistent") -> Semidiscrete:
    """Assemble with scikit-fem, pick the mass variant, eliminate a clamped far end.

    Gravity is a body acceleration: the load is F = -g M 1 with the scheme's own mass
    M, so a massless contact node feels no gravity and a rigid free fall is exact for
    every mass variant. Initial data are nodal interpolants of the case's u0 and v0.
    """
    check_case(case)
    mass_kind = canonical_mass(mass_kind)
    try:
        asm = assemble(x, case.rho, case.E)
    except ValueError as exc:  # x-dependent rho or E not > 0 somewhere
        raise BenchError(f"case {case.spec}: {exc}") from None
    M = mass_variant(asm, mass_kind)
    K = asm.K
    n_nodes = x.size
    U = np.asarray(case.u0(x), dtype=float) * np.ones(n_nodes)
    V = np.asarray(case.v0(x), dtype=float) * np.ones(n_nodes)
    for name, values in (("u0", U), ("v0", V)):
        bad = ~np.isfinite(values)
        if bad.any():
            i = int(np.argmax(bad))
            raise BenchError(f"case {case.spec}: {name}(x={x[i]:g}) = {float(values[i])!r}; "
                             f"initial data must be finite")
    if U[0] < 0:
        raise BenchError(f"case {case.spec}: u0(0) = {U[0]:g} violates the obstacle "
                         f"constraint; allowed: u0(0) >= 0")
    F = -case.g * M.matvec(np.ones(n_nodes))
    if case.far_end == "clamped":
        m = n_nodes - 1
        uL = float(case.u_L)
        U[-1] = uL
        V[-1] = 0.0
        full_load = F.copy()
        F = F[:m].copy()
        F[m - 1] -= K.off[m - 1] * uL  # coupling with the clamped node
        # energy of the full vector minus the reduced expression
        offset = 0.5 * K.diag[m] * uL**2 - full_load[m] * uL
    elif case.far_end == "free":
        m = n_nodes
        uL = None
        offset = 0.0
    else:
        raise BenchError(f"case {case.spec}: far_end must be 'clamped' or 'free', "
                         f"got {case.far_end!r}")
    h0 = x[1] - x[0]
    E_contact = (float(np.asarray(case.E(np.array([0.5 * h0]))).ravel()[0]) if callable(case.E)
                 else float(case.E))
    # x-dependent E or rho: nodes and element midpoints, so that a jump inside an
    # element (a graded mesh) still shows both sides in the largest wave speed
    xs = np.concatenate((x, 0.5 * (x[1:] + x[:-1])))
    Ex = np.asarray(case.E(xs)) if callable(case.E) else case.E
    rx = np.asarray(case.rho(xs)) if callable(case.rho) else case.rho
    c_max = float(np.max(np.sqrt(np.asarray(Ex, float) / np.asarray(rx, float))))
    return Semidiscrete(
        x=x, nfree=m, M=M.head(m), K=K.head(m), F=F, U0=U[:m].copy(), V0=V[:m].copy(),
        u_fixed=uL, energy_offset=float(offset), massless=mass_kind in MASSLESS_KINDS,
        E_contact=E_contact, c_max=c_max,
    )


class BarProblem:
    """The bar's problem in the general form (`contact_bench.api.sparse.SparseProblem`'s
    attributes and methods), with its tridiagonal form `banded` as the 1D kernels' fast
    backend.

    One contact point, node 0, against the obstacle at 0 (G picks dof 0, g0 = 0, weight
    1: the contact stress is minus the obstacle's force); the axis view is the whole bar;
    the normal stress at the contact point is E_contact (u_1 - u_0) / h_0.
    """

    dim = 1
    equal_groups: tuple[np.ndarray, ...] = ()
    #: no time-dependent load on a bar (`SparseProblem.load`: the same attribute)
    load = None
    #: the seconds the harness took to build it (`SparseProblem.assembly_s`)
    assembly_s: float | None = None

    def __init__(self, semi: Semidiscrete, mass_kind: str = "consistent") -> None:
        self.banded = semi
        self.F, self.U0, self.V0 = semi.F, semi.U0, semi.V0
        self.c_max = semi.c_max
        self.energy_offset = semi.energy_offset
        self.mass_kind = canonical_mass(mass_kind)
        self.E_contact = semi.E_contact
        self.h_contact = float(semi.x[1] - semi.x[0])
        self.contact = ContactSet(dofs=np.zeros(1, np.int64), gap0=np.zeros(1),
                                  weights=np.ones(1))
        self.extra: dict[str, Any] = {}

    @cached_property
    def hmin(self) -> float:
        return self.banded.hmin

    @cached_property
    def axis(self) -> AxisView:
        return AxisView(np.arange(self.nfree), self.banded.x, self.banded.u_fixed)

    @property
    def nfree(self) -> int:
        return int(self.banded.nfree)

    @cached_property
    def M(self) -> sp.csr_matrix:  # noqa: N802 - the matrix's name
        return sp.csr_matrix(self.banded.M.to_sparse())

    @cached_property
    def K(self) -> sp.csr_matrix:  # noqa: N802 - the matrix's name
        return sp.csr_matrix(self.banded.K.to_sparse())

    @cached_property
    def normal_stress(self) -> sp.csr_matrix:
        n, E, h = self.nfree, self.E_contact, self.h_contact
        cols = [0, 1] if n > 1 else [0]
        vals = [-E / h, E / h][:len(cols)]
        return sp.csr_matrix((vals, ([0] * len(cols), cols)), shape=(1, n))

    @property
    def massless(self) -> np.ndarray:
        """Boolean mask of the dofs without inertia (zero mass diagonal)."""
        return np.asarray(self.banded.M.diag == 0.0)

    @property
    def nbytes(self) -> int:
        s = self.banded
        return int(sum(a.nbytes for a in (s.x, s.M.diag, s.M.off, s.K.diag, s.K.off, s.F,
                                           s.U0, s.V0)))

    def energy(self, U: np.ndarray, V: np.ndarray) -> float:
        """1/2 V.M.V + 1/2 U.K.U - F.U + energy_offset, as the 1D kernels sum it."""
        return discrete_energy(self.banded, U, V)

    def gaps(self, U: np.ndarray) -> np.ndarray:
        """The gap of the contact node (u_0) of a state or of a stack of states."""
        return np.asarray(U)[..., :1]

    def check(self) -> None:
        """Nothing beyond `discretise`'s checks."""


#: a problem of the one form: a 2D/3D body's, or the bar's with its banded backend
Problem = SparseProblem | BarProblem


def as_problem(problem: Any, mass_kind: str | None = None) -> Any:
    """The problem in the general form: a `Semidiscrete` becomes its `BarProblem`; a
    `SparseProblem` or `BarProblem` is returned as it is."""
    if isinstance(problem, Semidiscrete):
        kind = mass_kind or ("first_element_massless" if problem.massless else "consistent")
        return BarProblem(problem, kind)
    return problem


def banded(problem: Any) -> Semidiscrete | None:
    """The bar's tridiagonal form of a problem (the 1D kernels' fast backend), or None
    for a 2D/3D body."""
    if isinstance(problem, Semidiscrete):
        return problem
    return getattr(problem, "banded", None)


class BarScale:
    """A bar known only by its smallest element and its wave speed: what a scheme's 1D
    step-limit formula reads (`Scheme.stability_limit`), e.g. as a CFL number on a unit
    bar (every such limit scales like h / c)."""

    def __init__(self, hmin: float = 1.0, c_max: float = 1.0) -> None:
        self.hmin, self.c_max = float(hmin), float(c_max)

    @property
    def banded(self) -> BarScale:
        return self
