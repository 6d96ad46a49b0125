"""Oblique impact of an elastic sphere (or disc) on a rigid plane with Coulomb friction:
Maw, Barber and Fawcett's theory (Wear 38, 1976) in their normalised variables, as Chung
and Ooi (Granular Matter 13, 2011) use it to verify a code.

The body is rigid for its inertia (mass m, radius R, radius of gyration k R) and meets
the plane through a quasi-static Hertz-Mindlin contact: the normal force a function of
the approach, the tangential force the contact's elastic compliance capped by Coulomb's
mu times the normal force. With V_n the normal approach speed and c the contact point's
tangential velocity (centre velocity plus spin times R), the variables are

    kappa = 2 (1 - nu) / (2 - nu)   (Mindlin's tangential over Hertz's normal stiffness)
    chi   = (1 - nu) (1 + 1/k^2) / (2 - nu)
    psi   = kappa c / (mu V_n)   (psi1 before the impact, psi2 after, V_n the rebound's)
    Omega = omega R / (mu V_n)   (the spin after the impact, from rest)

Gross sliding (the contact point never sticks; the normal impulse 2 m V_n of an elastic
impact, the tangential one mu times it) is closed form: c changes by 2 mu V_n (1 +
1/k^2), so psi2 = psi1 - 4 chi and Omega = 2 / k^2 (`gross_sliding`). Below it the
tangential compliance matters: `compliant_impact` integrates the contact in time (Hertz
normal force, the tangential force's increments kappa times the normal stiffness times
the slip, returned onto the Coulomb limit), the 'no-slip' reading of Mindlin and
Deresiewicz's law; its limits are the theory's (gross sliding, and no slip as mu -> oo,
where psi2 / psi1 is the tangential oscillation's), in between it is a model of the
partial slip that Maw, Barber and Fawcett resolve ring by ring (docs/oblique-impact.md).
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


__all__ = ["chi", "compliant_impact", "gross_sliding", "kappa"]
