"""User-facing errors: one line that names the bad value and what is allowed."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class BenchError(ValueError):
    """A bad input. The CLI prints its message on one line and exits with code 2."""


def unknown(kind: str, name: str, allowed: Iterable[str]) -> BenchError:
    """Error for an unknown name, suggesting the closest allowed one."""
    allowed = sorted(allowed)
    close = difflib.get_close_matches(name, allowed, n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return BenchError(f"unknown {kind} {name!r}{hint}; allowed: {', '.join(allowed)}")
