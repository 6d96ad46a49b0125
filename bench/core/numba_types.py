"""Which typed structure a numba type is: the one test behind the compiled functions that
dispatch on a structure's type (numba `overload`), such as no time load
(`contact_bench.kernels.time_load.NoLoad`), no curved obstacle
(`contact_bench.kernels.contact.Flat`) or a sphere (`contact_bench.core.obstacle.Sphere`):
a structure that says what it is by its type needs no flag beside it."""

from __future__ import annotations

from typing import Any

from numba import types


def is_tuple_type(ty: Any, cls: type) -> bool:
    """Whether `ty`, a numba type, is the type of the NamedTuple class `cls`'s instances."""
    return isinstance(ty, types.BaseNamedTuple) and ty.instance_class is cls
