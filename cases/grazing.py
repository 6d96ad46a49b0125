"""Grazing: the end reaches the obstacle with zero velocity and leaves at once.

L = 1, rho = E = 1 (c = 1), g = 0, both ends free, T = 4.
u0 = A (1 + cos(pi x)), v0 = 0 with A = 0.1: the first free-free mode on top of a rigid
shift, u = A (1 + cos(pi x) cos(pi t)). The end u(0, t) = A (1 + cos(pi t)) comes down
to the obstacle at t = 1 (and t = 3) with zero velocity and zero contact force: the
contact periods are single instants (intervals of zero length, checked with the exact
solver in tests/test_scenes.py), and the free motion is the exact solution.

Stresses: contact detection at a touch (a scheme whose discrete end dips below 0 by
dispersion activates a spurious contact, a scheme that smooths the constraint may lift
the end early); everything else is smooth. Reference: that free motion in closed form
(`GrazingExact`), checked against the characteristics solution of the same data, which
finds the touch as a one-node contact run (tests/test_scenes.py). It provides u, u_t
and the energy, but no contact stress: the exact stress is identically 0, so the
relative stress error of the harness (divided by its norm) would be 0/0. The numerical
contact stress is in the trajectory and the figures.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bench.plugin import Case, grid_points

AMPLITUDE = 0.1


@njit(cache=True)
def _outer_kernel(A, at, cx, bt, sx, ct, u, ux, ut):  # pragma: no cover - compiled
    """u[k, m] = at[k] cx[m] + A, ux[k, m] = bt[k] sx[m] (and ut[k, m] = ct[k] cx[m]
    unless ut is empty): `GrazingExact.fields`'s expressions, in one pass."""
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
                      -A * w * np.sin(w * t), u, ux, np.empty((0, 0)) if ut is None else ut)

    def u(self, x, t):
        return self.fields(x, t, velocity=False)[0]

    def ux(self, x, t):
        return self.fields(x, t, velocity=False)[1]

    def ut(self, x, t):
        return self.fields(x, t)[2]

    def stress(self, t):
        """E u_x(0, t) = 0: the end only touches."""
        return np.zeros(np.shape(t))


class Grazing(Case):
    name = "grazing"
    summary = "first free-free mode whose end touches the obstacle with zero velocity"
    L, rho, E, g = 1.0, 1.0, 1.0, 0.0
    far_end, u_L = "free", 0.0
    T, nx, dt = 4.0, 80, 0.005
    reference = "exact"
    provides = frozenset({"u", "v", "energy"})

    def u0(self, x: np.ndarray) -> np.ndarray:
        return AMPLITUDE * (1.0 + np.cos(np.pi * np.asarray(x, float) / self.L))

    def exact(self, T: float) -> GrazingExact:
        return GrazingExact(self.L, float(np.sqrt(self.E / self.rho)), AMPLITUDE)

    @property
    def exact_energy(self) -> float:
        # 1/2 int E u0'^2 = 1/2 E (A pi / L)^2 L / 2
        return 0.25 * self.E * (AMPLITUDE * np.pi) ** 2 / self.L
