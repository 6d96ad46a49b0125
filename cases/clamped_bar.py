"""The clamped bar (Chouly, Hild, Renard 2015; GetFEM's dynamic 1D contact test).

L = 1, rho = E = 1, g = 0, u0 = 1/2 - x/2, v0 = 0, clamped at x = 1 (u = 0). The
bar, compressed against nothing, is released: the end at x = 0 moves down, hits the
obstacle at t = 1, stays in contact until t = 2 with stress -1/2 and flies off; the
motion is periodic with period 3 and the energy is 1/8.

Closed form (derived by marching the characteristics by hand): u = P(x+t) + Q(x-t),
  P(y) = P0(y mod 3) - floor(y/3)/4,  P0(y) = (1-y)/4 on [0,2), (y-3)/4 on [2,3);
  Q(s) = Q0(r mod 3) + floor(r/3)/4 with r = 1 - s,
  Q0(r) = r/4 on [0,1), (2-r)/4 on [1,2), (r-2)/4 on [2,3).
Stresses this scene: a kinked, piecewise-linear solution with repeated impacts.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bench.plugin import Case, flat_points, grid_points


@njit(cache=True)
def _mod3(y: float, fl: float) -> float:
    """y mod 3 in [0, 3) given fl = floor(y / 3.0): equal to Python's y % 3.0 (np.mod)
    for y >= 0, all this scene needs (y = x + t and 1 - x + t, x in [0, 1], t >= 0).

    y - 3 fl is exact (Sterbenz) and is the remainder unless y / 3 rounded up to the
    integer fl, where it is slightly negative and + 3 gives it. Branch-free, unlike the
    libm fmod behind `%` (ten times slower here)."""
    m = y - 3.0 * fl
    return m + 3.0 if m < 0.0 else m


@njit(cache=True)
def _point(x: float, t: float) -> tuple[float, float, float]:
    """(u, u_x, u_t) = (P(x+t) + Q(x-t), P' + Q', P' - Q') at one point; the slopes at
    a kink are those of the piece to the right, as np.where(r < 2, ...) gives them."""
    y = x + t
    fy = math.floor(y / 3.0)
    ry = _mod3(y, fy)
    P = ((1.0 - ry) / 4.0 if ry < 2.0 else (ry - 3.0) / 4.0) - fy / 4.0
    dP = -0.25 if ry < 2.0 else 0.25
    r = 1.0 - (x - t)
    fr = math.floor(r / 3.0)
    m = _mod3(r, fr)
    if m < 1.0:
        Q, dQ = m / 4.0, -0.25  # dQ/ds = -dQ0/dr
    elif m < 2.0:
        Q, dQ = (2.0 - m) / 4.0, 0.25
    else:
        Q, dQ = (m - 2.0) / 4.0, -0.25
    return P + (Q + fr / 4.0), dP + dQ, dP - dQ


@njit(cache=True)
def _fields_kernel(x, t, u, ux, ut):  # pragma: no cover - compiled
    """`_point` at the points (x[n], t[n]) (1-D arrays)."""
    for n in range(x.size):
        u[n], ux[n], ut[n] = _point(x[n], t[n])


@njit(cache=True)
def _grid_kernel(x, t, u, ux, ut):  # pragma: no cover - compiled
    """`_point` at the points (x[m], t[k]) into u[k, m], ux[k, m] (and ut[k, m] unless
    ut is empty): every sample time against the same points, without broadcast copies."""
    want_v = ut.size > 0
    for k in range(t.size):
        tk = t[k]
        for m in range(x.size):
            a, b, c = _point(x[m], tk)
            u[k, m] = a
            ux[k, m] = b
            if want_v:
                ut[k, m] = c


class ClampedBarExact:
    """The closed form above (rho = E = c = 1)."""

    energy = 0.125

    def fields(self, x, t, velocity: bool = True):
        """(u, u_x, u_t) at once (u_t None unless `velocity`): what the error norms use."""
        xf, tf, shape = flat_points(x, t)
        u, ux, ut = np.empty(xf.size), np.empty(xf.size), np.empty(xf.size)
        _fields_kernel(xf, tf, u, ux, ut)
        return u.reshape(shape), ux.reshape(shape), (ut.reshape(shape) if velocity else None)

    def fields_into(self, x: np.ndarray, t: np.ndarray, u: np.ndarray, ux: np.ndarray,
                    ut: np.ndarray | None = None) -> None:
        """`fields` at the points (x[m], t[k]) written into u[k, m], ux[k, m] and ut[k, m]
        (x, t 1-D; the outputs C-contiguous float arrays of shape (t.size, x.size)):
        what the error norms use, without temporaries."""
        x, t = grid_points(x, t, u, ux, ut)
        _grid_kernel(x, t, u, ux, np.empty((0, 0)) if ut is None else ut)

    def u(self, x, t):
        return self.fields(x, t, velocity=False)[0]

    def ut(self, x, t):
        return self.fields(x, t)[2]

    def ux(self, x, t):
        return self.fields(x, t, velocity=False)[1]

    def stress(self, t):
        t = np.asarray(t, float)
        return np.where((np.mod(t, 3.0) > 1.0) & (np.mod(t, 3.0) < 2.0), -0.5, 0.0)


class ClampedBar(Case):
    name = "clamped_bar"
    summary = "clamped bar released from compression, period 3, energy 1/8 (closed form)"
    L, rho, E, g = 1.0, 1.0, 1.0, 0.0
    far_end, u_L = "clamped", 0.0
    T, nx, dt = 12.0, 80, 0.005
    reference = "exact"
    in_default_run = True
    provides = frozenset({"u", "v", "stress", "energy"})

    def u0(self, x):
        return 0.5 - 0.5 * np.asarray(x, float)

    def exact(self, T: float) -> ClampedBarExact:
        return ClampedBarExact()

    @property
    def exact_energy(self) -> float:
        return 0.125
