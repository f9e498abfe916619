"""Pairing left and right images of unsynchronised cameras into stereo pairs, streaming.

Images pair by nearest stamp within a tolerance (half a frame period by default): with
both sides in stamp order, the two oldest waiting images pair when their stamps are that
close, and otherwise the older one can never pair and is dropped. A pair is emitted as
soon as its second image arrives, stamped with the left image's stamp.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator

import numpy as np

from flylog.sensors import StereoPair

MAX_PENDING = 8  # images waiting on a side whose partner stream is silent


class StereoPairing:
    """``add(side, stamp_ns, image)`` yields the pairs it completes; ``dropped`` counts
    images that found no partner (call :meth:`finish` at the end)."""

    def __init__(self, tolerance_ns: int) -> None:
        self.tolerance_ns = tolerance_ns
        self._pending: dict[str, deque[tuple[int, np.ndarray]]] = {
            "left": deque(),
            "right": deque(),
        }
        self.dropped = 0

    def add(self, side: str, stamp: int, image: np.ndarray) -> Iterator[StereoPair]:
        queue = self._pending[side]
        queue.append((stamp, image))
        left, right = self._pending["left"], self._pending["right"]
        while left and right:
            dt = left[0][0] - right[0][0]
            if abs(dt) <= self.tolerance_ns:
                (ls, li), (_, ri) = left.popleft(), right.popleft()
                yield StereoPair(ls, li, ri)
            else:
                (left if dt < 0 else right).popleft()
                self.dropped += 1
        if len(queue) > MAX_PENDING:
            queue.popleft()
            self.dropped += 1

    def finish(self) -> None:
        self.dropped += len(self._pending["left"]) + len(self._pending["right"])
        for queue in self._pending.values():
            queue.clear()
