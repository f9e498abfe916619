"""One sweep at a time in a directory: ``DIR/.flylog-sweep.lock``, held with ``fcntl.flock``
for the sweep's life and holding its process id. Two sweeps into one directory would run
every cell twice and race on its outputs; the second is refused, naming the first's pid.

The kernel releases the lock when its holder ends, however it ends (SIGKILL included), so
a lock file left behind never blocks the next sweep: the file stays, the lock goes.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from flylog.errors import OutputError

LOCK_NAME = ".flylog-sweep.lock"


@contextmanager
def sweep_lock(directory: Path) -> Iterator[None]:
    """Hold ``directory``'s sweep lock within the block; OutputError if another process
    holds it."""
    import fcntl

    path = Path(directory) / LOCK_NAME
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "unknown"
            msg = (
                f"{directory} is in use by another sweep (pid {holder}): wait for it to "
                "end, or give another output directory"
            )
            raise OutputError(msg, parameter="output") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
        yield
    finally:
        os.close(fd)  # releases the lock
