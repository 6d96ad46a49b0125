"""One typed, bounded cache for what a process builds once and hands on.

A run and a sweep task build a scene's mesh and its problem once; the harness hands the
problem on to the checks, the run and the timing, and what a later step of the same
process asks again (a sweep's timing pass, a scene's own methods reading its mesh) is
served from a `Kept`: an LRU map of at most `max_items` entries and at most `max_bytes`
bytes (the values' `nbytes_of`), which a test empties with `clear()` (`clear_all()`:
every `Kept` of the process).

`case_key` names a scene by what its data depend on (class, spec, attributes, data
files), so that two objects of the same scene share entries and a changed one does not;
`built_once` keeps a scene method's result (its mesh, its assembled body) by that key.
"""

from __future__ import annotations

import functools
import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any, Generic, TypeVar

import numpy as np

V = TypeVar("V")


def nbytes_of(value: Any) -> int:
    """The memory a kept value holds, roughly: its `nbytes` when it tells one, else the
    numpy arrays and scipy sparse matrices among its attributes (one level down)."""
    size = getattr(value, "nbytes", None)
    if isinstance(size, int | float):
        return int(size)
    total = 0
    for item in (vars(value).values() if hasattr(value, "__dict__") else ()):
        if hasattr(item, "indptr"):  # a scipy sparse matrix
            total += int(item.data.nbytes + item.indices.nbytes + item.indptr.nbytes)
        elif isinstance(item, np.ndarray):
            total += int(item.nbytes)
    return total


class Kept(Generic[V]):
    """An LRU cache by key: at most `max_items` entries, and at most `max_bytes` bytes
    (None: no byte bound); a value larger than `max_bytes` is not kept, unless
    `keep_last`: then the most recent value is kept whatever its size. `size`: a
    value's bytes (default `nbytes_of`). Thread-safe.
    `builds` counts the values `get_or_build` built (not served)."""

    _all: list[Kept[Any]] = []

    def __init__(self, name: str, max_items: int, max_bytes: int | None = None,
                 keep_last: bool = False, size: Callable[[Any], int] = nbytes_of) -> None:
        self.name, self.max_items, self.max_bytes = name, int(max_items), max_bytes
        self.keep_last, self.size = keep_last, size
        self._entries: OrderedDict[Hashable, tuple[V, int]] = OrderedDict()
        self._lock = threading.Lock()
        self.builds = 0
        Kept._all.append(self)

    def __len__(self) -> int:
        return len(self._entries)

    def __contains__(self, key: Hashable) -> bool:
        return key in self._entries

    def get(self, key: Hashable, default: Any = None) -> V | Any:
        """The value kept under key (now the most recent), or default."""
        with self._lock:
            if key not in self._entries:
                return default
            self._entries.move_to_end(key)
            return self._entries[key][0]

    def put(self, key: Hashable, value: V) -> V:
        """Keep value under key (the most recent), dropping the oldest beyond the
        bounds; returns value."""
        size = self.size(value) if self.max_bytes is not None else 0
        with self._lock:
            self._entries.pop(key, None)
            fits = self.max_bytes is None or size <= self.max_bytes
            if self.max_items < 1 or not (fits or self.keep_last):
                return value
            self._entries[key] = (value, size)
            while len(self._entries) > 1 and (  # the oldest go; the newest stays
                    len(self._entries) > self.max_items
                    or (self.max_bytes is not None
                        and sum(s for _, s in self._entries.values()) > self.max_bytes)):
                self._entries.popitem(last=False)
        return value

    def get_or_build(self, key: Hashable, build: Callable[[], V]) -> V:
        """The value kept under key, or `build()` kept and returned (an exception from
        build keeps nothing)."""
        missing = object()
        value = self.get(key, missing)
        if value is not missing:
            return value
        self.builds += 1
        return self.put(key, build())

    def clear(self) -> None:
        """Forget every entry."""
        with self._lock:
            self._entries.clear()

    @classmethod
    def clear_all(cls) -> None:
        """Forget every entry of every `Kept` of the process (tests)."""
        for kept in cls._all:
            kept.clear()


def case_key(case: Any) -> tuple:
    """What a scene's data depend on: its class, spec, attributes (`vars`) and data
    files (`data_hash`); equal for two objects of the same scene."""
    return (type(case), case.spec, repr(sorted(vars(case).items())), case.data_hash())


#: scene methods' results kept by `built_once` (meshes, assembled bodies)
BUILT: Kept[Any] = Kept("built", max_items=8, max_bytes=256 * 2**20)


def built_once(method: Callable[..., V]) -> Callable[..., V]:
    """A scene method (e.g. `mesh(nx)`, `body(nx)`) whose result is kept in `BUILT` by
    the scene (`case_key`) and the arguments: the run's checks, its problem, its error
    columns and its fields then read one mesh. The result is shared: never changed."""

    @functools.wraps(method)
    def kept(self: Any, *args: Any) -> V:
        key = (method.__qualname__, case_key(self), args)
        return BUILT.get_or_build(key, lambda: method(self, *args))

    return kept


__all__ = ["BUILT", "Kept", "built_once", "case_key", "nbytes_of"]
