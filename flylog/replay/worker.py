"""The queue of work the engine does not wait for (the planner's ticks and the snapshots),
and the writing of what it outputs: in order, on a worker thread or at once."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

from flylog.io.readahead import lower_thread_priority
from flylog.planner import Command, Status

Write = Callable[[str, int, Any], None]

# Planner jobs that may wait for the worker thread before the engine waits for them.
MAX_PENDING_JOBS = 8


@dataclass(frozen=True)
class Outputs:
    """What one job writes: messages, and for a planner tick its command and its row of the
    per-step table."""

    messages: list[tuple[str, int, Any]]
    command: Command | None = None
    row: dict[str, Any] | None = None


class OutputQueue:
    """Runs jobs and writes their outputs: ``write(topic, t_ns, message)`` each message,
    ``on_row`` each row.

    With ``threaded``, on a worker thread that runs nicer than the engine's (see
    :mod:`flylog.io.readahead`): the jobs run in the order asked for, each one's outputs are
    written as it ends, and ``write`` and ``on_row`` are called on that thread only; at most
    ``MAX_PENDING_JOBS`` wait. Without, each job runs and is written at once.
    """

    def __init__(
        self, write: Write, on_row: Callable[[dict[str, Any]], None] | None, *, threaded: bool
    ) -> None:
        self._write = write
        self._on_row = on_row
        self.command = Command(0.0, 0.0, Status.DRIVING)  # the newest written
        self._worker = (
            ThreadPoolExecutor(1, "flylog-planner", initializer=lower_thread_priority)
            if threaded
            else None
        )
        self._pending: deque[Future[None]] = deque()  # the worker's jobs, in the order asked for

    def submit(self, job: Callable[..., Outputs], *args: Any) -> None:
        """Run ``job(*args)`` and write its outputs. A job's error is raised here, at a later
        call, or by :meth:`flush`."""
        if self._worker is None:
            self._emit(job(*args))
            return
        self._pending.append(self._worker.submit(self._run_and_emit, job, args))
        while self._pending and (self._pending[0].done() or len(self._pending) > MAX_PENDING_JOBS):
            self._pending.popleft().result()

    def flush(self) -> None:
        """Wait until every output asked for is written."""
        while self._pending:
            self._pending.popleft().result()

    def close(self) -> None:
        """Stop the worker thread (after :meth:`flush`, or to abandon a run)."""
        if self._worker is not None:
            self._worker.shutdown(wait=True, cancel_futures=True)
            self._worker = None
            self._pending.clear()

    def _run_and_emit(self, job: Callable[..., Outputs], args: tuple[Any, ...]) -> None:
        self._emit(job(*args))

    def _emit(self, outputs: Outputs) -> None:
        for topic, t_ns, message in outputs.messages:
            self._write(topic, t_ns, message)
        if outputs.command is not None:
            self.command = outputs.command
        if outputs.row is not None and self._on_row is not None:
            self._on_row(outputs.row)
