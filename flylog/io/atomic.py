"""Outputs that appear whole or not at all: written to a temporary file beside the target,
made durable (fsync) and renamed onto it only when complete.

The temporary file is ``.NAME.PID-TOKEN.part``: the writer's process id is in its name, so
that a later writer of the same output removes the parts of writers that died without
cleaning up (a SIGKILL, a power cut) and leaves alone those of writers still running. It is
created with mode 0666 as ``open()`` does, so the process's umask gives the output its
permissions without the umask ever being read or changed (it is process-wide, and replay
writes from several threads).
"""

from __future__ import annotations

import errno
import os
import re
import secrets
from pathlib import Path

from flylog.errors import OutputError

PART_SUFFIX = ".part"
_FLAGS = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
_TOKEN_BYTES = 4


def _part_pattern(path: Path) -> re.Pattern[str]:
    return re.compile(rf"\.{re.escape(path.name)}\.(\d+)-[0-9a-f]{{{2 * _TOKEN_BYTES}}}\.part")


def _process_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def stale_parts(path: Path) -> list[Path]:
    """The temporary files beside ``path`` left by writers of ``path`` that are gone."""
    pattern = _part_pattern(path)
    try:
        names = os.listdir(path.parent)
    except OSError:
        return []
    stale = []
    for name in names:
        found = pattern.fullmatch(name)
        if found is not None and not _process_alive(int(found.group(1))):
            stale.append(path.parent / name)
    return stale


def _cannot_write(path: Path, exc: OSError) -> OutputError:
    reason = exc.strerror or str(exc)
    if exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        reason = f"directory {path.parent} is not writable ({reason})"
    return OutputError(f"cannot write {path}: {reason}")


def temporary_beside(path: Path) -> tuple[int, Path]:
    """(file descriptor, path) of a new temporary file in ``path``'s directory, after
    removing the stale ones of earlier writers of ``path``."""
    path = Path(path)
    if not path.parent.is_dir():
        msg = f"cannot write {path}: directory {path.parent} does not exist"
        raise OutputError(msg)
    for stale in stale_parts(path):
        stale.unlink(missing_ok=True)
    while True:
        token = secrets.token_hex(_TOKEN_BYTES)
        tmp = path.parent / f".{path.name}.{os.getpid()}-{token}{PART_SUFFIX}"
        try:
            return os.open(tmp, _FLAGS, 0o666), tmp
        except FileExistsError:
            continue
        except OSError as exc:
            raise _cannot_write(path, exc) from None


def _fsync_directory(directory: Path) -> None:
    """Make a rename in ``directory`` durable, where the platform allows it."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:  # e.g. Windows: directories cannot be opened
        return
    try:
        os.fsync(fd)
    except OSError:  # some file systems refuse fsync on a directory
        pass
    finally:
        os.close(fd)


def publish(tmp: Path, path: Path) -> None:
    """Flush ``tmp`` to the disk and rename it onto ``path``: after a crash, ``path`` holds
    the old file or the complete new one."""
    fd = os.open(tmp, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    try:
        os.replace(tmp, path)
    except OSError as exc:
        raise _cannot_write(path, exc) from None
    _fsync_directory(path.parent)


def write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    path = Path(path)
    fd, tmp = temporary_beside(path)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        publish(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_text(path: Path, text: str, encoding: str = "utf-8") -> None:
    """Write ``text`` to ``path`` atomically."""
    write_bytes(path, text.encode(encoding))
