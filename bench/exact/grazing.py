"""The free motion u = A (1 + cos(pi x / L) cos(pi c t / L)) in closed form: the grazing
scene's reference, evaluated in compiled code (`GrazingExact`)."""

from __future__ import annotations

import numpy as np
from numba import njit

from contact_bench.api.plugin import Fields, grid_points


@njit(cache=True)
def _outer_kernel(A, at, cx, bt, sx, ct, out):  # pragma: no cover - compiled
    """u[k, m] = at[k] cx[m] + A, ux[k, m] = bt[k] sx[m] (and ut[k, m] = ct[k] cx[m]
    unless ut is empty), out the `Fields` (u, ux, ut): `GrazingExact.fields`'s
    expressions, in one pass."""
    u, ux, ut = out
    want_v = ut.size > 0
    for k in range(at.size):
        a, b, c = at[k], bt[k], ct[k]
        uk, uxk = u[k], ux[k]
        vk = ut[k] if want_v else uk
        for m in range(cx.size):
            uk[m] = a * cx[m] + A
            uxk[m] = b * sx[m]
            if want_v:
                vk[m] = c * cx[m]


class GrazingExact:
    """u = A (1 + cos(k x) cos(w t)), k = pi / L, w = c k: the first free-free mode on a
    rigid shift A. Separable, so `fields_into` takes the cosines and sines once per
    point and once per time, and each field is one product per (time, point), compiled
    (`_outer_kernel`, one pass over the outputs)."""

    def __init__(self, L: float, c: float, A: float) -> None:
        self.A, self.k, self.w = float(A), np.pi / float(L), np.pi * float(c) / float(L)

    def fields(self, x, t, velocity: bool = True):
        """(u, u_x, u_t) at once, x and t broadcast (u_t None unless `velocity`)."""
        x, t = np.broadcast_arrays(np.asarray(x, float), np.asarray(t, float))
        A, k, w = self.A, self.k, self.w
        cx, ct = np.cos(k * x), np.cos(w * t)
        u = (A * ct) * cx + A
        ux = (-A * k * ct) * np.sin(k * x)
        ut = (-A * w * np.sin(w * t)) * cx if velocity else None
        return u, ux, ut

    def fields_into(self, x: np.ndarray, t: np.ndarray, u: np.ndarray, ux: np.ndarray,
                    ut: np.ndarray | None = None) -> None:
        """`fields` at the points (x[m], t[k]) written into u[k, m], ux[k, m] and ut[k, m]
        (x, t 1-D; outputs C-contiguous float arrays of shape (t.size, x.size)): what the
        error norms use, with the same expressions as `fields`."""
        x, t = grid_points(x, t, u, ux, ut)
        A, k, w = self.A, self.k, self.w
        ct = np.cos(w * t)
        _outer_kernel(A, A * ct, np.cos(k * x), -A * k * ct, np.sin(k * x),
                      -A * w * np.sin(w * t),
                      Fields(u, ux, np.empty((0, 0)) if ut is None else ut))

    def u(self, x, t):
        return self.fields(x, t, velocity=False)[0]

    def ux(self, x, t):
        return self.fields(x, t, velocity=False)[1]

    def ut(self, x, t):
        return self.fields(x, t)[2]

    def stress(self, t):
        """E u_x(0, t) = 0: the end only touches."""
        return np.zeros(np.shape(t))
