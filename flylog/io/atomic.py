"""Outputs that appear whole or not at all: written to a temporary file beside the target,
made durable (fsync) and renamed onto it only when complete. Every output of flylog is
written here, so this is where an output is refused that would replace what it must not
(:func:`refuse_to_replace`): an input of the running command (:mod:`flylog.io.inputs`), a
path inside an input directory, or anything that is not a regular file (a FIFO, a device
such as /dev/null, a socket, a directory), which a rename would replace by a file.

The temporary file is ``.NAME.PID-TOKEN.part``: the writer's process id is in its name, so
that a later writer of the same output removes the parts of writers that died without
cleaning up (a SIGKILL, a power cut) and leaves alone those of writers still running. A
NAME too long for that to fit the file system's limit on a name (255 bytes on Linux and
macOS) is cut and followed by a digest of the whole name. The file is created with mode
0666 as ``open()`` does, so the process's umask gives the output its permissions without
the umask ever being read or changed (it is process-wide, and replay writes from several
threads).

Outputs that belong together (the logs of one ``flylog import`` of many scenes) are
published together by a :class:`Batch`: each is written in full to its temporary file and
none is renamed before the last is complete, so a failure or a stop signal leaves every file
that was there as it was.
"""

from __future__ import annotations

import errno
import hashlib
import os
import re
import secrets
import signal
import stat
import threading
from pathlib import Path
from types import TracebackType

from flylog.errors import OutputError
from flylog.io.inputs import command_inputs

PART_SUFFIX = ".part"
_FLAGS = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
_TOKEN_BYTES = 4
# The longest file name Linux and macOS file systems take, in bytes (NAME_MAX).
NAME_MAX = 255
# What ".NAME" is followed by: "." + a process id (at most 7 digits on Linux, whose pid_max
# is at most 2**22) + "-" + the token + ".part"; and the digest of a cut name.
_PART_TAIL = 1 + 7 + 1 + 2 * _TOKEN_BYTES + len(PART_SUFFIX)
_DIGEST_CHARS = 16


def part_stem(path: Path) -> str:
    """ ".NAME", or for a name too long to fit with the tail, its start and a digest of the
    whole: the same for every writer of ``path``, so that stale parts are found."""
    stem = f".{path.name}"
    if len(os.fsencode(stem)) + _PART_TAIL <= NAME_MAX:
        return stem
    digest = hashlib.blake2b(os.fsencode(path.name), digest_size=_DIGEST_CHARS // 2).hexdigest()
    room = NAME_MAX - _PART_TAIL - 1 - len(digest)  # "~" + digest
    head = os.fsencode(stem)[:room].decode(errors="ignore")  # whole characters only
    return f"{head}~{digest}"


def _part_pattern(path: Path) -> re.Pattern[str]:
    stem = re.escape(part_stem(path))
    return re.compile(rf"{stem}\.(\d+)-[0-9a-f]{{{2 * _TOKEN_BYTES}}}\.part")


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
    return OutputError(f"cannot write {path}: {reason}", path=path)


_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISDIR, "a directory"),
)


def refuse_to_replace(path: Path) -> None:
    """OutputError if writing ``path`` would replace an input of the running command, write
    inside an input directory, or replace something that is not a regular file (a rename
    would turn a FIFO or a device node into a plain file)."""
    try:
        mode = os.stat(path).st_mode
    except OSError:  # absent (or not examinable: the writer says why when it fails)
        mode = None
    if mode is not None and not stat.S_ISREG(mode):
        kind = next((what for test, what in _KINDS if test(mode)), "not a regular file")
        msg = f"{path} is {kind}: flylog writes regular files only and never replaces one"
        raise OutputError(msg, path=path)
    inputs = command_inputs()
    found = None if inputs is None else inputs.overwritten_by(path)
    if found is not None:
        source, within = found
        if within:
            msg = (
                f"{path} would be written inside {source.what} {source.path}, a directory "
                "this command reads"
            )
        else:
            msg = f"{path} would overwrite {source.what} {source.path}, which this command reads"
        raise OutputError(msg, path=path)


def temporary_beside(path: Path) -> tuple[int, Path]:
    """(file descriptor, path) of a new temporary file in ``path``'s directory, after
    removing the stale ones of earlier writers of ``path``; OutputError for an output that
    must not be replaced (:func:`refuse_to_replace`)."""
    path = Path(path)
    if not path.parent.is_dir():
        msg = f"cannot write {path}: directory {path.parent} does not exist"
        raise OutputError(msg, path=path)
    refuse_to_replace(path)
    for stale in stale_parts(path):
        stale.unlink(missing_ok=True)
    stem = part_stem(path)
    while True:
        token = secrets.token_hex(_TOKEN_BYTES)
        tmp = path.parent / f"{stem}.{os.getpid()}-{token}{PART_SUFFIX}"
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


def _flush(tmp: Path) -> None:
    fd = os.open(tmp, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _rename(tmp: Path, path: Path) -> None:
    try:
        os.replace(tmp, path)
    except OSError as exc:
        raise _cannot_write(path, exc) from None


def publish(tmp: Path, path: Path, batch: Batch | None = None) -> None:
    """Flush ``tmp`` to the disk and rename it onto ``path``: after a crash, ``path`` holds
    the old file or the complete new one. With ``batch``, the rename waits for the batch's
    end (:class:`Batch`), which then owns ``tmp``. OutputError for an output that must not
    be replaced (:func:`refuse_to_replace`), checked again here: the command may have read
    the file since the temporary one was made."""
    path = Path(path)
    refuse_to_replace(path)
    _flush(tmp)
    if batch is not None:
        batch.add(tmp, path)
        return
    _rename(tmp, path)
    _fsync_directory(path.parent)


class Batch:
    """Outputs published together, in a ``with`` block: each writer given the batch leaves
    its complete temporary file with it, and at the block's end all are checked and then
    renamed onto their targets, none if the block failed or was stopped (its temporary files
    are removed). Stop signals wait while the renames run (in the main thread), so an
    interruption finds every output either all new or all as it was."""

    def __init__(self) -> None:
        self._staged: list[tuple[Path, Path]] = []

    def add(self, tmp: Path, path: Path) -> None:
        self._staged.append((Path(tmp), Path(path)))

    def __enter__(self) -> Batch:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        try:
            if exc_type is None:
                for _, path in self._staged:
                    refuse_to_replace(path)
                self._rename_all()
        finally:
            for tmp, _ in self._staged:
                tmp.unlink(missing_ok=True)
            self._staged.clear()

    def _rename_all(self) -> None:
        blocked = _STOP_SIGNALS if threading.current_thread() is threading.main_thread() else ()
        previous = signal.pthread_sigmask(signal.SIG_BLOCK, blocked) if blocked else None
        try:
            for tmp, path in self._staged:
                _rename(tmp, path)
            for directory in {path.parent for _, path in self._staged}:
                _fsync_directory(directory)
        finally:
            if previous is not None:  # a signal that came meanwhile is delivered now
                signal.pthread_sigmask(signal.SIG_SETMASK, previous)


_STOP_SIGNALS = (
    tuple(
        getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
    )
    if hasattr(signal, "pthread_sigmask")
    else ()
)


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
