"""The first contact of a 1D reference: its start, end, duration, peak force, impulse.

Generic over the exact solutions (`contact_bench.api.plugin.Exact`): read from the
reference's contact stress sigma(0, t) alone, so every reference that provides the
stress provides these quantities, closed forms, characteristics and d'Alembert alike.

* Contact at t: the contact force -sigma(0, t) is above `FORCE_TOL` times the largest
  force scanned (below). A reference without a positive force (a grazing
  touch: zero force, contact of zero duration) has no first contact.
* Scan: `SCAN_SAMPLES` uniform times over [0, T], chunk by chunk until the first
  contact has ended; a contact shorter than the scan's spacing between two of them is
  missed (T / SCAN_SAMPLES: 1e-4 for T = 6).
* Start and end: bisection of the contact predicate between the last scanned time
  without and the first with (start), the last with and the first without (end), down
  to a few ulps of the time (`STOP_ULPS`). Where the force jumps (an impact at nonzero
  speed) that is the jump; where it goes to 0 continuously (a smooth take-off) it is
  the root, shifted by FORCE_TOL x peak / |slope|. A contact is a positive force: a
  stretch where the end rests on the obstacle without force (rough_data's (1.5, 1.7))
  is no contact (the characteristics' `contact_intervals`, on u(0, t), count it).
* Peak force: the largest force over the contact, from a dense scan of it refined by
  golden-section search around its best sample, and the one-sided limits at the
  start and end (the force `EDGE_ULPS` ulps inside them): exact for piecewise-linear
  forces (whose maximum is at a kink or an end), to round-off for smooth ones.

* Impulse: the integral of the force over [start, end], by adaptive Gauss-Legendre
  quadrature (`integral`: panels split until their 5- and 10-point rules agree to
  `IMPULSE_TOL` x peak x duration, all panels of a round in one call of the stress):
  exact to that tolerance on piecewise-linear forces, their kinks and jumps included.

The end is None when the contact lasts to T (then no end, duration or impulse).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from contact_bench.api.plugin import CONTACT_QUANTITIES

#: contact: the force above this fraction of the scan's largest force
FORCE_TOL = 1e-12
#: uniform scan times over [0, T] for the first contact
SCAN_SAMPLES = 1 << 16
#: scan times per chunk (the scan stops once the first contact has ended)
CHUNK = 1 << 12
#: samples of the contact interval for its peak force
PEAK_SAMPLES = 4096
#: the one-sided limits at the contact's ends: this many ulps of the time inside
EDGE_ULPS = 64
#: bisection and golden-section search stop at this many ulps of the time
STOP_ULPS = 4
#: the impulse's quadrature: absolute tolerance per panel, relative to peak x duration
IMPULSE_TOL = 1e-15
#: ... and at most this many rounds of splitting panels
IMPULSE_ROUNDS = 80


@dataclass(frozen=True)
class FirstContact:
    """The first contact of a reference on [0, T]: start and end times (end None if it
    lasts to T) and the peak contact force (per unit section: -sigma(0, t))."""

    start: float
    end: float | None
    peak_force: float
    impulse: float | None = None

    @property
    def duration(self) -> float | None:
        return None if self.end is None else self.end - self.start

    def quantities(self) -> dict[str, float]:
        """The reference values by quantity name (`CONTACT_QUANTITIES`), those it has."""
        out = {"contact_start": self.start, "peak_force": self.peak_force}
        if self.end is not None:
            out["contact_end"] = self.end
            out["contact_duration"] = self.end - self.start
        if self.impulse is not None:
            out["contact_impulse"] = self.impulse
        return out


def _bisect(inside: Callable[[float], bool], a: float, b: float, tol: float) -> float:
    """The switch of `inside` in (a, b], inside(a) != inside(b): bisection down to tol
    ulps of b."""
    side_a = inside(a)
    while b - a > tol * np.spacing(b):
        m = 0.5 * (a + b)
        if m <= a or m >= b:
            break
        if inside(m) == side_a:
            a = m
        else:
            b = m
    return 0.5 * (a + b)


def _golden_max(f: Callable[[float], float], a: float, b: float, tol: float) -> float:
    """max of f on [a, b] near a local maximum, by golden-section search down to tol
    ulps of b."""
    r = (math.sqrt(5.0) - 1.0) / 2.0
    c, d = b - r * (b - a), a + r * (b - a)
    fc, fd = f(c), f(d)
    best = max(f(a), f(b), fc, fd)
    while b - a > tol * np.spacing(b):
        if fc >= fd:
            b, d, fd = d, c, fc
            c = b - r * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + r * (b - a)
            fd = f(d)
        best = max(best, fc, fd)
    return best


def first_contact(stress: Callable[[np.ndarray], np.ndarray], T: float
                  ) -> FirstContact | None:
    """The first contact of a reference whose contact stress is `stress(t)` (<= 0,
    arrays of times in [0, T]) on [0, T], or None without a positive contact force
    (module docstring)."""
    T = float(T)
    if not (T > 0.0 and math.isfinite(T)):
        raise ValueError(f"T must be positive and finite, got {T!r}")

    def force(t: np.ndarray) -> np.ndarray:
        return -np.asarray(stress(np.asarray(t, float)), float)

    def force1(t: float) -> float:
        return float(force(np.array([min(max(t, 0.0), T)]))[0])

    times = np.linspace(0.0, T, SCAN_SAMPLES + 1)
    scale = 0.0
    values = np.empty(0)
    for lo in range(0, times.size, CHUNK):
        f = force(times[lo:lo + CHUNK])
        values = np.concatenate([values, f])
        scale = max(scale, float(np.max(f, initial=0.0)))
        on = values > FORCE_TOL * scale
        if on.any() and not on[np.argmax(on):].all():  # the first contact has ended
            break
    if not scale > 0.0:
        return None
    tol_f = FORCE_TOL * scale
    on = values > tol_f
    a = int(np.argmax(on))
    off = np.flatnonzero(~on[a:])

    def inside(t: float) -> bool:
        return force1(t) > tol_f

    start = 0.0 if a == 0 else _bisect(inside, float(times[a - 1]), float(times[a]),
                                       STOP_ULPS)
    end = None
    if off.size:
        b = a + int(off[0])
        end = _bisect(inside, float(times[b - 1]), float(times[b]), STOP_ULPS)
    hi = T if end is None else end
    edge = EDGE_ULPS * float(np.spacing(hi))
    dense = np.linspace(start + edge, hi - edge, PEAK_SAMPLES + 1)
    f = force(dense)
    k = int(np.argmax(f))
    lo_k, hi_k = dense[max(k - 1, 0)], dense[min(k + 1, dense.size - 1)]
    peak = max(float(f[k]), _golden_max(force1, float(lo_k), float(hi_k), STOP_ULPS),
               force1(start + edge), force1(hi - edge))
    impulse = None
    if end is not None:
        impulse = integral(force, start, end, IMPULSE_TOL * peak * (end - start))
    return FirstContact(start=float(start), end=None if end is None else float(end),
                        peak_force=peak, impulse=impulse)


def integral(f: Callable[[np.ndarray], np.ndarray], a: float, b: float, tol: float
             ) -> float:
    """int_a^b f by adaptive Gauss-Legendre quadrature, f vectorised: 64 panels, each
    accepted when its 5- and 10-point rules differ by at most tol (absolute; or when it
    is a few ulps long), else halved; every round's panels in one call of f."""
    x5, w5 = np.polynomial.legendre.leggauss(5)
    x10, w10 = np.polynomial.legendre.leggauss(10)
    nodes = np.concatenate([x5, x10])
    edges = np.linspace(a, b, 65)
    lo, hi = edges[:-1], edges[1:]
    total = 0.0
    for _ in range(IMPULSE_ROUNDS):
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        values = f((mid[:, None] + half[:, None] * nodes[None, :]).ravel())
        values = values.reshape(lo.size, nodes.size)
        g5 = half * (values[:, :5] @ w5)
        g10 = half * (values[:, 5:] @ w10)
        done = (np.abs(g10 - g5) <= tol) | (hi - lo <= 8 * np.spacing(np.abs(hi)))
        total += float(np.sum(g10[done]))
        if done.all():
            return total
        lo, hi = lo[~done], hi[~done]
        m = 0.5 * (lo + hi)
        lo, hi = np.concatenate([lo, m]), np.concatenate([m, hi])
    raise RuntimeError(f"integral on [{a!r}, {b!r}]: {lo.size} panels above {tol:g} "
                       f"after {IMPULSE_ROUNDS} rounds")


__all__ = ["CONTACT_QUANTITIES", "FirstContact", "first_contact", "integral"]
