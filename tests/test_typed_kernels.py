"""The compiled code's shape (issue 44): no compiled function takes more than 8
parameters (a scheme's step works over typed structures, never a long positional list),
and the run's bookkeeping (statistics, impulse) is called from the one loop only
(`contact_bench.core.loop`), read from the source (AST)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted([*(ROOT / "bench").rglob("*.py"), *(ROOT / "schemes").glob("*.py"),
                  *(ROOT / "cases").glob("*.py")])


def _compiled(tree: ast.AST):
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef) and any(
                "jit" in ast.unparse(d) for d in node.decorator_list):
            yield node


def test_no_compiled_function_takes_more_than_eight_parameters():
    wide = []
    for path in SOURCES:
        for node in _compiled(ast.parse(path.read_text(encoding="utf-8"))):
            k = len(node.args.args) + len(node.args.kwonlyargs)
            if k > 8:
                wide.append(f"{path.relative_to(ROOT)}:{node.name} ({k})")
    assert wide == []


def test_the_contact_statistics_are_kept_by_the_one_loop():
    calls = []
    for path in SOURCES:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                    and node.func.id in ("stats_update", "impulse_update")):
                calls.append(f"{path.relative_to(ROOT)}:{node.func.id}")
    # core.loop.book_step; the adaptive stepper's statistics are its samples' (DOP853's
    # own steps are not the suite's)
    assert sorted(calls) == ["bench/core/loop.py:impulse_update", "bench/core/loop.py:stats_update",
                             "bench/kernels/sparse_family.py:stats_update"]
