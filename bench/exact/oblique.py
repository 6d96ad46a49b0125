"""Oblique impact of an elastic sphere (or disc) on a rigid plane with Coulomb friction:
Maw, Barber and Fawcett's theory (Wear 38, 1976; J. Lubr. Technol. 103, 1981) in their
normalised variables, as Chung and Ooi (Granular Matter 13, 2011, tests 6-7) use it to
verify a code.

The body is rigid for its inertia (mass m, radius R, radius of gyration k R) and meets
the plane through a quasi-static contact: Hertz's normal pressure, and Mindlin and
Deresiewicz's tangential traction under the varying normal and tangential load, each
annulus of the contact circle sticking or slipping (|q| <= mu p). With V_n the normal
approach speed and c the contact point's tangential velocity (centre velocity plus spin
times R), the variables are

    kappa = 2 (1 - nu) / (2 - nu)   (Mindlin's tangential over Hertz's normal stiffness)
    chi   = (1 - nu) (1 + 1/k^2) / (2 - nu)
    psi   = kappa c / (mu V_n)   (psi1 before the impact, psi2 after, V_n the rebound's)
    Omega = omega R / (mu V_n)   (the spin after the impact, from rest)

Gross sliding (the contact point never sticks; the normal impulse 2 m V_n of an elastic
impact, the tangential one mu times it) is closed form: c changes by 2 mu V_n (1 +
1/k^2), so psi2 = psi1 - 4 chi and Omega = 2 / k^2 (`gross_sliding`). Below it,
`mbf_impact` integrates MBF's ring-by-ring partial slip in time (`mbf_rebound`: the
contact circle cut into annuli, each with its own stuck tangential displacement, slipping
at mu times its share of the Hertz pressure, released when it leaves the contact).
`compliant_impact` is the cruder one-spring model the scene was first compared with (one
tangential spring of Mindlin's incremental stiffness capped by Coulomb); it keeps the
tangential energy the leaving annuli release, and so misses MBF's reversal at small psi1
(docs/oblique-impact.md).
"""

from __future__ import annotations

import numpy as np


def kappa(nu: float) -> float:
    """Mindlin's tangential over Hertz's normal contact stiffness, 2 (1 - nu) / (2 - nu),
    for an elastic body on a rigid plane."""
    return 2.0 * (1.0 - nu) / (2.0 - nu)


def chi(nu: float, k2: float) -> float:
    """Maw-Barber-Fawcett's parameter (1 - nu) (1 + 1/k^2) / (2 - nu), k^2 = I / (m R^2)."""
    return (1.0 - nu) * (1.0 + 1.0 / k2) / (2.0 - nu)


def gross_sliding(psi1: np.ndarray, nu: float, k2: float) -> tuple[np.ndarray, np.ndarray]:
    """(psi2, Omega) of an elastic impact in gross sliding: psi1 - 4 chi and 2 / k^2."""
    psi1 = np.asarray(psi1, float)
    return psi1 - 4.0 * chi(nu, k2), np.full_like(psi1, 2.0 / k2)


