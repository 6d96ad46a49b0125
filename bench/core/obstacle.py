"""The gaps of a contact set as the loop's bookkeeping reads them: linear or curved.

A contact set's gaps are g = gap0 + G U for a plane (at any angle) or two bodies: G as
its CSR arrays (indptr, indices, data). A rigid sphere (a circle in 2D) of centre c and
radius R with the body outside it has the nonlinear gaps g_j = |x_j + U_j - c| - R
(`Sphere`: x_j the reference position of contact point j, U_j its displacement, read from
the dofs `dofs[j]`); the compiled schemes step it through a tangent G updated every step
(`contact_bench.kernels.contact`), while the smallest gap here is the exact nonlinear one.
`min_gap(G, gap0, U, start)` takes either (numba dispatches on G's type).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba.extending import overload

from contact_bench.core.numba_types import is_tuple_type
from contact_bench.core.refcount import uncounted


class Sphere(NamedTuple):
    """A rigid sphere (circle in 2D), the body outside it: gap_j = |points[j] +
    U[dofs[j]] - centre| - radius."""

    centre: np.ndarray  # (dim,)
    radius: float
    points: np.ndarray  # (n_c, dim): the contact points' reference positions
    dofs: np.ndarray  # (n_c, dim) int64: the dof of each component (-1: held at 0)


def sphere(centre: np.ndarray, radius: float, points: np.ndarray,
           dofs: np.ndarray) -> Sphere:
    """A `Sphere` with its arrays in the compiled kernels' dtypes and layouts; a one-line
    ValueError names a radius that is not positive or shapes that do not match."""
    c = np.ascontiguousarray(centre, float).ravel()
    P = np.ascontiguousarray(points, float)
    D = np.ascontiguousarray(dofs, np.int64)
    if not (math.isfinite(float(radius)) and float(radius) > 0.0):
        raise ValueError(f"radius = {radius!r}: must be positive and finite")
    if P.ndim != 2 or P.shape != D.shape or P.shape[1] != c.size:
        raise ValueError(f"points {P.shape}, dofs {D.shape}, centre {c.shape}: expected "
                         "(n_c, dim) twice and (dim,)")
    return Sphere(c, float(radius), P, D)


@uncounted
def point_u(ob, j, a, U):  # pragma: no cover - compiled
    """Component a of contact point j's displacement in U (0 for a held component)."""
    d = ob.dofs[j, a]
    return U[d] if d >= 0 else 0.0


@uncounted
def sphere_gap(ob, j, U):  # pragma: no cover - compiled
    """The exact gap of contact point j of the sphere `ob` in state U."""
    acc = 0.0
    for a in range(ob.centre.size):
        d = ob.points[j, a] + point_u(ob, j, a, U) - ob.centre[a]
        acc += d * d
    return math.sqrt(acc) - ob.radius


def sphere_gaps(ob: Sphere, U: np.ndarray) -> np.ndarray:
    """Every contact point's exact gap in U (or in each state of a stack, last axis)."""
    U = np.asarray(U, float)
    x = ob.points + np.where(ob.dofs >= 0, U[..., np.maximum(ob.dofs, 0)], 0.0)
    return np.linalg.norm(x - ob.centre, axis=-1) - ob.radius


def min_gap(G, gap0, U, start):  # pragma: no cover - compiled through its overload
    """min(start, smallest gap of U): gap0 + G U for G's CSR arrays, the exact gaps for a
    `Sphere`."""
    if isinstance(G, Sphere):
        return float(min(start, np.min(sphere_gaps(G, U), initial=np.inf)))
    indptr, indices, data = G
    g = start
    for j in range(gap0.size):
        g = min(g, gap0[j] + float(np.dot(data[indptr[j]:indptr[j + 1]],
                                          U[indices[indptr[j]:indptr[j + 1]]])))
    return g


@overload(min_gap)
def _min_gap_compiled(G, gap0, U, start):  # pragma: no cover - compiled
    if is_tuple_type(G, Sphere):
        def curved(G, gap0, U, start):
            g = start
            for j in range(G.points.shape[0]):
                g = min(g, sphere_gap(G, j, U))
            return g
        return curved

    def linear(G, gap0, U, start):
        indptr, indices, data = G
        g = start
        for j in range(gap0.size):
            acc = 0.0
            for kk in range(indptr[j], indptr[j + 1]):
                acc += data[kk] * U[indices[kk]]
            g = min(g, gap0[j] + acc)
        return g
    return linear
