"""Every statement is laid out by ``ruff format`` (flylog issue 31). A formatter-suppression
comment (``fmt:`` skip or off) stays only where the formatted form would be unreadable, a
table of numbers whose columns line up, and then the line directly above the statement is a
comment that gives the reason, starting ``# Unformatted:``."""

from __future__ import annotations

import io
import os
import re
import tokenize
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# Not walked: hidden directories (.venv, .git, the tools' caches) and build output.
BUILD_DIRS = {"build", "dist", "__pycache__"}
REASON = "# Unformatted:"
SUPPRESSION = re.compile(r"fmt:\s*(skip|off)")


def python_files(root: Path) -> list[Path]:
    """Every ``*.py`` under ``root``, but in hidden and build directories."""
    found = []
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(
            d
            for d in dirs
            if not d.startswith(".") and d not in BUILD_DIRS and not d.endswith(".egg-info")
        )
        found += [Path(folder) / name for name in sorted(files) if name.endswith(".py")]
    return found


def unreasoned(source: str) -> list[tuple[int, str]]:
    """(line, marker) of every suppression comment whose statement has no ``# Unformatted:``
    comment on the line directly above it. A trailing marker belongs to the statement (the
    logical line) it ends, which may start lines above it; an own-line marker to itself.
    Comments only: a string that mentions a marker is not one."""
    lines = source.split("\n")
    found = []
    start = None  # first line of the logical line being read
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.NEWLINE:
            start = None
        elif token.type == tokenize.COMMENT:
            parts = (part.strip() for part in token.string.split("#"))
            marker = next((p for p in parts if SUPPRESSION.fullmatch(p)), None)
            if marker is None:
                continue
            line = token.start[0]
            own_line = not token.line[: token.start[1]].strip()
            statement = line if own_line or start is None else start
            above = lines[statement - 2].strip() if statement > 1 else ""
            if not above.startswith(REASON):
                found.append((line, f"# {marker}"))
        elif token.type not in (tokenize.NL, tokenize.INDENT, tokenize.DEDENT) and start is None:
            start = token.start[0]
    return found


def test_every_formatter_suppression_gives_its_reason():
    files = python_files(ROOT)
    assert ROOT / "tests" / "test_fmt_skip.py" in files and len(files) > 300
    bad = [
        f"{path.relative_to(ROOT)}:{line}: `{marker}` without a reason"
        for path in files
        for line, marker in unreasoned(path.read_text(encoding="utf-8"))
    ]
    assert not bad, (
        "\n".join(bad) + "\nRemove the marker and run `ruff format`; only where the formatted "
        "statement would be unreadable (a table of numbers whose columns line up) keep it, "
        f"with `{REASON} <why>` on the line directly above the statement."
    )


def test_a_marker_without_its_reason_is_found():
    mark = "# fmt" + ": skip"  # built, so that this file carries no marker of its own
    source = "\n".join(
        [
            f"a = [1,2]  {mark}",  # 1: bare
            f"{REASON} the rows line up as the matrix's.",
            f"b = [[1, 0],\n     [0, 1]]  {mark}",  # 3-4: reasoned, the marker on line 4
            "# a comment, but not the reason",
            f"c = f(1,\n      2)  {mark}  # pragma: no cover",  # 6-7: bare, the marker on 7
            f"d = '{mark}'",  # 8: a string, not a comment
            "# fmt" + ":off",  # 9: bare, own line
            "# the markers (fmt" + ": skip) in prose are not markers",
            "",
        ]
    )
    assert unreasoned(source) == [(1, mark), (7, mark), (9, "# fmt" + ":off")]
