"""The first run's numba compilations, shown as they happen.

flylog's kernels are compiled on their first call and cached on disk (``cache=True``): a
command's first run on a machine spends most of its first minute compiling (the first
replay of a fixture log: see ``COLD_START``), which without a word looks like a hang. numba
announces each compilation (not a load from its cache) as a ``numba:compile`` event
(numba.core.event); a listener prints one line at the first and counts them on the bar.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from rich.console import Console

# The first `flylog replay` of fixtures/logs/corridor.mcap with an empty numba cache
# (NUMBA_CACHE_DIR): 38 s of CPU, 107 s of wall time on 2 cores shared with other jobs (load
# average 7.5).
COLD_START = "about a minute"


class _Listener:
    """Counts top-level compilations (those a kernel's own calls start are inside them)."""

    def __init__(self, console: Console, describe: Callable[[str], None] | None) -> None:
        self.console = console
        self.describe = describe
        self.depth = 0
        self.count = 0

    def notify(self, event: Any) -> None:
        if event.is_start:
            self.depth += 1
            if self.depth > 1:
                return
            if self.count == 0:
                self.console.print(
                    f"compiling flylog's numba kernels, first run only ({COLD_START}; "
                    "cached after that)…",
                    soft_wrap=True,
                )
            self.count += 1
            if self.describe is not None:
                name = getattr(event.data["dispatcher"], "__name__", "kernel")
                self.describe(f"compiling kernels, first run only: {self.count} ({name})")
        elif event.is_end:
            self.depth = max(0, self.depth - 1)
            if self.depth == 0 and self.describe is not None:
                self.describe("")


@contextmanager
def compiles_shown(
    console: Console, describe: Callable[[str], None] | None = None
) -> Iterator[None]:
    """Within the block, the first numba compilation prints a line on ``console`` and each
    one is passed to ``describe`` as a note ("" once it is done)."""
    from numba.core import event

    listener = _Listener(console, describe)

    class _Forward(event.Listener):
        def on_start(self, ev: event.Event) -> None:
            listener.notify(ev)

        def on_end(self, ev: event.Event) -> None:
            listener.notify(ev)

    with event.install_listener("numba:compile", _Forward()):
        yield
