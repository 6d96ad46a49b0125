"""Where set-up time goes: named phases, timed where they happen, read by the harness.

A function marked `@phase("factor")` (a factorisation) or `@phase("contact")` (the contact
operators) adds its wall time to that phase's total while a `recording()` is open, and
costs one global read otherwise. Times are exclusive: a phase inside another (a factor
made while the contact operators are built) counts for the inner one only, so the totals
add up to at most the recorded span. The harness opens a recording around a scheme's
preparation and splits `setup_s` with it (`contact_bench.harness.runner`).
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

#: the open recording: phase -> seconds, and the stack of children's time per open phase
_totals: dict[str, float] | None = None
_children: list[float] = []


@contextmanager
def recording() -> Iterator[dict[str, float]]:
    """Collect the phases' exclusive times in the dict it yields (nested recordings:
    the inner one collects, the outer one gets nothing of that span's phases)."""
    global _totals, _children
    outer, outer_children = _totals, _children
    _totals, _children = {}, []
    try:
        yield _totals
    finally:
        _totals, _children = outer, outer_children


def phase(name: str) -> Callable[[F], F]:
    """Decorator: the function's wall time, less that of the phases it calls, goes to
    `name` in the open recording."""

    def wrap(func: F) -> F:
        @functools.wraps(func)
        def timed(*args: Any, **kwargs: Any) -> Any:
            totals = _totals
            if totals is None:
                return func(*args, **kwargs)
            _children.append(0.0)
            start = time.perf_counter()
            try:
                return func(*args, **kwargs)
            finally:
                elapsed = time.perf_counter() - start
                inner = _children.pop()
                totals[name] = totals.get(name, 0.0) + elapsed - inner
                if _children:
                    _children[-1] += elapsed

        return timed  # type: ignore[return-value]

    return wrap
