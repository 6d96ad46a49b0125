"""The source hash: which code made a published result, and which results are stale.

`source_hash()` names the code, not the commit: a hash of the Python files of the
package's three source folders (bench/, schemes/, cases/), each file by its git blob id
(sha1 of "blob <size>\\0" + its bytes, what `git ls-files -s` and `git ls-tree` print),
so a commit that changes no code file (docs, results, tests) keeps it, and a checkout
outside git computes the same value. `source_hash_at(commit)` is the same hash of a past
commit's tree (from `git ls-tree`).

Every entry of results/ (a file, or a folder of files written as one set) has a line
"<source hash> <entry>" in results/sources.txt. `contact_bench.harness.io` records it when
a result file or set is written under results/ (`record`); a file made by redirecting a
command's output is recorded with

    python -m contact_bench.core.sources record results/bad_inputs.md

An entry whose recorded hash is not `source_hash()` is stale: `stale_entries()`, printed by
`python -m contact_bench.core.sources stale`; results/README.md lists exactly those
(`tests/test_results_sources.py`).
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from functools import cache
from pathlib import Path

#: the repository holding this package (the editable install's checkout)
REPO = Path(__file__).resolve().parents[2]
#: the folders whose Python files are "the code"
CODE_FOLDERS = ("bench", "schemes", "cases")
RESULTS = REPO / "results"
MANIFEST_NAME = "sources.txt"
#: files of results/ that are not results
NOT_RESULTS = ("README.md", MANIFEST_NAME)
UNKNOWN = "unknown"
_HEADER = ("# source hash (contact_bench.core.sources.source_hash) of the code that made "
           "each entry of results/\n")


def blob_id(data: bytes) -> str:
    """git's blob id of these bytes."""
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


def _digest(pairs: Sequence[tuple[str, str]]) -> str:
    text = "".join(f"{path} {blob}\n" for path, blob in sorted(pairs))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def code_files(root: Path = REPO) -> list[Path]:
    """The code's files under `root`: *.py of the source folders (no caches)."""
    return sorted(p for folder in CODE_FOLDERS for p in (root / folder).rglob("*.py")
                  if "__pycache__" not in p.parts)


def source_hash(root: Path | None = None) -> str:
    """16 hex digits naming the code of the checkout `root` (module docstring); for the
    package's own checkout (root None), computed once per process: the code it runs."""
    if root is None:
        return _own_hash()
    return _digest([(p.relative_to(root).as_posix(), blob_id(p.read_bytes()))
                    for p in code_files(root)])


@cache
def _own_hash() -> str:
    return source_hash(REPO)


def source_hash_at(commit: str, root: Path = REPO) -> str:
    """The same hash of a commit's tree (ValueError when git cannot read it)."""
    out = subprocess.run(["git", "ls-tree", "-r", commit, "--", *CODE_FOLDERS], cwd=root,
                         capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise ValueError(f"git ls-tree {commit}: {out.stderr.strip()}")
    pairs = []
    for line in out.stdout.splitlines():
        meta, path = line.split("\t", 1)
        if path.endswith(".py"):
            pairs.append((path, meta.split()[2]))
    return _digest(pairs)


def entry_of(path: str | Path, results: Path | None = None) -> str | None:
    """The entry of results/ that `path` belongs to ("study/" for a file in a folder,
    "memory.md" for a file), None outside results/ or for a hidden (partial) name."""
    results = RESULTS if results is None else results
    try:
        rel = Path(path).resolve().relative_to(results.resolve())
    except ValueError:
        return None
    if not rel.parts or rel.parts[0].startswith(".") or rel.parts[0] in NOT_RESULTS:
        return None
    return rel.parts[0] + ("/" if len(rel.parts) > 1 or (results / rel).is_dir() else "")


def entries(results: Path | None = None) -> list[str]:
    """Every entry of results/ (its files and folders, hidden names and README.md and
    the manifest excepted)."""
    results = RESULTS if results is None else results
    return sorted(p.name + ("/" if p.is_dir() else "") for p in results.iterdir()
                  if not p.name.startswith(".") and p.name not in NOT_RESULTS)


def recorded(results: Path | None = None) -> dict[str, str]:
    """The manifest: entry -> the source hash recorded for it."""
    results = RESULTS if results is None else results
    path = results / MANIFEST_NAME
    if not path.is_file():
        return {}
    out = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.strip() and not line.startswith("#"):
            value, entry = line.split(maxsplit=1)
            out[entry] = value
    return out


def _write_manifest(table: dict[str, str], results: Path) -> None:
    text = _HEADER + "".join(f"{table[e]} {e}\n" for e in sorted(table))
    fd, tmp = tempfile.mkstemp(prefix=f".{MANIFEST_NAME}.", dir=results)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.chmod(tmp, 0o644)
        os.replace(tmp, results / MANIFEST_NAME)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def record(path: str | Path, value: str | None = None, results: Path | None = None) -> str | None:
    """Record `value` (default: today's `source_hash()`) for the entry holding `path`;
    nothing for a path outside results/. Returns the entry."""
    results = RESULTS if results is None else results
    entry = entry_of(path, results)
    if entry is None or not results.is_dir():
        return None
    table = recorded(results)
    table[entry] = value or source_hash()
    _write_manifest(table, results)
    return entry


def stale_entries(results: Path | None = None, current: str | None = None) -> list[str]:
    """The entries whose recorded hash is not today's (or that have none)."""
    results = RESULTS if results is None else results
    now = current or source_hash()
    table = recorded(results)
    return [e for e in entries(results) if table.get(e) != now]


def main(argv: Sequence[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if args[:1] == ["record"] and len(args) > 1:
        for p in args[1:]:
            if record(p) is None:
                print(f"sources: {p} is not in {RESULTS}", file=sys.stderr)
                return 2
        return 0
    if args == ["stale"]:
        for e in stale_entries():
            print(f"- `{e}`")
        return 0
    if args == ["hash"]:
        print(source_hash())
        return 0
    print("usage: python -m contact_bench.core.sources record PATH... | stale | hash",
          file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
