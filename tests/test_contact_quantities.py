"""The first-contact quantities of the 1D references (`contact_bench.exact.contacts`) against
independent closed forms, and their error columns on runs (`contact_bench.harness.quantities`):
present, converging with nx and dt, inherited by the embedded bar, absent where the
reference does not provide them."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

from contact_bench.api.registry import make_case
from contact_bench.exact.contacts import FirstContact, first_contact
from contact_bench.harness.quantities import contact_quantity_errors, run_first_contact
from contact_bench.harness.runner import run_one

CONTACT_COLUMNS = ("err_contact_start", "err_contact_end", "err_contact_duration",
                   "err_peak_force", "err_contact_impulse")


def _reference(name: str) -> FirstContact:
    case = make_case(name)
    fc = first_contact(case.exact(case.T).stress, case.T)
    assert fc is not None and fc.end is not None
    return fc


def test_clamped_and_dropped_bar_against_closed_forms():
    """clamped_bar: contact [1, 2], force 1/2. dropped_bar: free fall to t1 = sqrt(2 h / g),
    contact for 2 L / c, the force rho c (g t1 + g t') growing linearly to
    rho c g t1 + 2 rho g L; the impulses: force x duration, the mean force x duration."""
    fc = _reference("clamped_bar")
    assert (fc.start, fc.end, fc.duration, fc.peak_force, fc.impulse) == pytest.approx(
        (1.0, 2.0, 1.0, 0.5, 0.5), rel=1e-14)
    case = make_case("dropped_bar")
    fc = _reference("dropped_bar")
    c = case.wave_speed
    t1 = math.sqrt(2 * case.height / case.g)
    assert fc.start == pytest.approx(t1, rel=1e-14)
    assert fc.duration == pytest.approx(2 * case.L / c, rel=1e-13)
    first = case.rho * c * case.g * t1
    peak = first + 2 * case.rho * case.g * case.L
    assert fc.peak_force == pytest.approx(peak, rel=1e-12)
    assert fc.impulse == pytest.approx(0.5 * (first + peak) * 2 * case.L / c, rel=1e-13)


@pytest.mark.parametrize("name", ["steel_bar", "fast_impact[mach=0.5]", "fast_impact"])
def test_uniform_impacts_against_closed_forms(name):
    """A free bar at speed v: impact at gap / v, two transits 2 L / c in contact, force
    rho c v, impulse 2 rho L v (the momentum reversed; steel_bar in SI units,
    fast_impact at two Mach numbers)."""
    case = make_case(name)
    x = np.array([0.0])
    gap, v = float(case.u0(x)[0]), -float(case.v0(x)[0])
    c = case.wave_speed
    fc = _reference(name)
    assert fc.start == pytest.approx(gap / v, rel=1e-13)
    assert fc.duration == pytest.approx(2 * case.L / c, rel=1e-13)
    assert fc.peak_force == pytest.approx(case.rho * c * v, rel=1e-13)
    assert fc.impulse == pytest.approx(2 * case.rho * case.L * v, rel=1e-13)


def test_pulse_against_its_travelling_waves():
    """By hand from d'Alembert: u = P(x + t) + Q(x - t) with P' = -gap / 2 + f',
    f(s) = -A b((s - x0) / w), and Q' = -gap / 2 from the data. Before the contact the
    free end's u_x(0, t) = 0 gives u(0, t) = gap (1 - t) + 2 f(t) (f(0) = 0): the impact
    is its root. In contact u(0, t) = 0 gives Q'(-t) = P'(t), so the force is
    -2 P'(t) = gap - 2 f'(t), which leaves at its zero; the peak is its maximum between,
    the impulse its integral gap (end - start) - 2 (f(end) - f(start))."""
    from contact_bench.cases import pulse

    A, gap, x0, w = pulse.AMPLITUDE, pulse.GAP, pulse.CENTER, pulse.WIDTH

    def bump(t: float) -> tuple[float, float]:
        y = (t - x0) / w
        if abs(y) >= 1.0:
            return 0.0, 0.0
        b = math.exp(1 - 1 / (1 - y * y))
        return b, b * (-2 * y / (1 - y * y) ** 2) / w  # b and d/dt b

    def end_height(t: float) -> float:
        return gap * (1 - t) - 2 * A * bump(t)[0]

    def force(t: float) -> float:
        return gap + 2 * A * bump(t)[1]  # gap - 2 f'(t)

    start = brentq(end_height, x0 - w, x0, xtol=1e-16, rtol=1e-15)
    end = brentq(force, x0 + 1e-3, x0 + 0.5 * w, xtol=1e-16, rtol=1e-15)
    best = minimize_scalar(lambda t: -force(t), bounds=(start, end), method="bounded",
                           options={"xatol": 1e-12})
    fc = _reference("pulse")
    assert fc.start == pytest.approx(start, rel=1e-13)
    assert fc.end == pytest.approx(end, rel=1e-10)  # a smooth take-off: the force's root
    # the reference's slopes come from its cubic Hermite table (2e-8 on u_x by
    # docs/exact-solutions.md), so its peak force is good to that
    assert fc.peak_force == pytest.approx(-best.fun, rel=1e-8)
    impulse = gap * (end - start) + 2 * A * (bump(end)[0] - bump(start)[0])
    assert fc.impulse == pytest.approx(impulse, rel=1e-9)


def test_rough_data_contact_ends_with_its_force():
    """rough_data's end rests on the obstacle without force on (1.5, 1.7): a contact is
    a positive force, so the first contact ends at 1.5 (the characteristics' displacement
    intervals say 1.7)."""
    case = make_case("rough_data")
    ex = case.exact(case.T)
    fc = first_contact(ex.stress, case.T)
    assert (fc.start, fc.end, fc.peak_force) == pytest.approx((0.5, 1.5, 0.75), rel=1e-14)
    assert ex.contact_intervals()[0] == pytest.approx((0.5, 1.7), rel=1e-14)
    t = np.linspace(1.51, 1.69, 7)
    assert np.all(ex.stress(t) == 0.0) and np.all(np.abs(ex.u(0.0, t)) < 1e-14)


def test_no_first_contact_without_force_or_before_T():
    assert first_contact(make_case("grazing").exact(4.0).stress, 4.0) is None  # touches
    fc = first_contact(make_case("clamped_bar").exact(1.5).stress, 1.5)
    assert fc.start == pytest.approx(1.0, rel=1e-15) and fc.end is None
    assert set(fc.quantities()) == {"contact_start", "peak_force"}


def test_run_first_contact_from_samples_and_from_step_statistics():
    """Samples: the switches where the free samples' smallest gap (contact_u) crosses zero,
    by the secant of the two free samples next to each (the midpoint of the bracketing
    samples without them), the peak over the contact's samples. Per-step statistics:
    their instants as they are (interpolated by the loop), the force per area."""
    t = np.arange(8.0)
    stress = -np.array([0, 0, 1, 3, 2, 0, 5, 0.0])
    gap = np.array([2.5, 1.0, 0, 0, 0, 0.1, 0, 1.0])
    fc = run_first_contact(SimpleNamespace(t=t, stress=stress, contact_u=gap, extra={}), 1.0)
    # start: 1 + 1 / 1.5 on the secant of samples 0, 1; end: contact again at sample 6
    assert (fc.start, fc.end, fc.peak_force, fc.impulse) == pytest.approx(
        (1.0 + 1.0 / 1.5, 4.5, 3.0, 6.0), rel=1e-15)
    stress[6], gap[6] = 0.0, 0.5
    fc = run_first_contact(SimpleNamespace(t=t, stress=stress, contact_u=gap, extra={}), 1.0)
    assert fc.end == pytest.approx(5.0 - 0.1 / 0.4, rel=1e-15)  # back along samples 5, 6
    steps = SimpleNamespace(t=t, stress=stress, contact_u=gap, extra={
        "first_contact_start": 2.25, "first_contact_end": 4.75, "first_contact_peak": 6.0,
        "first_contact_impulse": 8.0})
    fc = run_first_contact(steps, 0.5, area=2.0)
    assert (fc.start, fc.end, fc.peak_force, fc.impulse) == (2.25, 4.75, 3.0, 4.0)
    ref = FirstContact(1.0, 5.0, 4.0, 5.0)
    assert contact_quantity_errors(ref, fc) == pytest.approx({
        "err_contact_start": 1.25, "err_contact_end": 0.05, "err_contact_duration": 0.375,
        "err_peak_force": 0.25, "err_contact_impulse": 0.2})
    assert contact_quantity_errors(ref, None) == {"err_peak_force": 1.0}
    assert contact_quantity_errors(None, fc) == {}


@pytest.mark.parametrize("name, T, nx, dt", [("clamped_bar", 3.0, 40, 0.01),
                                             ("dropped_bar", 2.5, 50, 0.004)])
def test_columns_converge_with_nx_and_dt(name, T, nx, dt):
    """The redistributed scheme's first-contact times and impulse converge as nx doubles
    twice and dt halves twice (the peak force carries the discrete stress' overshoot at the
    fronts: present, bounded, not converging on these piecewise-constant stresses)."""
    coarse = run_one(name, "redistributed", nx=nx, dt=dt, T=T).row
    fine = run_one(name, "redistributed", nx=4 * nx, dt=dt / 4, T=T).row
    for col in CONTACT_COLUMNS:
        assert coarse[col] is not None and np.isfinite(coarse[col]), col
    for col in (*CONTACT_COLUMNS[:3], "err_contact_impulse"):
        if col == "err_contact_start" and name == "dropped_bar":  # the rigid free fall:
            assert coarse[col] < 1e-9 and fine[col] < 1e-9  # its crossing, to round-off
            continue
        assert fine[col] < 0.6 * coarse[col] and coarse[col] < 0.06, col
    assert 0.0 < fine["err_peak_force"] < 1.0


def test_embedded_bar_inherits_and_other_scenes_lack():
    """embedded_bar: the 1D scene's reference, its kernel's per-step statistics give the
    1D run's sampled values, at any stride (the 1D samples blur with it). No columns
    where the reference gives no first contact: grazing (no contact force),
    heterogeneous_bar (numerical), and no end or duration before the reference's
    contact ends."""
    one = run_one("clamped_bar", "redistributed", nx=20, dt=0.02, T=3.0).row
    emb = run_one("embedded_bar", "redistributed", nx=20, dt=0.02, T=3.0).row
    for col in CONTACT_COLUMNS:
        assert emb[col] == pytest.approx(one[col], rel=1e-9, abs=1e-12), col
    strided = run_one("embedded_bar", "redistributed", nx=20, dt=0.02, T=3.0, stride=7).row
    for col in CONTACT_COLUMNS:  # per-step statistics: the stride changes nothing
        assert strided[col] == pytest.approx(emb[col], rel=1e-12, abs=1e-15), col
    sampled = run_one("clamped_bar", "redistributed", nx=20, dt=0.02, T=3.0, stride=7).row
    assert sampled["err_contact_start"] != pytest.approx(one["err_contact_start"])
    short = run_one("clamped_bar", "redistributed", nx=20, dt=0.02, T=1.5).row
    assert short["err_contact_start"] is not None and short["err_contact_end"] is None
    assert short["err_contact_duration"] is None
    for name, T in (("grazing", 1.5), ("heterogeneous_bar", 0.5)):
        row = run_one(name, "redistributed", nx=20, dt=0.02, T=T).row
        assert not set(CONTACT_COLUMNS) & set(row), name  # not declared: no column
