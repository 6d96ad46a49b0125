"""User-facing errors: one line that names the bad value and what is allowed."""

from __future__ import annotations

import difflib
from collections.abc import Iterable

#: longest user text echoed whole in a message; longer text is cut in the middle
SHOWN_CHARS = 80


def _cut(text: str, limit: int) -> tuple[str, str]:
    keep = max(8, limit // 2 - 10)
    return text[:keep], text[-keep:]


def shown(value: object, limit: int = SHOWN_CHARS) -> str:
    """`str(value)` for a message: cut in the middle, with its length, when too long."""
    text = value if isinstance(value, str) else str(value)
    if len(text) <= limit:
        return text
    head, tail = _cut(text, limit)
    return f"{head}...{tail} ({len(text)} characters)"


def shown_repr(value: object, limit: int = SHOWN_CHARS) -> str:
    """`repr(value)` for a message, cut like `shown` (the length is the value's)."""
    if not isinstance(value, str) or len(value) <= limit:
        return shown(repr(value), limit)
    head, tail = _cut(value, limit)
    return f"{head + '...' + tail!r} ({len(value)} characters)"


class BenchError(ValueError):
    """A bad input. The CLI prints its message on one line and exits with code 2."""


def unknown(kind: str, name: str, allowed: Iterable[str]) -> BenchError:
    """Error for an unknown name, suggesting the closest allowed one."""
    allowed = sorted(allowed)
    close = difflib.get_close_matches(name, allowed, n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return BenchError(f"unknown {kind} {shown_repr(name)}{hint}; allowed: {', '.join(allowed)}")
