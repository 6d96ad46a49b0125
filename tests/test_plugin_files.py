"""Plugin files show the plugin first: a short docstring, then the plugin class.

Every file of `schemes/` and `cases/`: a module docstring of at most `MAX_DOC_LINES`
lines (derivations and measurements belong in docs/schemes.md and docs/scenes.md), and
no function or class defined above the plugin class (compiled helpers go below it or
into `contact_bench.kernels` / `contact_bench.exact`).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from contact_bench.api.plugin import Case, Scheme
from contact_bench.api.registry import cases, schemes

ROOT = Path(__file__).resolve().parents[1]
MAX_DOC_LINES = 20
FILES = sorted(p for folder in ("schemes", "cases") for p in (ROOT / folder).glob("*.py")
               if not p.name.startswith("_"))


@pytest.mark.parametrize("path", FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_plugin_file_opens_with_a_short_docstring_then_the_plugin(path: Path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    doc = ast.get_docstring(tree, clean=False)
    assert doc, f"{path.name} has no module docstring"
    n = len(doc.strip("\n").splitlines())
    assert n <= MAX_DOC_LINES, f"{path.name}: module docstring of {n} lines"
    defs = [node for node in tree.body if isinstance(node, (ast.ClassDef, ast.FunctionDef))]
    assert defs and isinstance(defs[0], ast.ClassDef), (
        f"{path.name}: {defs[0].name if defs else 'nothing'} is defined before the plugin class")
    registry = schemes() if path.parent.name == "schemes" else cases()
    base = Scheme if path.parent.name == "schemes" else Case
    cls = registry.plugins.get(_declared_name(defs[0]))
    assert cls is not None and issubclass(cls, base), (
        f"{path.name}: the first class, {defs[0].name}, is not a registered plugin")


def _declared_name(node: ast.ClassDef) -> str:
    """The `name = "..."` a plugin class declares in its body ('' if none)."""
    for stmt in node.body:
        if (isinstance(stmt, ast.Assign) and len(stmt.targets) == 1
                and isinstance(stmt.targets[0], ast.Name) and stmt.targets[0].id == "name"
                and isinstance(stmt.value, ast.Constant)):
            return str(stmt.value.value)
    return ""

