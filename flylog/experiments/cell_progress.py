"""Progress within an experiment's cell, in log seconds simulated and replayed: the cell's
simulations and replays each report through :func:`stage`, and the sum goes to the sink
the cell runs with (:func:`reporting`). In a pool's worker the sink is a small file that
the parent reads while it waits (:class:`FileSink`, :func:`read_progress`), so that a bar
moves during a 180 s closed loop instead of standing still until the cell ends."""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable, Iterator
from contextvars import ContextVar
from pathlib import Path

Sink = Callable[[float], None]

# The sink of the cell running in this context (None outside a cell): a context variable,
# so that the experiments' functions need no extra argument to report through it.
_METER: ContextVar[_Meter | None] = ContextVar("flylog_cell_meter", default=None)


class _Meter:
    """The log seconds of each stage so far; their sum never goes back, even when a stage
    ends early (a closed loop at its goal) or reports its end twice."""

    def __init__(self, sink: Sink) -> None:
        self._sink = sink
        self._parts: list[float] = []

    def stage(self, seconds: float | None) -> Callable[[float, float], None]:
        index = len(self._parts)
        self._parts.append(0.0)

        def update(done: float, total: float) -> None:
            if total <= 0:
                return
            part = (total if seconds is None else seconds) * min(1.0, done / total)
            self._parts[index] = max(self._parts[index], part)
            self._sink(sum(self._parts))

        return update


@contextlib.contextmanager
def reporting(sink: Sink) -> Iterator[None]:
    """Within the block, the stages of :func:`stage` report to ``sink``."""
    token = _METER.set(_Meter(sink))
    try:
        yield
    finally:
        _METER.reset(token)


def stage(seconds: float | None = None) -> Callable[[float, float], None] | None:
    """An ``on_progress(done, total)`` for a simulation or replay inside the running cell:
    ``done / total`` of ``seconds`` of log time (``None``: done and total are log seconds);
    None outside a cell."""
    meter = _METER.get()
    return None if meter is None else meter.stage(seconds)


class FileSink:
    """Writes the cell's log seconds to ``path`` at most every ``every`` seconds of wall
    time (a rename, so the reader never sees half a number)."""

    def __init__(self, path: Path, every: float = 0.5) -> None:
        self._path = path
        self._every = every
        self._last = -float("inf")

    def __call__(self, seconds: float) -> None:
        now = time.monotonic()
        if now - self._last < self._every:
            return
        self._last = now
        staging = self._path.with_suffix(".part")
        staging.write_text(repr(float(seconds)), encoding="ascii")
        os.replace(staging, self._path)


def read_progress(path: Path) -> float:
    """The log seconds a cell's :class:`FileSink` last wrote; 0 before its first write."""
    try:
        return float(path.read_text(encoding="ascii"))
    except (FileNotFoundError, ValueError):
        return 0.0