def compliant_impact(psi1: np.ndarray, nu: float, k2: float, steps: int = 20000
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(psi2, Omega) for each incidence psi1, by integrating the impact in normalised
    units (m = V_n = mu = 1, Hertz's force P = delta^(3/2), its stiffness 3/2 delta^(1/2)):
    the normal approach by velocity Verlet over `steps` steps of the contact; the
    tangential force Q incremented by -kappa (dP/ddelta) c dt and returned onto |Q| <=
    P; c' = (1 + 1/k^2) Q. Every psi1 shares the normal history (it does not depend on
    the tangential motion)."""
    psi1 = np.asarray(psi1, float)
    kap = kappa(nu)
    # the contact lasts 2.94 delta_max / V_n, delta_max = (5/4)^(2/5) here (Hertz)
    dt = 2.94 * 1.25 ** 0.4 / steps
    c = psi1 / kap  # the contact point's velocity (mu = V_n = 1)
    Q = np.zeros_like(psi1)
    d, v = 0.0, 1.0
    a = 0.0
    while True:
        d_new = d + dt * v + 0.5 * dt * dt * a
        if d_new <= 0.0:
            break
        a_new = -max(d_new, 0.0) ** 1.5
        kn = 1.5 * np.sqrt(0.5 * (d + d_new))
        P = d_new ** 1.5
        c = c + dt * (1.0 + 1.0 / k2) * Q  # the force of the step's start
        Q = np.clip(Q - kap * kn * c * dt, -P, P)
        v = v + 0.5 * dt * (a + a_new)
        d, a = d_new, a_new
    v_out = -v  # the rebound's normal speed (1 up to the step's error)
    psi2 = kap * c / v_out
    omega = (psi1 / kap - c) / (1.0 + k2)
    return psi2, omega


def _cell_load(d: float, x0: np.ndarray, x1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For the approach d (R = 1): each annulus cell [x0, x1]'s length in contact and its
    share of the normal force, the integral of d - x^2 over the part below a = sqrt(d).

    The cells are those of the one-dimensional equivalent (Popov and Hess' reduction of
    an axisymmetric contact: the abscissa x stands for the annulus of radius x, the
    profile x^2 / R for the sphere's), in which Hertz's force is 2 x the integral of
    d - x^2 over [0, a], 4/3 d^(3/2), and Mindlin-Deresiewicz's tangential traction
    for any load history is that of independent springs of kappa times the normal
    stiffness, each stuck or slipping at mu times its normal force."""
    a = np.sqrt(max(d, 0.0))
    top = np.minimum(x1, a)
    length = np.maximum(top - x0, 0.0)
    load = np.where(length > 0.0, d * length - (top ** 3 - x0 ** 3) / 3.0, 0.0)
    return length, np.maximum(load, 0.0)


def mbf_rebound(c1: np.ndarray, mu: float, nu: float, k2: float, annuli: int = 400,
                steps: int = 4000) -> dict[str, np.ndarray]:
    """Maw-Barber-Fawcett's impact integrated in time, in units m = R = V_n = 1 with
    Hertz's force 4/3 d^(3/2) (d the approach): for each initial contact-point velocity
    c1 (no initial spin), the rebound's normal speed `vn2`, tangential centre velocity
    `vt2`, spin times R `spin` (positive against a +x slip), contact-point velocity `c2`
    and the tangential traction's work on the ball `work` (the change of its tangential
    and rotational kinetic energy).

    The contact circle up to the largest contact radius is cut into `annuli` rings
    (`_cell_load`); each ring holds a tangential force f_i: stuck, it grows by kappa
    times its length in contact times the step's slip c dt; it is capped at mu times the
    ring's normal force (slip), and so falls to zero as the ring leaves the contact.
    The normal approach and c advance by velocity Verlet (the normal motion does not
    depend on the tangential one), `steps` steps over Hertz's contact time. mu = inf:
    no ring ever slips (it is released when it leaves the contact)."""
    c1 = np.atleast_1d(np.asarray(c1, float))
    if not (annuli >= 10 and steps >= 100):
        raise ValueError(f"annuli {annuli!r}, steps {steps!r}: need >= 10 and >= 100")
    if not mu > 0.0:
        raise ValueError(f"mu {mu!r}: the theory needs mu > 0")
    kap = kappa(nu)
    d_max = (15.0 / 16.0) ** 0.4  # m V_n^2 / 2 = (8/15) d_max^(5/2)
    dt = 2.9432 * d_max / steps  # Hertz's contact time 2.9432 d_max / V_n
    edges = np.linspace(0.0, 1.001 * np.sqrt(d_max), annuli + 1)
    x0, x1 = edges[:-1], edges[1:]
    gain = 1.0 + 1.0 / k2
    f = np.zeros((c1.size, annuli))
    c = c1.copy()
    impulse = np.zeros_like(c1)  # the tangential force's impulse, against +x
    d, v, F, Q = 0.0, 1.0, 0.0, np.zeros_like(c1)
    while True:
        v_half = v - 0.5 * dt * F
        c_half = c - 0.5 * dt * gain * Q
        impulse += 0.5 * dt * Q
        d_new = d + dt * v_half
        length, load = _cell_load(d_new, x0, x1)
        F = 2.0 * float(np.sum(load)) if d_new > 0.0 else 0.0
        f = f + kap * length[None, :] * (c_half * dt)[:, None]
        if np.isinf(mu):  # no slip: a ring out of the contact carries nothing
            f = np.where(load[None, :] > 0.0, f, 0.0)
        else:
            f = np.clip(f, -mu * load[None, :], mu * load[None, :])
        Q = 2.0 * np.sum(f, axis=1)
        v = v_half - 0.5 * dt * F
        c = c_half - 0.5 * dt * gain * Q
        impulse += 0.5 * dt * Q
        d = d_new
        if d <= 0.0:
            break
    vt2 = c1 - impulse
    spin = impulse / k2
    work = 0.5 * (vt2 ** 2 - c1 ** 2) + 0.5 * k2 * spin ** 2
    return {"vn2": np.full_like(c1, -v), "vt2": vt2, "spin": spin, "c2": vt2 - spin,
            "work": work}


def mbf_impact(psi1: np.ndarray, nu: float, k2: float, annuli: int = 400,
               steps: int = 4000) -> tuple[np.ndarray, np.ndarray]:
    """(psi2, Omega) of Maw-Barber-Fawcett's theory for each psi1 (`mbf_rebound` with
    mu = 1: the normalised results do not depend on mu; psi2 with the rebound's normal
    speed, Omega with the approach's)."""
    psi1 = np.asarray(psi1, float)
    r = mbf_rebound(psi1 / kappa(nu), 1.0, nu, k2, annuli, steps)
    return kappa(nu) * r["c2"] / r["vn2"], r["spin"]


__all__ = ["chi", "compliant_impact", "gross_sliding", "kappa", "mbf_impact", "mbf_rebound"]
