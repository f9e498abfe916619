"""Reading ahead in a background thread, so that decompressing the next chunks of a log
overlaps with the work done on the messages already read.

The costly parts of reading (file reads, lz4/zstd decompression, CRC checks) release the
GIL, so on two cores they run beside the engine's compiled kernels, which release it too.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Iterator
from typing import TypeVar

T = TypeVar("T")

_DONE = object()
_POLL_S = 0.05  # how often a blocked producer checks whether the consumer has gone away


def read_ahead(items: Iterator[T], depth: int) -> Iterator[T]:
    """The items of ``items``, in order, produced up to ``depth`` ahead by a background
    thread (bounded memory: at most ``depth`` items wait). An exception raised by ``items``
    is raised here, at the point in the sequence where it happened. Closing this generator
    (or dropping it) stops the thread and closes ``items``."""
    if depth < 1:
        msg = f"read-ahead depth must be at least 1, got {depth}"
        raise ValueError(msg)
    ready: queue.Queue[tuple[bool, object]] = queue.Queue(maxsize=depth)
    stop = threading.Event()

    def put(entry: tuple[bool, object]) -> bool:
        while not stop.is_set():
            try:
                ready.put(entry, timeout=_POLL_S)
                return True
            except queue.Full:
                continue
        return False

    def produce() -> None:
        try:
            for item in items:
                if not put((True, item)):
                    return
            put((True, _DONE))
        except BaseException as exc:  # handed to the consumer, raised there
            put((False, exc))
        finally:
            close = getattr(items, "close", None)
            if close is not None:
                close()

    thread = threading.Thread(target=produce, name="flylog-read-ahead", daemon=True)
    thread.start()
    try:
        while True:
            ok, value = ready.get()
            if not ok:
                assert isinstance(value, BaseException)
                raise value
            if value is _DONE:
                return
            yield value  # type: ignore[misc]
    finally:
        stop.set()
        thread.join()
