"""Parameters kept to the last digit: parsed, formatted, planned and run as given, never
rounded to the digits a table shows."""

from __future__ import annotations

import math

import pytest

from contact_bench.api.params import Param, expand_spec, format_value, parse_spec
from contact_bench.api.registry import cases, make_case, make_scheme, schemes
from contact_bench.core.errors import BenchError
from contact_bench.sweeps.cache import Cache
from contact_bench.sweeps.sweep import Task, plan, run_sweep


def _values(p: Param) -> list:
    """Allowed values of p, with floats that `:g` would round (many digits, neighbours)."""
    if p.choices is not None:
        return list(p.choices)
    if p.kind is bool:
        return [True, False]
    if p.kind is int:
        return [p.default, p.default + 1, 10**30 + 7]
    if p.kind is not float:
        return [p.default, "x"]
    lo = -1e6 if p.low is None else p.low
    hi = 1e6 if p.high is None else p.high
    out = [p.default]
    for frac in (0.123456789012345, 0.5, 0.999999999):
        out.append(lo + (hi - lo) * frac)
    for edge, toward in ((lo, hi), (hi, lo)):
        out += [edge, math.nextafter(edge, toward), math.nextafter(math.nextafter(edge, toward),
                                                                   toward)]
    out += [math.nextafter(p.default, hi), math.nextafter(p.default, lo)]
    return out


def _plugin_params() -> list[tuple[str, type, str, Param]]:
    return [(kind, cls, key, p) for kind, reg in (("scheme", schemes()), ("case", cases()))
            for cls in reg.plugins.values() for key, p in cls.params.items()]


@pytest.mark.parametrize("kind,cls,key,p", _plugin_params(),
                         ids=[f"{c.name}.{k}" for _, c, k, _p in _plugin_params()])
def test_parse_format_parse_is_the_identity_for_every_parameter(kind, cls, key, p):
    make = make_scheme if kind == "scheme" else make_case
    tried = 0
    for value in _values(p):
        try:
            plugin = make(f"{cls.name}[{key}={format_value(value)}]")
        except BenchError:  # out of range (an open bound) or refused by validate()
            continue
        tried += 1
        assert plugin.values[key] == value and type(plugin.values[key]) is type(value)
        again = make(plugin.spec)  # format -> parse
        assert again.values == plugin.values, (plugin.spec, again.spec)
        assert again.spec == plugin.spec
        if isinstance(value, float):  # every bit, not only ==
            assert math.copysign(1, again.values[key]) == math.copysign(1, value) or value == 0
            assert again.values[key].hex() == (value + 0.0).hex()
    assert tried >= 1


def test_specs_keep_every_digit():
    assert make_scheme("penalty[gamma_p=1.0000001]").spec == "penalty[gamma_p=1.0000001]"
    assert make_scheme("nitsche[gamma0=1.0000001]").values["gamma0"] == 1.0000001
    assert make_scheme("restitution[e=0.9999999]").spec == "restitution[e=0.9999999]"
    assert make_case("fast_impact[mach=0.0123456789]").mach == 0.0123456789
    # -0.0 is 0.0 (one value, one spec); huge and infinite integers are a one-line error
    assert make_scheme("restitution[e=-0.0]").spec == "restitution"
    for bad in ("inf", "-inf", "1e999", "9" * 400, "nan"):
        with pytest.raises(BenchError, match="theta="):
            make_scheme(f"nitsche[theta={bad}]")


def test_grids_keep_distinct_values_and_refuse_empty_items():
    specs = expand_spec("penalty[gamma_p=[1.0000001,1.0000002,1.00000049]]")
    assert [make_scheme(s).values["gamma_p"] for s in specs] == [1.0000001, 1.0000002,
                                                                 1.00000049]
    for bad in ("penalty[gamma_p=[1,,2]]", "penalty[gamma_p=[1,2,]]", "penalty[gamma_p=[]]",
                "penalty[gamma_p=1,,beta=0.3]"):
        with pytest.raises(BenchError):
            expand_spec(bad)
    assert parse_spec("penalty[gamma_p=[1, 2]]") == ("penalty", {"gamma_p": ["1", "2"]})


def test_sweep_over_two_values_equal_to_6_digits_gives_two_rows():
    tasks = plan(["clamped_bar"], ["penalty[gamma_p=[1.0000001,1.0000002]]"], [8], T=0.5)
    res = run_sweep(tasks, cache=Cache(None), repeats=0, quiet=True)
    df = res.table
    assert len(df) == 2, df[["scheme", "status"]]
    assert list(df["scheme"]) == ["penalty[gamma_p=1.0000001]", "penalty[gamma_p=1.0000002]"]
    assert list(df["status"]) == ["ok", "ok"], list(df["notes"])
    # each row was run with its own value: rebuild from the row's label
    assert [make_scheme(s).values["gamma_p"] for s in df["scheme"]] == [1.0000001, 1.0000002]


def test_sweep_runs_the_parsed_value_not_a_rounded_one():
    mach = 0.0123456789
    tasks = [Task("fast_impact[mach=0.0123456789]", "standard", nx=8, T=0.05),
             Task("fast_impact[mach=0.0123457]", "standard", nx=8, T=0.05)]
    df = run_sweep(tasks, cache=Cache(None), repeats=0, quiet=True).table
    assert len(df) == 2 and make_case(df["case"][0]).mach == mach
    a, b = df.iloc[0], df.iloc[1]
    assert a["energy_initial"] != b["energy_initial"] or a["energy_final"] != b["energy_final"]
