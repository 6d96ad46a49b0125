"""The import rules of the layout, read from the source (AST), and the package's isolation.

Layers, bottom to top: core < api < kernels, exact < harness < sweeps < output < cli. A
module imports only its own layer or lower ones; kernels and exact do not import each
other. No private (leading underscore) module or name is imported across subpackages,
and no module imports a private name of another module, in its own subpackage either.
Plugins (`schemes/`, `cases/`) import only core, api, kernels and exact, never one another.

The package installs as `contact_bench` only: a working directory holding folders named
`cases` and `schemes` changes nothing.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PKG = "contact_bench"
#: the repository's folders and the subpackages they install as
FOLDERS = {"bench": PKG, "schemes": f"{PKG}.schemes", "cases": f"{PKG}.cases"}
RANK = {"core": 0, "api": 1, "kernels": 2, "exact": 2, "harness": 3, "sweeps": 4,
        "output": 5, "cli": 6}
PLUGIN_PACKAGES = ("schemes", "cases", "plugins")
#: what a plugin may import
PLUGIN_MAY_IMPORT = ("core", "api", "kernels", "exact")


def _modules() -> dict[str, Path]:
    out = {}
    for folder, package in FOLDERS.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            rel = path.relative_to(ROOT / folder).with_suffix("").parts
            if rel[-1] == "__init__":
                rel = rel[:-1]
            out[".".join((package, *rel))] = path
    return out


def _is_package(name: str, modules: dict[str, Path]) -> bool:
    return modules[name].name == "__init__.py"


def _imports(name: str, path: Path, modules: dict[str, Path]) -> list[tuple[int, str, str]]:
    """(line, imported module, imported name or '') of every project import in the file."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    here = name if _is_package(name, modules) else name.rsplit(".", 1)[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name, "") for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join([*base, node.module] if node.module else base)
            else:
                target = node.module or ""
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                if sub in modules:  # `from package import module`
                    out.append((node.lineno, sub, ""))
                else:
                    out.append((node.lineno, target, alias.name))
    return [(line, mod, nm) for line, mod, nm in out if mod.split(".")[0] == PKG]


