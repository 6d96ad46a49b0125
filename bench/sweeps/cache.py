"""The run cache: identical runs (same inputs, same code) are not recomputed.

A key is the SHA-256 of the run's canonical inputs and of a *code hash*: the source of
the scheme's and the case's modules, of every project module they reach through their
globals (e.g. `contact_bench.kernels.newmark`, `contact_bench.exact.characteristics`), of
every module of the compiled layers (`contact_bench.core`, `contact_bench.kernels`) and of
the harness modules a run goes through (`SHARED_MODULES` and what they reach). Plugin
files of a plugin folder are loaded as `contact_bench.plugins.<stem>` and count like the
built-ins; an entry-point plugin's module counts with the modules of its own top-level
package that it reaches. A scene's stored converged reference, read at run time
(results/references/<name>.json, `contact_bench.exact.converged`), counts too.
Editing any of them gives new keys, so stale rows are never served.

Each entry is one small JSON file (its key, a digest and the row; verified when read,
see `Cache`), written atomically (`contact_bench.harness.io`) by the
process that collects the results as each run finishes: a sweep killed half-way keeps every run
finished so far, and the next identical sweep starts from there.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import math
import os
import pkgutil
import sys
import tempfile
from collections.abc import Callable
from functools import cache
from pathlib import Path
from types import ModuleType
from typing import Any

from contact_bench.core.errors import BenchError, shown
from contact_bench.harness.io import write_text

PROJECT_PACKAGES = ("contact_bench",)
#: the harness modules every run goes through; what they import is reached from them
SHARED_MODULES = ("contact_bench.harness.runner", "contact_bench.sweeps.sweep")
#: layers whose every module counts (kernels reached only through compiled dispatchers)
COMPILED_LAYERS = ("contact_bench.core", "contact_bench.kernels")


def default_cache_dir() -> Path:
    """$CONTACT_BENCH_CACHE, else $XDG_CACHE_HOME/contact-bench, else ~/.cache/contact-bench."""
    if os.environ.get("CONTACT_BENCH_CACHE"):
        return Path(os.environ["CONTACT_BENCH_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "contact-bench"


def _project_module(name: str | None, roots: tuple[str, ...] = PROJECT_PACKAGES) -> bool:
    return bool(name) and name.split(".")[0] in roots  # type: ignore[union-attr]


def _reached(module: ModuleType, seen: set[str],
             roots: tuple[str, ...] = PROJECT_PACKAGES) -> None:
    """Add module and the modules of the packages `roots` reachable through its globals
    to seen."""
    if module.__name__ in seen:
        return
    seen.add(module.__name__)
    for obj in vars(module).values():
        name = obj.__name__ if isinstance(obj, ModuleType) else getattr(obj, "__module__", None)
        if isinstance(name, str) and _project_module(name, roots) and name in sys.modules:
            _reached(sys.modules[name], seen, roots)


def _shared() -> list[str]:
    names = list(SHARED_MODULES)
    for layer in COMPILED_LAYERS:
        pkg = importlib.import_module(layer)
        names += [f"{layer}.{info.name}" for info in pkgutil.iter_modules(pkg.__path__)]
    return names


@cache
def module_hash(*module_names: str) -> str:
    """SHA-256 over the sources of these modules and every project module they reach."""
    seen: set[str] = set()
    # an entry-point plugin's own package counts too (e.g. mypkg.helpers of mypkg.scheme)
    roots = tuple(dict.fromkeys((*PROJECT_PACKAGES, *(n.split(".")[0] for n in module_names))))
    for name in (*module_names, *_shared()):
        _reached(importlib.import_module(name), seen, roots)
    digest = hashlib.sha256()
    for name in sorted(seen):
        file = getattr(sys.modules[name], "__file__", None)
        digest.update(name.encode())
        if file and os.path.exists(file):
            digest.update(Path(file).read_bytes())
    return digest.hexdigest()[:16]


def reference_hash(case_name: str) -> str:
    """SHA-256 of the converged reference a scene reads at run time
    (results/references/<name>.json, `contact_bench.exact.converged.load`); "" without one."""
    from contact_bench.exact.converged import REFERENCES
    path = REFERENCES / f"{case_name}.json"
    return hashlib.sha256(path.read_bytes()).hexdigest()[:16] if path.is_file() else ""


def code_hash(case_cls: type, scheme_cls: type) -> str:
    """The code hash of a (case, scheme) pair (see the module docstring): its modules' and
    the scene's stored converged reference's."""
    code = module_hash(*sorted({case_cls.__module__, scheme_cls.__module__}))
    ref = reference_hash(getattr(case_cls, "name", ""))
    return code if not ref else hashlib.sha256(f"{code}{ref}".encode()).hexdigest()[:16]


def run_key(inputs: dict[str, Any], code: str, kind: str = "run") -> str:
    """Key of one run: its canonical inputs, the code hash and what is stored (run/timing)."""
    blob = json.dumps({"inputs": inputs, "code": code, "kind": kind}, sort_keys=True,
                      default=str)
    return hashlib.sha256(blob.encode()).hexdigest()


def _plain(value: Any) -> Any:
    """JSON-able Python scalars (numpy scalars -> Python, NaN kept)."""
    if hasattr(value, "item") and not isinstance(value, str | bytes):
        try:
            return value.item()
        except (ValueError, TypeError):
            return str(value)
    return value


#: what `Cache.get` verifies returns None (valid) or why the entry is refused
Check = Callable[[dict[str, Any]], "str | None"]


def digest(row: dict[str, Any]) -> str:
    """SHA-256 of a stored row's canonical JSON (what `Cache.put` writes)."""
    text = json.dumps(row, sort_keys=True, allow_nan=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


class Cache:
    """One JSON file per key under `root/ab/abcdef....json`; `None` root: no caching.

    An entry is ``{"key", "digest", "row"}``: its own key, the SHA-256 of its row, the
    row. `get` serves an entry only when it is a JSON object of that form, its key is
    the one asked for (not another run's entry copied in), its digest matches (no hand
    edit) and the caller's `check` of the row's columns and types passes. Anything
    else is a miss: the run is recomputed and the entry rewritten; the first refused
    entry is said once on stderr (`refused` counts them).
    """

    def __init__(self, root: str | Path | None) -> None:
        self.root = None if root is None else Path(root)
        self.refused = 0

    def _path(self, key: str) -> Path:
        assert self.root is not None
        return self.root / key[:2] / f"{key}.json"

    def check_writable(self) -> None:
        """Raise a one-line BenchError unless entries can be written under the root
        (called before any run, so a bad cache folder fails before the work)."""
        if self.root is None:
            return
        root = self.root
        try:
            root.mkdir(parents=True, exist_ok=True)
            fd, probe = tempfile.mkstemp(prefix=".probe.", dir=root)
            os.close(fd)
            os.unlink(probe)
        except OSError as exc:
            why = exc.strerror or type(exc).__name__
            raise BenchError(f"cache folder {shown(str(root))} is not a writable folder "
                             f"({why}); give another --cache or CONTACT_BENCH_CACHE, "
                             "or --no-cache") from None

    def get(self, key: str, check: Check | None = None) -> dict[str, Any] | None:
        """The verified row stored under key, else None (see the class docstring)."""
        if self.root is None:
            return None
        path = self._path(key)
        try:
            with open(path, encoding="utf-8") as fh:
                entry = json.load(fh)
        except FileNotFoundError:
            return None
        except (OSError, ValueError, RecursionError):  # unreadable or cut short
            return self._refuse(path, "not readable JSON")
        reason = _verify(entry, key)
        if reason is None and check is not None:
            reason = check(entry["row"])
        if reason is not None:
            return self._refuse(path, reason)
        return dict(entry["row"])

    def _refuse(self, path: Path, reason: str) -> None:
        self.refused += 1
        if self.refused == 1:
            print(f"contact-bench: note: cache entry {path} refused ({shown(reason)}); its run "
                  "is recomputed (any further damaged entries silently)", file=sys.stderr)
        return None

    def put(self, key: str, row: dict[str, Any]) -> None:
        if self.root is None:
            return
        plain = {k: _plain(v) for k, v in row.items()}
        plain = {k: (None if isinstance(v, float) and math.isnan(v) else v)
                 for k, v in plain.items()}
        plain = json.loads(json.dumps(plain, allow_nan=True, default=str))  # as read back
        entry = {"key": key, "digest": digest(plain), "row": plain}
        write_text(self._path(key), json.dumps(entry, allow_nan=True))

    def __len__(self) -> int:
        if self.root is None or not self.root.exists():
            return 0
        return sum(1 for p in self.root.glob("*/*.json") if not p.name.startswith("."))


def _verify(entry: Any, key: str) -> str | None:
    """Why an entry read under key is not a valid one (None: valid envelope)."""
    if not isinstance(entry, dict) or set(entry) != {"key", "digest", "row"}:
        return "not a cache entry"
    if entry["key"] != key:
        return "stored under another key"
    if not isinstance(entry["row"], dict):
        return "its row is not an object"
    if entry["digest"] != digest(entry["row"]):
        return "its content does not match its digest"
    return None
