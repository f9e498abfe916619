"""Refuse, before a job starts, an output that would overwrite one of its inputs or another
of its outputs, or whose directory is not writable.

Two paths name the same file when the file exists and ``os.path.samefile`` says so (it
follows symbolic links and sees hard links), or when their resolved paths (symbolic links
followed, ``..`` removed) are equal: that is the case of an output that does not exist yet.
An input that is a directory (a rosbag2 bag) holds every path inside it: an output there
would change the bag's files.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from flylog.errors import OutputError


@dataclass(frozen=True)
class Role:
    """A file a job reads or writes: its path, what it is, and the parameter that sets it
    (for an output: the one to change when it collides)."""

    path: Path
    what: str  # "the sensor log", "the step table", ...
    parameter: str


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether ``a`` and ``b`` are (or, once written, will be) the same file."""
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet), or cannot be examined
        return os.path.realpath(a) == os.path.realpath(b)


def inside(path: str | os.PathLike[str], directory: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is (or, once written, will be) a file inside the existing directory
    ``directory``, at any depth."""
    if not os.path.isdir(directory):
        return False
    return Path(os.path.realpath(directory)) in Path(os.path.realpath(path)).parents


def check_outputs(inputs: Iterable[Role], outputs: Iterable[Role]) -> None:
    """Raise OutputError if an output is an input or another output (naming both files),
    or if its directory exists but cannot be written to; ``parameter`` is the output's.

    A missing directory is left to the writer (``flylog export`` creates its own)."""
    inputs, outputs = list(inputs), list(outputs)
    for i, out in enumerate(outputs):
        directory = Path(out.path).parent
        if directory.is_dir() and not os.access(directory, os.W_OK | os.X_OK):
            msg = f"cannot write {out.what} {out.path}: directory {directory} is not writable"
            raise OutputError(msg, parameter=out.parameter)
        for inp in inputs:
            if same_file(out.path, inp.path):
                msg = (
                    f"{out.what} {out.path} would overwrite {inp.what} {inp.path}: "
                    "they are the same file"
                )
                raise OutputError(msg, parameter=out.parameter)
            if inside(out.path, inp.path):
                msg = (
                    f"{out.what} {out.path} would be written inside {inp.what} {inp.path}, "
                    "a directory that is read"
                )
                raise OutputError(msg, parameter=out.parameter)
        for other in outputs[:i]:
            if same_file(out.path, other.path):
                msg = f"{out.what} {out.path} and {other.what} {other.path} would be the same file"
                raise OutputError(msg, parameter=out.parameter)
