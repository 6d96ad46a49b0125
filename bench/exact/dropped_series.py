"""The dropped bar's series solution (Dabaghi, Petrov, Pousin, Renard 2014, eq. 5.5), corrected.

A cross-check of the `dropped_bar` scene's reference (the characteristics solution),
for its data only: L = 10, E = 900, rho = 1, g = 10, u0 = 5, v0 = 0, both ends free.
The paper's formula has a typo: in h1 the factor sqrt(2 u0 / g) must be sqrt(2 u0 g)
(the impact speed 10, not the fall time 1). Its impact times
t_{4k+1} = 3L/sqrt(E) + 16 k L/sqrt(E) rely on sqrt(2 u0 / g) = 3 L / sqrt(E), true for
these parameters only. With `SERIES_MODES` modes the truncation error on u is below
`SERIES_TRUNCATION` (the tail of h2's series, sum_{n>N} 4 g / (E lam_n^2) <=
4 g L^2 / (E pi^2 N); h1's tail is O(N^-2)).
"""

from __future__ import annotations

import numpy as np

LENGTH, YOUNG, GRAVITY, HEIGHT = 10.0, 900.0, 10.0, 5.0  # the dropped_bar scene (rho = 1)
SERIES_MODES = 4000
SERIES_TRUNCATION = 1.2e-4  # bound on |u_series - u| with SERIES_MODES modes


def series_u(x: np.ndarray, t: np.ndarray, modes: int = SERIES_MODES) -> np.ndarray:
    """u(x, t) of the dropped bar by the corrected eq. (5.5), vectorised."""
    L, E, g, u0 = LENGTH, YOUNG, GRAVITY, HEIGHT
    x, t = np.broadcast_arrays(np.asarray(x, float), np.asarray(t, float))
    x, t = x.ravel(), t.ravel()
    sE = np.sqrt(E)
    tL, t1, vf = L / sE, np.sqrt(2 * u0 / g), np.sqrt(2 * u0 * g)
    n = np.arange(1, modes + 1)
    nu, lam = (n - 0.5) * np.pi / L, n * np.pi / L

    def h1(xx, tt):
        s = np.zeros_like(xx)
        for a in range(0, xx.size, 2000):
            b = slice(a, a + 2000)
            s[b] = ((np.cos(sE * np.outer(tt[b], nu)) - 1) * np.sin(np.outer(xx[b], nu))
                    ) @ (2 * g / (E * L * nu**3))
        return -vf * np.minimum(xx / sE, tL - np.abs(tt - tL)) + s

    def h2(xx, tt):
        s = np.zeros_like(xx)
        for a in range(0, xx.size, 2000):
            b = slice(a, a + 2000)
            s[b] = (np.cos(sE * np.outer(tt[b], lam)) * np.cos(np.outer(xx[b], lam))
                    ) @ (4 * g / (E * lam**2))
        return u0 - 0.5 * g * (tt - t1) ** 2 - 2 * g * L**2 / (3 * E) + s

    out = np.empty_like(x)
    period = 16 * tL
    k = np.floor((t - 3 * tL) / period)
    k = np.maximum(k, 0)
    ta = 3 * tL + k * period  # t_{4k+1}
    tb, tc, td = ta + 2 * tL, ta + 8 * tL, ta + 10 * tL
    free0 = t <= t1
    out[free0] = u0 - 0.5 * g * t[free0] ** 2
    m1 = ~free0 & (t > ta) & (t <= tb)
    out[m1] = h1(x[m1], t[m1] - ta[m1])
    m2 = ~free0 & (t > tb) & (t <= tc)
    out[m2] = h2(x[m2], t[m2] - tb[m2])
    m3 = ~free0 & (t > tc) & (t <= td)
    out[m3] = h1(x[m3], td[m3] - t[m3])
    m4 = ~free0 & (t > td)
    out[m4] = u0 - 0.5 * g * (t[m4] - td[m4] - t1) ** 2
    return out
