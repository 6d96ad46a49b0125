"""Every relative link in README.md and docs/*.md resolves to an existing file or folder.

Links are Markdown `[text](target)`; targets with a scheme (http:, mailto:) and pure
anchors (#...) are skipped, a target's own #anchor is dropped. Paths resolve from the
folder of the page that holds the link, as GitHub resolves them.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^(```|~~~).*?^\1", flags=re.S | re.M)


def relative_links(page: Path) -> list[str]:
    """The relative link targets of a page, outside fenced code blocks."""
    text = FENCE.sub("", page.read_text(encoding="utf-8"))
    targets = []
    for target in LINK.findall(text):
        if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", target) or target.startswith("#"):
            continue
        targets.append(target.split("#", 1)[0])
    return targets


def dead_links(page: Path) -> list[str]:
    return [t for t in relative_links(page) if not (page.parent / t).exists()]


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(ROOT).as_posix() for p in PAGES])
def test_relative_links_resolve(page: Path) -> None:
    assert not dead_links(page), f"{page.relative_to(ROOT)}: dead links {dead_links(page)}"


def test_the_checker_finds_a_dead_link(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text("[ok](page.md) [web](https://example.org) [gone](docs/missing.md#top)\n"
                    "```\n[in code](nowhere.md)\n```\n", encoding="utf-8")
    assert dead_links(page) == ["docs/missing.md"]
