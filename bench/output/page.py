"""HTML pieces shared by the report's pages (`index.html` of `contact_bench.output.report`,
`friction.html` of `contact_bench.output.friction_report`): links to the files a page
sits beside, and a saved figure's block. Its own module, beneath both, because the report
imports the friction report."""

from __future__ import annotations

import html
from collections.abc import Sequence
from pathlib import Path

from matplotlib.figure import Figure

from contact_bench.output.figures import save_figure


def file_links(paths: Sequence[Path]) -> str:
    """Links to the written files by name (the page is written in their folder)."""
    return " ".join(f'<a href="{html.escape(p.name)}">{html.escape(p.name)}</a>'
                    for p in paths)


def figure_block(fig: Figure, out: Path, stem: str, formats: Sequence[str], prov: str,
                 alt: str) -> tuple[str, list[Path]]:
    """Save fig as out/stem in each format (`save_figure`); the page's block for it (the
    PNG, else the SVG, shown when written, and links to every file) and the files."""
    files = save_figure(fig, out / stem, formats, prov)
    shown = next((f for f in ("png", "svg") if f in formats), None)
    img = f'<img src="{stem}.{shown}" alt="{html.escape(alt)}">' if shown else ""
    return f"{img}<p>figure: {file_links(files)}</p>", files
