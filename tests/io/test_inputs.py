"""Every file the library reads goes through flylog.io.inputs, so that each command's
registry of inputs is complete and the atomic writer never replaces one: a read anywhere
else fails here, until it goes through the door (or is listed below with its reason)."""

from __future__ import annotations

import ast
from pathlib import Path

LIBRARY = Path(__file__).resolve().parents[2] / "flylog"
DOOR = LIBRARY / "io" / "inputs.py"

# Calls that read a file given its path or open one: method or function names.
READING_ATTRIBUTES = {
    "open", "read_text", "read_bytes", "imread", "read_table", "read_schema",
    "read_metadata", "ParquetFile", "loadtxt", "genfromtxt", "fromfile", "AnyReader",
    "make_reader",
}  # fmt: skip
# Reads that are not a command's inputs, with the reason.
NOT_INPUTS = {
    # `make docs`: the pages it regenerates, not a command
    ("reference_docs.py", "read_text"),
    # a sweep's own cell records, which it writes again when a cell runs again
    ("sweep/work.py", "read_text"),
    # the confidence model packaged with flylog (importlib.resources), not a user's file
    ("fly/confidence.py", "read_text"),
    # the bag's MCAP file, opened "xb" to write inside the export's staging directory
    ("ros2/bagwriter.py", "open"),
    # the sweep folder's lock file, opened to hold an fcntl lock, never read as an input
    ("sweep/lock.py", "open"),
    # os.open: the atomic writer's own temporary file and directory (fsync)
    ("io/atomic.py", "open"),
}


def _through_the_door(call: ast.Call) -> bool:
    """Whether the path a reader is given comes straight from the door:
    ``pq.read_table(input_path(found, "the table"))``."""
    first = call.args[0] if call.args else None
    return (
        isinstance(first, ast.Call)
        and isinstance(first.func, ast.Name)
        and first.func.id in ("input_path", "open_input")
    )


def _reads(path: Path) -> list[tuple[str, int]]:
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, ast.Call):
            continue
        func = node.func
        if isinstance(func, ast.Name) and func.id in ("open", "AnyReader"):
            found.append((func.id, node.lineno))
        elif (
            isinstance(func, ast.Attribute)
            and func.attr in READING_ATTRIBUTES
            and not _through_the_door(node)
        ):
            found.append((func.attr, node.lineno))
    return found


def test_every_read_of_the_library_goes_through_the_inputs_door() -> None:
    outside = []
    for path in sorted(LIBRARY.rglob("*.py")):
        if path == DOOR:
            continue
        where = str(path.relative_to(LIBRARY))
        outside += [
            f"{where}:{line}: {name}"
            for name, line in _reads(path)
            if (where, name) not in NOT_INPUTS
        ]
    assert outside == []
