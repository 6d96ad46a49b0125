"""Plugin discovery: the built-in packages, entry points and plugin folders.

Schemes and cases come from three places, in this order:

1. the built-in packages `contact_bench.schemes` and `contact_bench.cases` (the
   repository's `schemes/` and `cases/` folders), every public module;
2. entry points in the groups `contact_bench.schemes` and `contact_bench.cases` of any
   installed distribution; an entry point names a module (every plugin class defined in
   it counts) or one plugin class;
3. every `*.py` file (not starting with ``_``) of the plugin folders: those named by
   ``--plugins DIR`` on the command line and by the environment variable
   `CONTACT_BENCH_PLUGINS` (folders separated by `os.pathsep`). A file may define schemes,
   cases or both. It is loaded as the module ``contact_bench.plugins.<stem>``, inside the
   project's namespace, so that the run cache's code hash covers it.

A name defined twice is a one-line BenchError naming both files. A module or file that
fails to import does not crash the suite: it is recorded in `broken` and shown by
`contact-bench list`. The registries are cached per set of plugin folders, so changing
`CONTACT_BENCH_PLUGINS` (as ``--plugins`` does, for sweep workers too) is seen at once.
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import os
import pkgutil
import sys
from functools import cache
from importlib.metadata import entry_points
from pathlib import Path
from types import ModuleType
from typing import Any

from contact_bench.api.params import parse_spec
from contact_bench.api.plugin import Case, Plugin, Scheme
from contact_bench.core.errors import BenchError, unknown

#: environment variable naming plugin folders (separated by os.pathsep)
PLUGINS_ENV = "CONTACT_BENCH_PLUGINS"
#: package under which plugin files are loaded (contact_bench.plugins.<stem>)
PLUGIN_NAMESPACE = "contact_bench.plugins"


def plugin_dirs() -> tuple[str, ...]:
    """The plugin folders named by CONTACT_BENCH_PLUGINS, resolved, without repeats."""
    raw = os.environ.get(PLUGINS_ENV, "")
    dirs = [str(Path(d).expanduser().resolve()) for d in raw.split(os.pathsep) if d.strip()]
    return tuple(dict.fromkeys(dirs))


def use_plugin_dirs(dirs: tuple[str, ...] | list[str]) -> None:
    """Make these the plugin folders of this process (a sweep worker given its parent's
    folders); nothing when none are given, so a worker's own setting stays."""
    if dirs and tuple(dirs) != plugin_dirs():
        os.environ[PLUGINS_ENV] = os.pathsep.join(dirs)


def checked_plugin_dirs(dirs: list[str]) -> list[str]:
    """The folders as resolved paths, or a one-line BenchError naming one that is not a
    folder (``--plugins DIR``)."""
    out = []
    for d in dirs:
        path = Path(d).expanduser()
        if not path.is_dir():
            raise BenchError(f"--plugins {d}: not a folder")
        out.append(str(path.resolve()))
    return out


def _where(obj: Any) -> str:
    """The file defining a plugin class or module (its module name when it has none)."""
    try:
        return inspect.getsourcefile(obj) or inspect.getfile(obj)
    except (TypeError, OSError):
        return getattr(obj, "__module__", None) or getattr(obj, "__name__", repr(obj))


def _one_line(exc: BaseException) -> str:
    return " ".join(f"{type(exc).__name__}: {exc}".split())


def _load_file(path: Path, name: str) -> ModuleType:
    """Execute a plugin file as the module `name` (replacing an older module of that name:
    another folder's file, or an earlier version of this one)."""
    importlib.import_module(PLUGIN_NAMESPACE)
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot load {path}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


@cache
def _plugin_files(dirs: tuple[str, ...]) -> tuple[list[ModuleType], dict[str, str]]:
    """The modules of every plugin file in the folders, and the files that failed to import
    (name -> one-line error). Two files of the same stem are a BenchError."""
    modules: list[ModuleType] = []
    broken: dict[str, str] = {}
    seen: dict[str, Path] = {}
    for folder in dirs:
        if not Path(folder).is_dir():
            raise BenchError(f"{PLUGINS_ENV}: {folder} is not a folder")
        for path in sorted(Path(folder).glob("*.py")):
            if path.stem.startswith("_"):
                continue
            if not path.stem.isidentifier():
                raise BenchError(f"plugin file {path}: the name {path.stem!r} is not a "
                                 "Python identifier")
            if path.stem in seen:
                raise BenchError(f"two plugin files are named {path.name}: {seen[path.stem]} "
                                 f"and {path}")
            seen[path.stem] = path
            try:
                modules.append(_load_file(path, f"{PLUGIN_NAMESPACE}.{path.stem}"))
            except Exception as exc:  # noqa: BLE001 - a broken plugin becomes a placeholder
                broken[path.stem] = f"{path}: {_one_line(exc)}"
    return modules, broken


class Registry:
    """The plugins of one kind (schemes or cases): name -> class, and the broken modules."""

    def __init__(self, package: str, base: type[Plugin], dirs: tuple[str, ...] = ()) -> None:
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
                self.broken[info.name] = _one_line(exc)
                continue
            self._add_module(module)
        for ep in sorted(entry_points(group=package), key=lambda e: e.name):
            try:
                obj = ep.load()
            except Exception as exc:  # noqa: BLE001 - a broken plugin becomes a placeholder
                self.broken[ep.name] = f"entry point {ep.value}: {_one_line(exc)}"
                continue
            if isinstance(obj, ModuleType):
                self._add_module(obj)
            elif isinstance(obj, type) and issubclass(obj, Plugin):
                if issubclass(obj, base):
                    self._add(obj)
            else:
                self.broken[ep.name] = (f"entry point {ep.value}: not a module or a "
                                        f"plugin class but {type(obj).__name__}")
        modules, broken = _plugin_files(dirs)
        for module in modules:
            self._add_module(module)
        self.broken.update(broken)

    def _add_module(self, module: ModuleType) -> None:
        for obj in list(vars(module).values()):
            if (isinstance(obj, type) and issubclass(obj, self.base) and obj.name
                    and obj.__module__ == module.__name__):
                self._add(obj)

    def _add(self, cls: type[Plugin]) -> None:
        old = self.plugins.get(cls.name)
        if old is not None and old is not cls:
            raise BenchError(f"two {self.kind[:-1]} plugins are named {cls.name!r}: "
                             f"{_where(old)} and {_where(cls)}")
        self.plugins[cls.name] = cls

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
def _schemes(dirs: tuple[str, ...]) -> Registry:
    return Registry("contact_bench.schemes", Scheme, dirs)


@cache
def _cases(dirs: tuple[str, ...]) -> Registry:
    return Registry("contact_bench.cases", Case, dirs)


def schemes() -> Registry:
    """The scheme registry for the current plugin folders."""
    return _schemes(plugin_dirs())


def cases() -> Registry:
    """The case (scene) registry for the current plugin folders."""
    return _cases(plugin_dirs())


def make_scheme(spec: str) -> Scheme:
    return schemes().make(spec)  # type: ignore[return-value]


def make_case(spec: str) -> Case:
    return cases().make(spec)  # type: ignore[return-value]
