"""Hertz's impact formulas (contact_bench.exact.hertz) against the note's derived numbers
and against an independent integration of m d'' = -k d^(3/2)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from contact_bench.exact.hertz import CONTACT_TIME_FACTOR, HertzImpact


def test_indentation_contact_time_and_peak_force_at_v_001():
    h = HertzImpact(R=1.0, E=1.0, nu=0.3, rho=1.0, v=0.01)
    assert h.d_max == pytest.approx(0.04181, abs=5e-6)
    assert h.contact_time == pytest.approx(12.30, abs=5e-3)
    assert h.peak_force == pytest.approx(0.01252, abs=5e-6)
    assert CONTACT_TIME_FACTOR == pytest.approx(2.9433, abs=1e-4)


@pytest.mark.parametrize("v", [0.01, 0.001, 0.3])
def test_against_the_ode(v):
    """m d'' = -k d^(3/2) from d = 0, d' = v: the contact ends when d returns to 0."""
    h = HertzImpact(R=1.3, E=2.0, nu=0.25, rho=0.7, v=v)

    def rhs(_t, y):
        return [y[1], -h.k * max(y[0], 0.0) ** 1.5 / h.mass]

    def back(_t, y):
        return y[0]

    back.terminal, back.direction = True, -1
    guess = 10 * h.d_max / v
    sol = solve_ivp(rhs, (0.0, guess), [0.0, v], events=back, rtol=1e-11, atol=1e-14 * h.d_max,
                    dense_output=True)
    t_end = sol.t_events[0][0]
    assert t_end == pytest.approx(h.contact_time, rel=1e-7)
    t = np.linspace(0.0, t_end, 20001)
    d = sol.sol(t)[0]
    assert d.max() == pytest.approx(h.d_max, rel=1e-7)
    assert h.k * d.max() ** 1.5 == pytest.approx(h.peak_force, rel=1e-7)
    # energy: the kinetic energy is stored at the largest approach
    assert 0.4 * h.k * h.d_max**2.5 == pytest.approx(0.5 * h.mass * v * v, rel=1e-12)


@pytest.mark.parametrize("bad", [dict(v=0.0), dict(R=-1.0), dict(nu=0.5), dict(E=math.nan)])
def test_bad_values_are_named(bad):
    args = dict(R=1.0, E=1.0, nu=0.3, rho=1.0, v=0.01) | bad
    with pytest.raises(ValueError, match=next(iter(bad))):
        HertzImpact(**args)
