"""Declared plugin parameters and the `name[key=value,...]` spec syntax.

A spec names a plugin and some of its parameters: ``redistributed[variant=getfem,beta=0.25]``.
A value may be a list, ``penalty[gamma_p=[1,10,100]]``; `expand_spec` turns such a spec
into one spec per combination (benchopt style).
"""

from __future__ import annotations

import itertools
import math
import sys
from dataclasses import dataclass
from typing import Any

from contact_bench.core.errors import BenchError, shown, shown_repr, unknown


@dataclass(frozen=True)
class Param:
    """One parameter: its default, type, allowed values or range, and a short doc.

    `sweep`: the values the published study runs the scheme at (its stability part, each
    value as a variant of the scheme; the quick study takes the first and the last), or
    None when the study keeps the default only. `quick`: the quick study's value.
    """

    default: Any
    doc: str = ""
    choices: tuple[Any, ...] | None = None
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    #: older spellings of choices that still parse: (old, canonical) pairs
    aliases: tuple[tuple[Any, Any], ...] = ()
    sweep: tuple[Any, ...] | None = None
    #: the value the quick study (a smoke test on tiny grids) runs the scheme at when its
    #: spec does not fix it, e.g. a looser tolerance; None: the default
    quick: Any = None

    @property
    def kind(self) -> type:
        return type(self.default)

    def allowed(self) -> str:
        if self.choices is not None:
            return "one of " + ", ".join(str(c) for c in self.choices)
        if self.kind is str:
            return "a string"
        lo = "-inf" if self.low is None else f"{self.low:g}"
        hi = "inf" if self.high is None else f"{self.high:g}"
        left = "(" if self.low_open or self.low is None else "["
        right = ")" if self.high_open or self.high is None else "]"
        return f"{self.kind.__name__} in {left}{lo}, {hi}{right}"

    def convert(self, owner: str, name: str, raw: Any) -> Any:
        """Parse and check a value; raise a one-line BenchError naming it.

        Floats keep every digit (`format_value` writes them back exactly); -0.0 is 0.0.
        """
        where = f"{shown(owner)}[{shown(name)}={shown(raw)}]"
        try:
            if self.kind is bool:
                if isinstance(raw, str):
                    if raw.lower() not in {"true", "false", "1", "0"}:
                        raise ValueError
                    value: Any = raw.lower() in {"true", "1"}
                else:
                    value = bool(raw)
            elif self.kind is int:
                value = _to_int(raw)
            elif self.kind is float:
                if isinstance(raw, bool):
                    raise ValueError
                value = float(raw) + 0.0  # -0.0 -> 0.0: one value, one spec
            else:
                value = str(raw)
        except (TypeError, ValueError, OverflowError):
            raise BenchError(f"{where}: not a valid {self.kind.__name__}; "
                             f"allowed: {self.allowed()}") from None
        if self.choices is not None:
            value = dict(self.aliases).get(value, value)
            if value not in self.choices:
                raise BenchError(f"{where}: not allowed; allowed: {self.allowed()}")
            return value
        if isinstance(value, float) and not math.isfinite(value):
            raise BenchError(f"{where}: must be finite; allowed: {self.allowed()}")
        if isinstance(value, float) and value != 0.0 and abs(value) < sys.float_info.min:
            raise BenchError(f"{where}: subnormal (0 < |value| < {sys.float_info.min:.3g}), "
                             f"too small to compute with; allowed: {self.allowed()}")
        if self.low is not None and (value < self.low or (self.low_open and value == self.low)):
            raise BenchError(f"{where}: out of range; allowed: {self.allowed()}")
        if self.high is not None and (value > self.high or (self.high_open and value == self.high)):
            raise BenchError(f"{where}: out of range; allowed: {self.allowed()}")
        return value


def _to_int(raw: Any) -> int:
    """An integer from int, integral float or text ('3', '3.0', '1e3'); else ValueError."""
    if isinstance(raw, bool):
        raise ValueError
    if isinstance(raw, int):
        return raw
    if isinstance(raw, str):
        try:
            return int(raw.strip())
        except ValueError:
            raw = float(raw)
    value = float(raw)
    if not value.is_integer():  # also inf and nan
        raise ValueError
    return int(value)


