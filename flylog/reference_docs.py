"""The reference pages of ``docs/`` that are made from the code, never written by hand.

``docs/configuration.md`` (:mod:`flylog.config_reference`), and in ``docs/metrics.md`` the
Parquet schemas between ``<!-- generated: NAME -->`` and ``<!-- end generated -->`` markers,
from the ``Column`` tuples the writers use; and beside ``docs/``, the annotated sample
``fixtures/replay.toml`` (every replay key at its default, ``sample_toml``).
``python -m flylog.reference_docs [DOCS_DIR]`` (``make docs``) rewrites what is out of
date; ``--check`` only reports it (exit code 1), as the test does.
"""

from __future__ import annotations

import os
import re
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from flylog.config_reference import config_files, configuration_md, sample_toml
from flylog.io.atomic import publish, temporary_beside


def _schemas() -> dict[str, Callable[[], str]]:
    """The generated blocks of metrics.md, by name."""

    def block(module: str, attr: str) -> Callable[[], str]:
        def make() -> str:
            import importlib

            from flylog.io.tables import schema_markdown

            return schema_markdown(getattr(importlib.import_module(module), attr))

        return make

    return {
        "replay-steps": block("flylog.replay.run", "STEP_COLUMNS"),
        "metrics-snapshots": block("flylog.metrics.tables", "SNAPSHOT_COLUMNS"),
        "metrics-summary": block("flylog.metrics.tables", "SUMMARY_COLUMNS"),
        "metrics-obstacles": block("flylog.metrics.tables", "OBSTACLE_COLUMNS"),
    }


_BLOCK = re.compile(r"(<!-- generated: ([a-z0-9-]+) -->\n)(.*?)(<!-- end generated -->)", re.S)


def fill_blocks(text: str) -> str:
    """``text`` with every generated block's body made again from the code."""
    makers = _schemas()

    def fill(m: re.Match[str]) -> str:
        name = m.group(2)
        if name not in makers:
            msg = f"unknown generated block '{name}'; known: {', '.join(sorted(makers))}"
            raise ValueError(msg)
        return f"{m.group(1)}{makers[name]()}\n{m.group(4)}"

    return _BLOCK.sub(fill, text)


def expected_pages(docs: Path) -> dict[Path, str]:
    """Each generated page under ``docs`` and the text it should have."""
    metrics = docs / "metrics.md"
    pages = {docs / "configuration.md": configuration_md()}
    if metrics.exists():
        pages[metrics] = fill_blocks(metrics.read_text(encoding="utf-8"))
    fixtures = docs.parent / "fixtures"
    if fixtures.is_dir():
        pages[fixtures / "replay.toml"] = sample_toml(config_files()[0])
    return pages


def stale_pages(docs: Path) -> list[Path]:
    return [
        p
        for p, text in expected_pages(docs).items()
        if not p.exists() or p.read_text(encoding="utf-8") != text
    ]


def _write(path: Path, text: str) -> None:
    fd, tmp = temporary_beside(path)
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        fh.write(text)
    publish(tmp, path)


def main(argv: Sequence[str]) -> int:
    check = "--check" in argv
    args = [a for a in argv if a != "--check"]
    docs = Path(args[0] if args else "docs")
    if check:
        stale = stale_pages(docs)
        for p in stale:
            print(f"{p} is out of date: run `make docs`", file=sys.stderr)
        return 1 if stale else 0
    for p, text in expected_pages(docs).items():
        if not p.exists() or p.read_text(encoding="utf-8") != text:
            _write(p, text)
            print(f"wrote {p}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
