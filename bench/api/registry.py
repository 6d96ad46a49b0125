"""Plugin discovery: every public module of a package that defines plugin classes.

Adding a scheme or a case is adding one file to `schemes/` or `cases/`. A module that
fails to import does not crash the suite: it is recorded in `broken` and shown by
`contact-bench list`.
"""

from __future__ import annotations

import importlib
import pkgutil
from functools import cache
from types import ModuleType

from contact_bench.api.params import parse_spec
from contact_bench.api.plugin import Case, Plugin, Scheme
from contact_bench.core.errors import BenchError, unknown


class Registry:
    def __init__(self, package: str, base: type[Plugin]) -> None:
        self.package = package
        self.kind = package.rsplit(".", 1)[-1]
        self.base = base
        self.plugins: dict[str, type[Plugin]] = {}
        self.broken: dict[str, str] = {}
        pkg: ModuleType = importlib.import_module(package)
        for info in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda m: m.name):
            if info.name.startswith("_"):
                continue
            try:
                module = importlib.import_module(f"{package}.{info.name}")
            except Exception as exc:  # noqa: BLE001 - a broken plugin becomes a placeholder
                self.broken[info.name] = f"{type(exc).__name__}: {exc}"
                continue
            for obj in vars(module).values():
                if (isinstance(obj, type) and issubclass(obj, base) and obj.name
                        and obj.__module__ == module.__name__):
                    if obj.name in self.plugins:
                        raise RuntimeError(f"two {self.kind} plugins are named {obj.name!r}")
                    self.plugins[obj.name] = obj

    def names(self) -> list[str]:
        return list(self.plugins)

    def get(self, name: str) -> type[Plugin]:
        if name not in self.plugins:
            if name in self.broken:
                raise BenchError(
                    f"{self.kind} plugin {name!r} failed to import: {self.broken[name]}")
            raise unknown(self.kind[:-1], name, self.plugins)
        return self.plugins[name]

    def make(self, spec: str) -> Plugin:
        """Instantiate from a spec string such as ``redistributed[variant=getfem]``."""
        name, params = parse_spec(spec)
        return self.get(name)(**params)


@cache
def schemes() -> Registry:
    return Registry("contact_bench.schemes", Scheme)


@cache
def cases() -> Registry:
    return Registry("contact_bench.cases", Case)


def make_scheme(spec: str) -> Scheme:
    return schemes().make(spec)  # type: ignore[return-value]


def make_case(spec: str) -> Case:
    return cases().make(spec)  # type: ignore[return-value]