def format_value(value: Any) -> str:
    """A parameter value as spec text that parses back to the same value: a float as the
    shorter of `:g` and repr that round-trips (0.25, 1e+08, 1.0000001, 1e-320); never
    rounded. The rest as str."""
    if isinstance(value, float):
        value += 0.0  # -0.0 -> 0.0
        short = f"{value:g}"
        exact = repr(value)
        return short if float(short) == value and len(short) <= len(exact) else exact
    return str(value)


def _split_top(text: str, spec: str) -> list[str]:
    """Split on commas that are not inside brackets; an empty item is a BenchError."""
    parts, depth, cur = [], 0, []
    for ch in text:
        if ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        if ch == "," and depth == 0:
            parts.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    parts.append("".join(cur))
    items = [p.strip() for p in parts]
    if any(not p for p in items) and text.strip():
        raise BenchError(f"empty item in {shown(spec)!r}: remove the extra comma")
    return [p for p in items if p]


def parse_spec(spec: str) -> tuple[str, dict[str, str | list[str]]]:
    """``'name[a=1,b=[2,3]]'`` -> ``('name', {'a': '1', 'b': ['2', '3']})`` (values unchecked)."""
    spec = spec.strip()
    if not spec:
        raise BenchError("empty spec: expected name or name[key=value,...]")
    if "[" not in spec:
        return spec, {}
    if not spec.endswith("]") or spec.count("[") != spec.count("]"):
        raise BenchError(f"malformed spec {shown_repr(spec)}: expected name[key=value,...]")
    name, inner = spec[: spec.index("[")].strip(), spec[spec.index("[") + 1 : -1]
    params: dict[str, str | list[str]] = {}
    for item in _split_top(inner, spec):
        if "=" not in item:
            raise BenchError(f"malformed parameter {shown_repr(item)} in {shown_repr(spec)}: "
                             "expected key=value")
        key, value = (s.strip() for s in item.split("=", 1))
        if key in params:
            raise BenchError(f"parameter {shown_repr(key)} given twice in {shown_repr(spec)}")
        if value.startswith("[") and value.endswith("]"):
            params[key] = _split_top(value[1:-1], spec)
            if not params[key]:
                raise BenchError(f"{shown(name)}[{shown(key)}=[]]: an empty list of values")
        else:
            params[key] = value
    return name, params


def expand_spec(spec: str) -> list[str]:
    """One spec per combination of the list-valued parameters, in the given order."""
    name, params = parse_spec(spec)
    if not params:
        return [name]
    keys = list(params)
    grids = [v if isinstance(v, list) else [v] for v in params.values()]
    return [
        f"{name}[{','.join(f'{k}={v}' for k, v in zip(keys, combo, strict=True))}]"
        for combo in itertools.product(*grids)
    ]


def check_params(owner: str, declared: dict[str, Param], given: dict[str, Any]) -> dict[str, Any]:
    """Defaults overlaid with the given values, each converted and checked."""
    values = {k: p.default for k, p in declared.items()}
    for key, raw in given.items():
        if key not in declared:
            if not declared:
                raise BenchError(f"{owner} takes no parameters; got {shown_repr(key)}")
            raise unknown(f"parameter of {owner}", key, declared)
        if isinstance(raw, list):
            raise BenchError(f"{owner}[{shown(key)}=[...]]: a list of values is only allowed "
                             "in a sweep")
        values[key] = declared[key].convert(owner, key, raw)
    return values


def format_spec(name: str, declared: dict[str, Param], values: dict[str, Any]) -> str:
    """Canonical spec: the name and the non-default parameters in declaration order."""
    changed = [f"{k}={format_value(values[k])}" for k, p in declared.items()
               if values[k] != p.default]
    return f"{name}[{','.join(changed)}]" if changed else name
