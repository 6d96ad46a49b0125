"""Every registered scheme's declared time order (`Traits.order`) against a measured one.

diffrax's `test_ode_order` pattern: the schemes come from the registry, so a new scheme
file is covered with no test code. Each scheme runs at its defaults and, one parameter at
a time, at every other choice of a choice parameter and at the closed finite ends of a
numeric range (where a declared order may change, e.g. gamma = 1); a value the scheme
refuses is left out. `measure_time_order` (contact_bench.sweeps.time_order) fits the
order in dt on a smooth motion without contact, against the same scheme at a much finer
dt. Then:

- a declared order p: the measured order is within `TOLERANCE` of p;
- declared None: the scheme claims no order in dt; when its output does not change with
  dt at all (every error at the round-off floor: dt only picks the sample times) that
  is the right declaration, otherwise the test is skipped with the measured order in
  the reason;
- a scheme whose output does not depend on dt must not declare an order.
"""

from __future__ import annotations

import math

import pytest

from contact_bench.api.plugin import Scheme
from contact_bench.api.registry import schemes
from contact_bench.core.errors import BenchError
from contact_bench.sweeps.time_order import (
    AMPLITUDE,
    FLOOR,
    TOLERANCE,
    SmoothStretch,
    measure_time_order,
)


def _variants() -> list[Scheme]:
    out: dict[str, Scheme] = {}
    for _, cls in sorted(schemes().plugins.items()):
        tries: list[dict] = [{}]
        for key, p in cls.params.items():
            if p.choices is not None:
                tries += [{key: v} for v in p.choices if v != p.default]
            elif p.kind is float:
                ends = [(p.low, p.low_open), (p.high, p.high_open)]
                tries += [{key: v} for v, is_open in ends
                          if v is not None and not is_open and v != p.default]
        for given in tries:
            try:
                scheme = cls(**given)
            except BenchError:  # a combination the scheme refuses
                continue
            out.setdefault(scheme.spec, scheme)
    return list(out.values())


VARIANTS = _variants()


@pytest.mark.parametrize("scheme", VARIANTS, ids=[s.spec for s in VARIANTS])
def test_declared_time_order_is_measured(scheme: Scheme) -> None:
    reason = scheme.cannot_run(SmoothStretch())
    if reason:
        pytest.skip(f"{scheme.spec} cannot run the smooth stretch: {reason}")
    result = measure_time_order(scheme)
    where = f"{scheme.spec}: {result.describe()}"
    assert result.problem is None, f"{where}; {result.problem}"
    # the stretch is smooth for this scheme: its contact node never came near the obstacle
    assert result.min_contact_u > 0.5 * AMPLITUDE, (where, result.min_contact_u)
    if result.dt_free:
        assert result.declared is None, (
            f"{where}: the output does not depend on dt (every error <= {FLOOR:g}), so there "
            f"is no order in dt to declare")
        return
    if result.declared is None:
        pytest.skip(f"{scheme.spec} declares no time order; measured {result.order:.2f} "
                    f"on the smooth stretch")
    assert result.points >= 3, f"{where}: too few points above the round-off floor"
    assert math.isfinite(result.order) and abs(result.order - result.declared) <= TOLERANCE, where
    assert result.verdict == "agrees", where


def test_every_scheme_is_measured() -> None:
    reg = schemes()
    assert not reg.broken, reg.broken
    assert {s.name for s in VARIANTS} == set(reg.plugins)