def _sub(module: str) -> str:
    """The subpackage: contact_bench.<sub>..., or '' for the top module."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def _private(part: str) -> bool:
    return part.startswith("_") and not (part.startswith("__") and part.endswith("__"))


def _violations(name: str, path: Path, modules: dict[str, Path]) -> list[str]:
    where = str(path.relative_to(ROOT) if path.is_relative_to(ROOT) else path)
    mine = _sub(name)
    out = []
    for line, target, imported in _imports(name, path, modules):
        theirs = _sub(target)
        at = f"{where}:{line} imports {target}" + (f".{imported}" if imported else "")
        if theirs == mine or not mine:
            if mine in PLUGIN_PACKAGES and target != name and target.startswith(f"{PKG}."):
                if target != f"{PKG}.{mine}" and theirs == mine:
                    out.append(f"{at}: a plugin imports another plugin")
            continue
        if name == f"{PKG}.__main__" or target == PKG:  # the root imports no project module
            continue
        if mine in PLUGIN_PACKAGES:
            if theirs not in PLUGIN_MAY_IMPORT:
                out.append(f"{at}: a plugin imports only {', '.join(PLUGIN_MAY_IMPORT)}")
        elif theirs in PLUGIN_PACKAGES:
            out.append(f"{at}: a layer imports a plugin (read it from the registry)")
        elif theirs not in RANK:
            out.append(f"{at}: not a layer")
        elif RANK[theirs] > RANK[mine] or (RANK[theirs] == RANK[mine]):
            out.append(f"{at}: upward import ({mine} -> {theirs})")
        if any(_private(p) for p in target.split(".")[2:]) or _private(imported):
            out.append(f"{at}: private name across subpackages ({mine} -> {theirs})")
    return out


def test_imports_point_down_and_stay_public() -> None:
    modules = _modules()
    assert f"{PKG}.core.errors" in modules and f"{PKG}.schemes.standard" in modules
    bad = [v for name, path in modules.items() for v in _violations(name, path, modules)]
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("source, rule", [
    ("from contact_bench.harness.runner import run_one", "upward import"),
    ("from contact_bench.exact import clamped", "upward import"),
    ("import contact_bench.cli.main", "upward import"),
    ("from contact_bench.core.sampling import _hidden", "private name"),
    ("from contact_bench.core import _private_module", "private name"),
    ("from contact_bench.schemes.standard import Standard", "imports a plugin"),
])
def test_the_rules_catch_a_bad_import(tmp_path: Path, source: str, rule: str) -> None:
    """The checker itself: each kind of bad import in a kernels module (or, for the last,
    in a scheme) is reported."""
    path = tmp_path / "probe.py"
    path.write_text(source + "\n")
    modules = _modules()
    name = (f"{PKG}.schemes.probe" if "schemes" in source else f"{PKG}.kernels.probe")
    modules[name] = path
    found = [v for v in _violations(name, path, modules) if rule in v]
    if "schemes" in source:  # a scheme importing a scheme
        found = [v for v in _violations(name, path, modules) if "another plugin" in v]
    assert found, (source, _violations(name, path, modules))


def _private_imports(name: str, path: Path, modules: dict[str, Path]) -> list[str]:
    """`from contact_bench.X import _name` of a module other than this one: a private
    name shared across modules (inside a subpackage too)."""
    where = str(path.relative_to(ROOT) if path.is_relative_to(ROOT) else path)
    return [f"{where}:{line} imports {target}.{imported}"
            for line, target, imported in _imports(name, path, modules)
            if imported and _private(imported) and target != name]


def test_no_module_imports_a_private_name_of_another() -> None:
    """What one module shares with another is public: no `from contact_bench.X import
    _name` anywhere in bench/, schemes/ or cases/ (within a subpackage too)."""
    modules = _modules()
    bad = [v for name, path in modules.items() for v in _private_imports(name, path, modules)]
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("source, caught", [
    ("from contact_bench.kernels.sparse import _hidden", True),
    ("from .sparse import _hidden", True),
    ("from contact_bench.kernels.sparse import visible", False),
    ("from contact_bench.kernels import __version__", False),
])
def test_the_private_import_rule_catches_a_private_name(tmp_path: Path, source: str,
                                                       caught: bool) -> None:
    """The checker itself, in a kernels module importing from its own subpackage."""
    path = tmp_path / "probe.py"
    path.write_text(source + "\n")
    modules = _modules()
    name = f"{PKG}.kernels.probe"
    modules[name] = path
    assert bool(_private_imports(name, path, modules)) == caught


def test_a_plugin_importing_a_layer_above_kernels_is_caught(tmp_path: Path) -> None:
    path = tmp_path / "probe.py"
    path.write_text("from contact_bench.harness.metrics import error_norms\n")
    modules = {**_modules(), f"{PKG}.cases.probe": path}
    assert any("a plugin imports only" in v
               for v in _violations(f"{PKG}.cases.probe", path, modules))


def test_folders_named_cases_and_schemes_in_the_working_directory_change_nothing(
        tmp_path: Path) -> None:
    """`contact-bench list` shows every built-in scene and scheme from a folder that holds
    `cases/` and `schemes/`; `import cases` fails there (no top-level module installed)."""
    from contact_bench.api.registry import _cases, _schemes

    for sub in ("cases", "schemes"):
        (tmp_path / sub).mkdir()
        (tmp_path / sub / "unrelated.py").write_text("x = 1\n")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "CONTACT_BENCH_PLUGINS")}
    proc = subprocess.run([sys.executable, "-m", "contact_bench", "list"], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    listed = {line.split()[0] for line in proc.stdout.splitlines() if line.startswith("  ")
              and not line.startswith("   ")}
    builtins = set(_cases(()).plugins) | set(_schemes(()).plugins)
    assert builtins and builtins <= listed, builtins - listed
    for module in ("cases", "schemes", "bench"):
        # nothing of that name is installed (-I: the working directory not on sys.path)
        probe = subprocess.run([sys.executable, "-I", "-c", f"import {module}"], cwd=tmp_path,
                               env=env, capture_output=True, text=True, timeout=60)
        assert probe.returncode != 0 and "ModuleNotFoundError" in probe.stderr, module
    # plain `python -c`: `cases` is then only the user's own folder (a namespace package)
    probe = subprocess.run([sys.executable, "-c", "import cases; print(*cases.__path__)"],
                           cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60)
    assert probe.stdout.split() == [str(tmp_path / "cases")], probe.stdout + probe.stderr
