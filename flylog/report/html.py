"""One self-contained HTML page: sections of tables, preformatted text and PNG figures
embedded as ``data:`` URIs, with its style inline; no script, no font, nothing fetched
from a network. Written atomically."""

from __future__ import annotations

import base64
import html
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flylog.io.atomic import publish, temporary_beside
from flylog.io.inputs import read_input_bytes

_STYLE = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 78em; color: #222;
       padding: 0 1em; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; font-size: 0.85em; margin: 0.5em 0 1em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: right; }
th { background: #f0f0f0; } td.text, th.text { text-align: left; }
tr.failed td { background: #fde8e8; }
figure { margin: 0.5em 0 1.2em; } figcaption { font-size: 0.85em; color: #555; }
img { max-width: 100%; height: auto; border: 1px solid #eee; }
pre { background: #f7f7f7; padding: 0.7em; font-size: 0.8em; overflow-x: auto; }
p.note { font-size: 0.85em; color: #555; }
p.what { color: #444; margin: 0.2em 0; } p.verdict { font-size: 1.15em; margin: 0.5em 0; }
p.figures { font-size: 0.95em; background: #f4f7fb; padding: 0.5em 0.7em;
            border-left: 3px solid #4a78b5; }
details { margin: 0.5em 0 1em; } summary { cursor: pointer; color: #335; }
"""


def png_data_uri(path: Path) -> str:
    data = read_input_bytes(path, "a figure")
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def cell_text(value: Any) -> str:
    """A table cell's text: nulls and NaN as —, booleans yes/no, floats to 4 digits."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def _text(value: Any) -> str:
    return html.escape(cell_text(value), quote=False)


@dataclass
class Page:
    """Sections in the order added; ``render`` makes the HTML text."""

    title: str
    parts: list[str] = field(default_factory=list)

    def headline(self, what: str, verdict: str, figures: str) -> None:
        """The top of the page: what ran on what, the verdict in a sentence, key figures."""
        self.parts.append(
            f'<p class="what">{html.escape(what)}</p>'
            f'<p class="verdict"><strong>{html.escape(verdict)}</strong></p>'
            f'<p class="figures">{html.escape(figures)}</p>'
        )

    def heading(self, text: str) -> None:
        self.parts.append(f"<h2>{html.escape(text)}</h2>")

    def note(self, text: str) -> None:
        self.parts.append(f'<p class="note">{html.escape(text)}</p>')

    def table(
        self,
        header: Sequence[str],
        rows: Sequence[Sequence[Any]],
        *,
        text_columns: int = 1,
        row_classes: Sequence[str] | None = None,
    ) -> None:
        """A table; the first ``text_columns`` columns and text values are left-aligned,
        numbers right-aligned."""

        def cls(i: int, value: Any = None) -> str:
            return ' class="text"' if i < text_columns or isinstance(value, str) else ""

        head = "".join(f"<th{cls(i)}>{html.escape(h)}</th>" for i, h in enumerate(header))
        body = []
        for k, row in enumerate(rows):
            klass = f' class="{row_classes[k]}"' if row_classes and row_classes[k] else ""
            tds = "".join(f"<td{cls(i, v)}>{_text(v)}</td>" for i, v in enumerate(row))
            body.append(f"<tr{klass}>{tds}</tr>")
        rows_html = "".join(body)
        self.parts.append(
            f"<table><thead><tr>{head}</tr></thead><tbody>{rows_html}</tbody></table>"
        )

    def figure(self, png: Path, caption: str) -> None:
        alt = html.escape(caption, quote=True)
        self.parts.append(
            f'<figure><img src="{png_data_uri(png)}" alt="{alt}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>"
        )

    def preformatted(self, text: str) -> None:
        self.parts.append(f"<pre>{html.escape(text, quote=False)}</pre>")

    def folded(self, summary: str, text: str) -> None:
        """Preformatted ``text`` behind a line ``summary`` that unfolds it."""
        self.parts.append(
            f"<details><summary>{html.escape(summary)}</summary>"
            f"<pre>{html.escape(text, quote=False)}</pre></details>"
        )

    def render(self) -> str:
        title = html.escape(self.title)
        return (
            '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f"<title>{title}</title><style>{_STYLE}</style></head>\n<body>"
            f"<h1>{title}</h1>\n" + "\n".join(self.parts) + "\n</body></html>\n"
        )


def write_page(page: Page, path: Path) -> Path:
    """The page at ``path``, whole or not at all."""
    path = Path(path)
    fd, tmp = temporary_beside(path)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(page.render())
        publish(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
