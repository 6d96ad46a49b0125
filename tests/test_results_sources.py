"""Published results are made by today's code, or listed stale.

Every entry of results/ has the source hash of the code that made it in
results/sources.txt (`contact_bench.core.sources`); results/README.md's "Stale" section
lists exactly the entries whose hash is not today's. The hash names the code files only,
so a commit that changes docs, tests or results keeps it; a writer under results/ records
it.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from contact_bench.core import sources
from contact_bench.harness.io import folder_set, write_text

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "results" / "README.md"


def listed_stale() -> list[str]:
    text = README.read_text(encoding="utf-8")
    assert "\n## Stale\n" in text, "results/README.md has no '## Stale' section"
    section = text.split("\n## Stale\n", 1)[1].split("\n## ", 1)[0]
    return [re.match(r"- `([^`]+)`", line).group(1) for line in section.splitlines()
            if line.startswith("- `")]


def test_every_results_entry_records_the_code_that_made_it():
    table = sources.recorded()
    missing = [e for e in sources.entries() if e not in table]
    assert not missing, f"results/sources.txt has no source hash for {missing}"
    assert not set(table) - set(sources.entries()), "sources.txt names entries not in results/"
    assert all(re.fullmatch(r"[0-9a-f]{16}|unknown", v) for v in table.values())


def test_results_readme_lists_exactly_the_stale_entries():
    listed = listed_stale()
    assert len(listed) == len(set(listed)), "an entry is listed twice"
    stale = sources.stale_entries()
    assert sorted(listed) == sorted(stale), (
        "results/README.md's stale list is not the entries whose source hash is not today's "
        f"({sources.source_hash()}): listed but current {sorted(set(listed) - set(stale))}, "
        f"stale but not listed {sorted(set(stale) - set(listed))} "
        "(python -m contact_bench.core.sources stale)")


def _tree(tmp_path: Path) -> Path:
    root = tmp_path / "repo"
    for folder in sources.CODE_FOLDERS:
        shutil.copytree(ROOT / folder, root / folder,
                        ignore=shutil.ignore_patterns("__pycache__"))
    (root / "docs").mkdir()
    (root / "docs" / "a.md").write_text("x")
    return root


def test_the_hash_changes_with_code_only(tmp_path: Path):
    root = _tree(tmp_path)
    first = sources.source_hash(root)
    assert first == sources.source_hash(ROOT)  # the same files: the same hash
    (root / "docs" / "a.md").write_text("changed")  # not code
    (root / "bench" / "notes.txt").write_text("not a .py file")
    assert sources.source_hash(root) == first
    kernel = root / "schemes" / "standard.py"
    kernel.write_text(kernel.read_text() + "\n# a change\n")
    assert sources.source_hash(root) != first


def test_the_hash_of_a_commit_is_read_from_git_blob_ids():
    """Today's files, hashed from their bytes, against git's own blob ids of HEAD: equal
    when HEAD's code is the working tree's."""
    import subprocess

    changed = subprocess.run(["git", "status", "--porcelain", "--", *sources.CODE_FOLDERS],
                             cwd=ROOT, capture_output=True, text=True, check=False)
    if changed.returncode != 0:
        pytest.skip("not a git checkout")
    if any(line[3:].endswith(".py") for line in changed.stdout.splitlines()):
        pytest.skip("uncommitted code changes")
    assert sources.source_hash_at("HEAD") == sources.source_hash()
    data = b"one\ntwo \x00 three\n"
    by_git = subprocess.run(["git", "hash-object", "--stdin"], input=data, cwd=ROOT,
                            capture_output=True, check=True).stdout.decode().strip()
    assert sources.blob_id(data) == by_git


def test_writing_under_results_records_the_hash(tmp_path: Path, monkeypatch):
    results = tmp_path / "results"
    results.mkdir()
    monkeypatch.setattr(sources, "RESULTS", results)
    write_text(results / "one.md", "a table\n")
    with folder_set(results / "a_set") as tmp:
        write_text(tmp / "runs.csv", "x\n1\n")
    write_text(tmp_path / "elsewhere.md", "not a result\n")
    assert sources.recorded(results) == {"one.md": sources.source_hash(),
                                         "a_set/": sources.source_hash()}
    assert sources.stale_entries(results) == []
    assert sources.stale_entries(results, current="0" * 16) == ["a_set/", "one.md"]


def test_docs_schemes_tables_list_every_scheme():
    """docs/schemes.md's comparison table and its measured table (results/clamped_nx80)
    each have one row per registered scheme."""
    from contact_bench.api.registry import schemes

    text = (ROOT / "docs" / "schemes.md").read_text(encoding="utf-8")
    main = text.split("| scheme | what it is |", 1)[1].split("\n\n", 1)[0]
    listed = re.findall(r"^\| `(\w+)", main, flags=re.M)
    measured = text.split("## Measured on the clamped bar", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| clamped_bar \| (\w+) ", measured, flags=re.M)
    names = sorted(schemes().plugins)
    assert sorted(listed) == names, "docs/schemes.md's main table is not the registry"
    assert sorted(rows) == names, "docs/schemes.md's measured table is not the registry"
