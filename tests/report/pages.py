"""Checks of a self-contained page shared by the report tests."""

from __future__ import annotations

import base64
import re
from html.parser import HTMLParser
from pathlib import Path

import cv2
import numpy as np


class _Tags(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.tags: list[tuple[str, dict[str, str | None]]] = []
        self.headings: list[str] = []
        self._in_h2 = False

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        self._in_h2 = tag == "h2"

    def handle_endtag(self, tag):
        self._in_h2 = False

    def handle_data(self, data):
        if self._in_h2:
            self.headings.append(data)


def checked_page(path: Path) -> tuple[list[str], list[np.ndarray], list[tuple[str, dict]]]:
    """(section headings, decoded images, tags) of a page that references nothing outside
    itself: every src is a data: URI, no link, script, iframe or url() to fetch."""
    text = path.read_text(encoding="utf-8")
    parser = _Tags()
    parser.feed(text)
    assert text.startswith("<!DOCTYPE html>") and text.rstrip().endswith("</html>")
    assert not re.search(r"https?://|url\(|@import", text)
    images = []
    for tag, attrs in parser.tags:
        assert tag not in ("script", "link", "iframe", "object", "embed"), tag
        if "src" in attrs:
            src = attrs["src"] or ""
            assert src.startswith("data:image/png;base64,"), src[:40]
            data = np.frombuffer(base64.b64decode(src.split(",", 1)[1]), np.uint8)
            image = cv2.imdecode(data, cv2.IMREAD_COLOR)
            assert image is not None and image.shape[0] > 50 and image.shape[1] > 50
            images.append(image)
        assert "href" not in attrs
    return parser.headings, images, parser.tags
