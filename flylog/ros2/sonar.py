"""``sensor_msgs/msg/Range`` readings of a ring of sonars → flylog's SonarReading cycles.

Each Range topic is one sonar, mounted where ``/tf_static`` puts its frame in base_link.
A range of ±inf or NaN, or outside [min_range, max_range], is no echo (REP 117). Readings
are gathered into one cycle by time: a cycle opens with a reading and closes when every
sonar has reported, when a sonar reports again, or when a reading comes more than the
window after the opening one; it is stamped with its earliest reading.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from flylog.errors import LogError
from flylog.ros2.frames import frame_name, stamp_ns
from flylog.sensors import SonarReading

# How much the sonars of one ring may differ in cone and maximum range (rad, m): a
# SonarReading has one cone and one maximum for the ring.
RING_TOLERANCE = 1e-6


def echo(msg: Any) -> float:
    """The range of a Range message in metres, NaN for no echo (REP 117)."""
    r = np.float32(msg.range)
    if not math.isfinite(r) or r < np.float32(msg.min_range) or r > np.float32(msg.max_range):
        return math.nan
    return float(r)


class SonarRing:
    """Gathers the Range messages of ``topics`` into cycles (``window_ns`` wide)."""

    def __init__(self, topics: Sequence[str], mounts: np.ndarray, window_ns: int) -> None:
        self._index = {t: i for i, t in enumerate(topics)}
        self._mounts = mounts  # (n, 3) x, y, yaw in base_link
        self._window_ns = window_ns
        self._ranges = np.full(len(topics), np.nan)
        self._reported = np.zeros(len(topics), dtype=bool)
        self._opened_ns: int | None = None
        self._cone: float | None = None
        self._max_range: float | None = None
        self.where = ""  # the bag, for error messages

    def _ring_values(self, topic: str, msg: Any) -> None:
        cone, reach = float(np.float32(msg.field_of_view)), float(np.float32(msg.max_range))
        if self._cone is None or self._max_range is None:
            self._cone, self._max_range = cone, reach
        elif (
            abs(cone - self._cone) > RING_TOLERANCE or abs(reach - self._max_range) > RING_TOLERANCE
        ):
            msg_ = (
                f"{self.where}: {topic} has a {cone} rad cone and {reach} m reach, other "
                f"sonars {self._cone} rad and {self._max_range} m; flylog's sonar ring needs "
                f"one cone and one reach"
            )
            raise LogError(msg_)

    def add(self, topic: str, msg: Any) -> Iterator[SonarReading]:
        """Take one Range message; yield the cycles it closes (at most two)."""
        i = self._index[topic]
        t = stamp_ns(msg.header)
        self._ring_values(topic, msg)
        if self._opened_ns is not None and (
            self._reported[i] or t - self._opened_ns > self._window_ns
        ):
            yield self._close()
        if self._opened_ns is None:
            self._opened_ns = t
        self._opened_ns = min(self._opened_ns, t)
        self._ranges[i] = echo(msg)
        self._reported[i] = True
        if self._reported.all():
            yield self._close()

    def finish(self) -> Iterator[SonarReading]:
        """The cycle still open at the end of the bag, if any."""
        if self._opened_ns is not None:
            yield self._close()

    def _close(self) -> SonarReading:
        assert self._opened_ns is not None and self._cone is not None
        assert self._max_range is not None
        reading = SonarReading(
            self._opened_ns, self._ranges.copy(), self._mounts, self._cone, self._max_range
        )
        self._ranges[:] = np.nan
        self._reported[:] = False
        self._opened_ns = None
        return reading


def frame_of(msg: Any) -> str:
    return frame_name(msg.header.frame_id)
