"""Every registered scheme's declared time order (`Traits.order`) against a measured one.

diffrax's `test_ode_order` pattern: the schemes come from the registry, so a new scheme
file is covered with no test code. Each scheme runs at its defaults and at the
one-parameter variants of `scheme_variants` (every other choice, the closed ends of a
numeric range: where a declared order may change, e.g. gamma = 1). `measure_time_order`
(contact_bench.sweeps.time_order, docs/order.md) fits the order in dt on a smooth motion
without contact, against the same scheme at a much finer dt. Then:

- a declared order p: the measured order is within `TOLERANCE` of p;
- declared None: the scheme claims no order in dt; when its output does not change with
  dt at all (every error at the round-off floor: dt only picks the sample times) that
  is the right declaration, otherwise the test is skipped with the measured order in
  the reason;
- a scheme whose output does not depend on dt must not declare an order.
"""

from __future__ import annotations

import importlib.util
import math
from dataclasses import replace
from pathlib import Path

import pandas as pd
import pytest

from contact_bench.api.plugin import Scheme
from contact_bench.api.registry import schemes
from contact_bench.sweeps.analysis import with_time_orders
from contact_bench.sweeps.time_order import (
    AMPLITUDE,
    FLOOR,
    TOLERANCE,
    SmoothStretch,
    measure_time_order,
    scheme_variants,
    time_order_table,
)

VARIANTS = scheme_variants()


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


def _declaring(scheme: Scheme, order: int | None) -> Scheme:
    """The same scheme, declaring another order."""
    cls = type(scheme)
    traits = scheme.traits()
    fake = type(f"Declares{order}", (cls,), {"traits": lambda self: replace(traits, order=order)})
    return fake(**scheme.values)


def test_a_wrong_declaration_is_caught() -> None:
    second = next(s for s in VARIANTS if s.traits().order == 2)
    assert measure_time_order(_declaring(second, 2)).verdict == "agrees"
    assert measure_time_order(_declaring(second, 1)).verdict == "differs"
    assert measure_time_order(_declaring(second, 3)).verdict == "differs"
    samplers = [s for s in VARIANTS if s.traits().order is None]
    free = next((s for s in samplers if measure_time_order(s).dt_free), None)
    if free is not None:  # a scheme whose dt only samples may not declare an order
        assert measure_time_order(_declaring(free, 8)).verdict == "differs"


def test_time_order_table_sits_next_to_the_convergence_orders() -> None:
    specs = [s.spec for s in VARIANTS if s.traits().order is not None][:1]
    table = time_order_table([*specs, "ode_adaptive", "no_such_scheme"])
    verdicts = dict(zip(table["scheme"], table["verdict"], strict=True))
    assert verdicts == {specs[0]: "agrees", "ode_adaptive": "dt only samples",
                        "no_such_scheme": "run failed"}
    assert "no_such_scheme" in table.set_index("scheme").loc["no_such_scheme", "notes"]
    conv = pd.DataFrame({"scheme": [specs[0], "other"], "order": [0.5, 0.7],
                         "declared order": [2, None], "error": ["e", "e"]})
    both = with_time_orders(conv, table)
    assert list(both.columns) == ["scheme", "order", "declared order", "smooth order", "error"]
    measured = float(table.set_index("scheme").loc[specs[0], "measured order"])
    assert both["smooth order"].iloc[0] == measured and math.isnan(both["smooth order"].iloc[1])
    assert with_time_orders(conv, None) is conv


def test_order_start_script_shows_the_massless_start_up(capsys) -> None:
    """benchmarks/order_start.py (quoted in docs/order.md) runs and prints one row per
    variant with a massless contact node; with u0(0) on the node's equilibrium every
    declared order is measured again."""
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "order_start.py"
    spec = importlib.util.spec_from_file_location("_bench_order_start", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.main()
    lines = capsys.readouterr().out.strip().splitlines()[2:]
    massless = [s for s in VARIANTS if s.traits().massless_contact_node]
    assert [line.split(" | ")[0].lstrip("| ") for line in lines] == [s.spec for s in massless]
    for line in lines:
        declared, moved = line.split(" | ")[1], line.split(" | ")[-1].rstrip(" |")
        if declared != "None":
            assert abs(float(moved) - float(declared)) <= TOLERANCE, line
