"""The one door for a command's inputs: every file flylog opens for reading is opened (or
its path handed to a third-party reader) through this module, which registers it with the
running command's :class:`Inputs`; the atomic writer (:mod:`flylog.io.atomic`) asks that
registry before it creates or publishes an output, and refuses one that would replace an
input or be written inside an input directory (a rosbag2 bag).

The registry of the running command is held in a context variable, set by :func:`reading`
around a command (the command line does it for every command, ``flylog.cli.common``):

- a context variable, not a module-level object: each command (and each test calling one
  in the same process) has its own registry, dropped when it ends, and the library holds no
  state between calls;
- not an argument passed down: every reader and every writer would have to take it and
  pass it on (about thirty reading sites, a dozen writers), and a reader that is not given
  it could not register, so passing it would only move the place where a command can
  forget. Here a reader cannot forget: ``tests/io/test_inputs.py`` fails for a file read in
  the library anywhere else than through this module.

A thread started by flylog that reads files runs in a copy of its starter's context
(:mod:`flylog.io.readahead`), so its reads register with the same command. Outside a
command (a library call without :func:`reading`) nothing is registered and outputs are
checked only against what exists (:func:`flylog.io.atomic.refuse_to_replace`).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from flylog.errors import LogError


@dataclass(frozen=True)
class Input:
    """A file or directory a command reads: as given, resolved, and its identity."""

    path: Path
    what: str  # "the left image", "the sensor log", ...
    resolved: str  # symbolic links followed, ``..`` removed
    identity: tuple[int, int] | None  # (device, inode), None if it could not be examined
    directory: bool  # a directory read as a whole: nothing may be written inside it


class Inputs:
    """The inputs one command has read so far (safe to add to from several threads)."""

    def __init__(self) -> None:
        self._by_given: dict[tuple[str, bool], Input] = {}
        self._lock = threading.Lock()

    def add(self, path: str | os.PathLike[str], what: str, *, directory: bool = False) -> None:
        key = (os.fspath(path), directory)
        if key in self._by_given:  # a log is opened once per pass over it: cheap the 2nd time
            return
        try:
            st = os.stat(path)
            identity: tuple[int, int] | None = (st.st_dev, st.st_ino)
        except OSError:
            identity = None
        found = Input(Path(path), what, os.path.realpath(path), identity, directory)
        with self._lock:
            self._by_given.setdefault(key, found)

    def __iter__(self) -> Iterator[Input]:
        with self._lock:
            return iter(list(self._by_given.values()))

    def overwritten_by(self, output: str | os.PathLike[str]) -> tuple[Input, bool] | None:
        """The input that writing ``output`` would replace (``(input, False)``) or write
        inside (``(input, True)``), else None."""
        resolved = os.path.realpath(output)
        try:
            st = os.stat(output)
            identity: tuple[int, int] | None = (st.st_dev, st.st_ino)
        except OSError:
            identity = None
        for found in self:
            if (identity is not None and identity == found.identity) or (
                resolved == found.resolved
            ):
                return found, False
            if found.directory and Path(found.resolved) in Path(resolved).parents:
                return found, True
        return None


_COMMAND_INPUTS: ContextVar[Inputs | None] = ContextVar("flylog_command_inputs", default=None)


@contextmanager
def reading() -> Iterator[Inputs]:
    """Within the block (one command), every input opened through this module is registered
    with the yielded registry, which the atomic writer checks its outputs against."""
    inputs = Inputs()
    token = _COMMAND_INPUTS.set(inputs)
    try:
        yield inputs
    finally:
        _COMMAND_INPUTS.reset(token)


def command_inputs() -> Inputs | None:
    """The registry of the running command (None outside one)."""
    return _COMMAND_INPUTS.get()


def input_path(path: str | os.PathLike[str], what: str, *, directory: bool = False) -> Path:
    """Register ``path`` as an input (``directory``: a directory read as a whole, such as a
    rosbag2 bag, inside which nothing may be written) and return it, for a reader that
    takes a path (OpenCV, pyarrow, rosbags)."""
    inputs = _COMMAND_INPUTS.get()
    if inputs is not None:
        inputs.add(path, what, directory=directory)
    return Path(path)


def open_input(path: str | os.PathLike[str], what: str) -> BinaryIO:
    """``open(path, "rb")``, the file registered as an input."""
    return input_path(path, what).open("rb")


def read_input_bytes(path: str | os.PathLike[str], what: str) -> bytes:
    """The bytes of ``path``, registered as an input."""
    return input_path(path, what).read_bytes()


def read_input_text(path: str | os.PathLike[str], what: str) -> str:
    """The UTF-8 text of ``path``, registered as an input; LogError naming the file and the
    first byte that is not UTF-8 (a binary file, another encoding)."""
    data = read_input_bytes(path, what)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        msg = (
            f"{path}: {what} is not UTF-8 text (byte 0x{data[exc.start]:02x} at offset "
            f"{exc.start}); give the file as the dataset or tool wrote it"
        )
        raise LogError(msg) from None
