"""Reading ahead in a background thread, so that decompressing the next chunks of a log
overlaps with the work done on the messages already read.

The costly parts of reading (file reads, lz4/zstd decompression, CRC checks) release the
GIL, so on two cores they run beside the engine's compiled kernels, which release it too.
"""

from __future__ import annotations

import contextvars
import os
import queue
import sys
import threading
from collections.abc import Iterator
from typing import TypeVar

T = TypeVar("T")

_DONE = object()
_POLL_S = 0.05  # how often a blocked producer checks whether the consumer has gone away

# Helper threads (this reader, replay's planner worker) run this much nicer than the thread
# that does the work they serve. Why: replay's engine runs generation after generation on the
# main thread, its wall time is that thread's; with three busy threads on two cores at equal
# niceness the scheduler shares the cores evenly and the main thread waits a third of the
# time, while the helpers, which have slack (bounded queues), can wait instead.
HELPER_NICENESS = 10


def lower_thread_priority(step: int | None = None) -> bool:
    """Make the *calling* thread ``step`` (default :data:`HELPER_NICENESS`) nicer (Linux,
    where each thread has its own nice value); whether it applied. Elsewhere nice is per
    process: nothing is done. Raising a nice value needs no privilege; the thread cannot
    lower it again, so call it only on a thread that does nothing else."""
    step = HELPER_NICENESS if step is None else step
    if not sys.platform.startswith("linux") or step <= 0:
        return False
    tid = threading.get_native_id()
    try:
        os.setpriority(os.PRIO_PROCESS, tid, os.getpriority(os.PRIO_PROCESS, tid) + step)
    except OSError:  # a sandbox that forbids it: run at the same priority
        return False
    return True


def read_ahead(
    items: Iterator[T], depth: int, *, niceness: int | None = None, batch: int | None = None
) -> Iterator[T]:
    """The items of ``items``, in order, produced up to ``depth`` ahead by a background
    thread (bounded memory: at most ``depth`` items wait) running ``niceness`` (default
    :data:`HELPER_NICENESS`) nicer than the caller (:func:`lower_thread_priority`), handed
    over ``batch`` at a time (default :func:`batch_size`). An exception raised by ``items``
    is raised here, at the point in the sequence where it happened. Closing this generator
    (or dropping it) stops the thread and closes ``items``."""
    if depth < 1:
        msg = f"read-ahead depth must be at least 1, got {depth}"
        raise ValueError(msg)
    size = batch_size(depth) if batch is None else max(1, min(batch, depth))
    ready: queue.Queue[tuple[bool, object]] = queue.Queue(maxsize=depth // size)
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
        lower_thread_priority(niceness)
        pending: list[T] = []
        try:
            for item in items:
                pending.append(item)
                if len(pending) == size:
                    if not put((True, pending)):
                        return
                    pending = []
            if pending and not put((True, pending)):
                return
            put((True, _DONE))
        except BaseException as exc:  # handed to the consumer, raised there, after the
            if not pending or put((True, pending)):  # items read before it
                put((False, exc))
        finally:
            close = getattr(items, "close", None)
            if close is not None:
                close()

    # in a copy of this context: the files it opens register with this command's inputs
    # (flylog.io.inputs)
    context = contextvars.copy_context()
    thread = threading.Thread(
        target=context.run, args=(produce,), name="flylog-read-ahead", daemon=True
    )
    thread.start()
    try:
        while True:
            ok, value = ready.get()
            if not ok:
                assert isinstance(value, BaseException)
                raise value
            if value is _DONE:
                return
            yield from value  # type: ignore[misc]
    finally:
        stop.set()
        thread.join()


# Items handed over at once: each hand-over is a lock, a wake-up of the other thread and a
# GIL hand-off, 5 400 of them on replay's 60 s reference log when handed over one by one.
MAX_BATCH = 8


def batch_size(depth: int) -> int:
    """Items handed over at once for a read-ahead ``depth``: up to :data:`MAX_BATCH`, and
    small enough that at least eight batches wait (one item at a time below depth 16)."""
    return max(1, min(MAX_BATCH, depth // 8))
