"""A 1D scene's bar embedded in 2D (plane strain, Q1 quads) or 3D (Q1 hexes).

The bar (0, L) becomes the rectangle (0, L) x (0, 1) or the box (0, L) x (0, 1)^2 (a
section of measure 1, so that energies and contact stresses equal the 1D ones), with
`cells` elements across and `--nx` along. Its obstacle is the plane x = 0 under the
whole face x = 0 (frictionless), the far end x = L is clamped (every component) when the
1D scene's is. Lateral faces: `free` with nu = 0, or `sliding` (the normal component
zero, no friction) with any nu; Young's modulus is chosen so that lambda + 2 mu equals
the 1D E (the same wave speed). In both cases u = (u1(x, t), 0, 0) with u1 the 1D
solution solves the 2D/3D problem, so the 1D scene's exact solution is the reference
and the error norms are those of 1D, taken on the axis y = z = 0.

At the discrete level too: the Q1 mass is kron(M_x, M_y(, M_z)) and K keeps the 1D
subspace, so every 1D mass variant has the counterpart kron(M_x^variant, M_y, ...) and
every scheme's run equals its 1D run up to round-off (until round-off splits an
active set: the symmetry defect column shows the spread across the section).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import skfem as fe

from contact_bench.api import fem_nd
from contact_bench.api.fem import LUMPED_MASSLESS, MASS_KINDS, mesh_nodes
from contact_bench.api.params import Param
from contact_bench.api.plugin import BarCase, BodyCase, StudyGrid
from contact_bench.api.registry import make_case
from contact_bench.api.sparse import AxisView, ContactSet, SparseProblem
from contact_bench.core.errors import BenchError


class EmbeddedBar(BodyCase):
    name = "embedded_bar"
    summary = "a 1D scene's bar as a 2D/3D Q1 body (reference: the 1D exact solution)"
    #: those of the default `of` (clamped_bar); an instance takes its own scene's
    reference = "exact"
    provides = frozenset({"u", "v", "stress", "energy"})
    params = {
        "of": Param("clamped_bar", "the 1D scene embedded"),
        "dim": Param(2, "space dimension", choices=(2, 3)),
        "cells": Param(2, "elements across the bar", low=1, high=64),
        "sides": Param("free", "lateral faces: free (nu = 0) or sliding (any nu)",
                       choices=("free", "sliding")),
        "nu": Param(0.3, "Poisson's ratio with sliding sides", low=-0.99, high=0.49),
    }
    study = StudyGrid(specs=("embedded_bar",), nx=(10, 20, 40), T=None,
                      small="embedded_bar[of=fast_impact]", small_nx=(10,), small_T=2.0)

    def validate(self) -> None:
        if self.of == self.name or self.of.startswith(self.name + "["):
            raise BenchError(f"{self.spec}: of = {self.of!r}: a bar, not an embedded bar")
        bar = make_case(self.of)
        if not isinstance(bar, BarCase):
            raise BenchError(f"{self.spec}: of = {self.of!r} is not a 1D scene")
        if callable(bar.E) or callable(bar.rho):
            raise BenchError(f"{self.spec}: of = {self.of!r} has x-dependent E or rho; "
                             "allowed: scenes with constant E and rho")
        #: the embedded 1D scene: its bar's length, material, gravity, far end and data
        #: are this body's (`bar.L`, `bar.E`, ...)
        self.bar = bar
        self.T, self.nx, self.dt, self.stride = bar.T, bar.nx, bar.dt, bar.stride
        self.reference = bar.reference
        self.provides = bar.provides

    @property
    def size(self) -> float:
        """The bar's length."""
        return self.bar.L

    def exact(self, T: float):
        return self.bar.exact(T)

    @property
    def exact_energy(self) -> float | None:
        return self.bar.exact_energy  # the section has measure 1

    def _normal_stress(self, P: np.ndarray, face: np.ndarray, index: np.ndarray,
                       x: np.ndarray, dim: int) -> sp.csr_matrix:
        """sigma_xx at each contact node: E (u_x(x1) - u_x(0)) / h along its line, the
        first element's gradient, exact for u = (u1(x), 0, 0) (the 1D E u_x(0))."""
        key = {tuple(np.round(P[1:, s], 12)): s for s in np.flatnonzero(P[0] == x[1])}
        nxt = np.array([key[tuple(np.round(P[1:, s], 12))] for s in face])
        h = float(x[1] - x[0])
        rows = np.repeat(np.arange(face.size), 2)
        cols = np.stack([index[dim * face], index[dim * nxt]], axis=1).ravel()
        vals = np.tile([-float(self.bar.E) / h, float(self.bar.E) / h], face.size)
        keep = cols >= 0  # a clamped next node contributes nothing (its value is u_L)
        return sp.csr_matrix((vals[keep], (rows[keep], cols[keep])),
                             shape=(face.size, int(np.count_nonzero(index >= 0))))

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        if mass_kind not in (*MASS_KINDS, LUMPED_MASSLESS):
            raise ValueError(f"mass {mass_kind!r} has no tensor form; allowed: "
                             f"{', '.join((*MASS_KINDS, LUMPED_MASSLESS))}")
        bar, dim = self.bar, int(self.dim)
        x = mesh_nodes(float(bar.L), int(nx), grading)
        y = np.linspace(0.0, 1.0, int(self.cells) + 1)
        mesh = (fe.MeshQuad.init_tensor(x, y) if dim == 2
                else fe.MeshHex.init_tensor(x, y, y))
        nu = 0.0 if self.sides == "free" else float(self.nu)
        # lambda + 2 mu = E (1 - nu) / ((1 + nu) (1 - 2 nu)) is the 1D E
        E_nd = float(bar.E) * (1 + nu) * (1 - 2 * nu) / (1 - nu)
        body = fem_nd.assemble(mesh, E_nd, nu, float(bar.rho))
        M = fem_nd.mass_matrix(body, "kron:" + mass_kind)
        P = body.dof_coordinates  # (dim, nodes); node s has dofs dim s + c
        nodes = P.shape[1]
        n = dim * nodes
        g = np.zeros(dim)
        g[0] = -float(bar.g)
        F = fem_nd.body_force(M, dim, g)
        U = np.zeros(n)
        V = np.zeros(n)
        U[0::dim] = np.asarray(bar.u0(P[0]), float) * np.ones(nodes)
        V[0::dim] = np.asarray(bar.v0(P[0]), float) * np.ones(nodes)
        L = float(bar.L)
        far = np.isclose(P[0], x[-1], rtol=0, atol=1e-12 * L)
        clamp = []
        if bar.far_end == "clamped":
            values = [float(bar.u_L)] + [0.0] * (dim - 1)
            clamp = [fem_nd.Dirichlet(lambda q: np.isclose(q[0], L, rtol=0, atol=1e-12 * L),
                                      values=values)]
        sides = []
        if self.sides == "sliding":
            sides = [lambda q: np.any([np.isclose(q[c], 0.0) | np.isclose(q[c], 1.0)
                                       for c in range(1, dim)], axis=0)]
        red = fem_nd.constrain(body, M, F, dirichlet=clamp, sliding=sides)
        index = red.index
        face = np.flatnonzero(np.isclose(P[0], 0.0, rtol=0, atol=1e-12 * float(bar.L)))
        weights = np.ones(face.size)
        for c in range(1, dim):
            weights *= _trapezoid_weights(y)[np.searchsorted(y, P[c][face])]
        My = sp.diags([np.diff(y) / 6, _trapezoid_weights(y) * 2 / 3, np.diff(y) / 6],
                      [-1, 0, 1], format="csr")  # the consistent mass across, rho = 1
        Mf = My if dim == 2 else sp.kron(My, My, format="csr")
        t = np.searchsorted(y, P[1][face])
        if dim == 3:
            t = t * y.size + np.searchsorted(y, P[2][face])
        contact = ContactSet(dofs=index[dim * face], gap0=np.zeros(face.size), weights=weights,
                             face_mass=sp.csr_matrix(Mf[t][:, t]))
        on_axis = np.ones(nodes, bool)
        for c in range(1, dim):
            on_axis &= P[c] == 0.0
        axis_nodes = np.flatnonzero(on_axis & ~(far & (bar.far_end == "clamped")))
        axis_nodes = axis_nodes[np.argsort(P[0][axis_nodes])]
        axis = AxisView(dofs=index[dim * axis_nodes], x=x,
                        u_fixed=float(bar.u_L) if bar.far_end == "clamped" else None)
        # the x-displacement of every section: equal across it
        order = np.lexsort(tuple(P[c] for c in range(dim - 1, -1, -1)))  # x slowest
        groups = (dim * order).reshape(x.size, -1)
        if bar.far_end == "clamped":
            groups = groups[:-1]
        problem = SparseProblem(
            M=red.M, K=red.K, F=red.F, U0=U[red.free], V0=V[red.free], contact=contact,
            dim=dim, hmin=min(float(np.min(np.diff(x))), float(y[1] - y[0])),
            c_max=float(np.sqrt(float(bar.E) / float(bar.rho))),
            energy_offset=red.energy_offset,
            mass_kind=mass_kind, axis=axis, equal_groups=(index[groups],),
            E_contact=float(bar.E), h_contact=float(x[1] - x[0]),
            normal_stress=self._normal_stress(P, face, index, x, dim))
        return problem


def _trapezoid_weights(a: np.ndarray) -> np.ndarray:
    """The measure each node of a 1D grid stands for (half cells at the ends)."""
    h = np.diff(a)
    w = np.zeros(a.size)
    w[:-1] += 0.5 * h
    w[1:] += 0.5 * h
    return w
