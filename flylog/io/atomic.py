"""Outputs that appear whole or not at all: written to a temporary file beside the target,
renamed onto it only when complete. A killed writer leaves only a ``.NAME.*.part`` file."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from flylog.errors import LogError


def temporary_beside(path: Path) -> tuple[int, Path]:
    """(file descriptor, path) of a new temporary file in ``path``'s directory."""
    if not path.parent.is_dir():
        msg = f"cannot write {path}: directory {path.parent} does not exist"
        raise LogError(msg)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    return fd, Path(tmp)


def publish(tmp: Path, path: Path) -> None:
    """Give ``tmp`` the permissions ``open()`` would have (mkstemp makes it 0600) and rename
    it onto ``path``."""
    umask = os.umask(0)
    os.umask(umask)
    tmp.chmod(0o666 & ~umask)
    os.replace(tmp, path)
