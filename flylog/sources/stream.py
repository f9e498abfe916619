"""What replay reads, whatever the input: a flylog log (a simulated or an imported one) or a
ROS 2 bag, as the same ReplayInputs and the same stream of paired sensor records."""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

from flylog.geometry import Pose2D
from flylog.io.pairing import pair_stereo
from flylog.io.reader import LogReader
from flylog.io.records import LogMessage
from flylog.ros2.config import BagOptions
from flylog.ros2.source import BagSource
from flylog.sources.inputs import (
    SENSOR_TOPICS,
    ReplayInputs,
    given_row_period_ns,
    replay_inputs,
)

# Messages decoded ahead of the replay by a reading thread: about ten frames of stereo pairs
# (≈ 20 MB at 640×480), enough to hide a chunk's decompression behind the engine's work.
READ_AHEAD_MESSAGES = 64
PLANNER_OFF = "off"


class PlannerOffWarning(UserWarning):
    """The input gives no goal: replay runs the engine only, the planner off."""


@dataclass
class ReplaySource:
    """The inputs, the record stream and what the summary says of the input."""

    inputs: ReplayInputs
    records: Iterator[LogMessage]
    planner: bool  # False: no goal, the planner's outputs are not written
    _unpaired: Callable[[], int]

    @property
    def unpaired(self) -> int:
        """Images dropped for want of a partner (known once the stream has ended)."""
        return self._unpaired()


def log_source(
    reader: LogReader, *, goal: tuple[float, float] | None, row_period_us: float | None = None
) -> ReplaySource:
    """The replay source of a flylog log (which must give a goal, in its metadata or
    ``goal``); its row period is ``row_period_us`` when given, else its flylog.shutter
    record's (:func:`~flylog.sources.inputs.log_row_period_ns`)."""
    inputs = replay_inputs(reader, goal=goal, row_period_us=row_period_us)
    stream = pair_stereo(reader.messages(SENSOR_TOPICS, read_ahead=READ_AHEAD_MESSAGES))
    return ReplaySource(inputs, stream, inputs.has_planner, lambda: 0)


def bag_source(
    log: Path,
    *,
    goal: tuple[float, float] | None,
    bag: BagOptions,
    row_period_us: float | None = None,
) -> ReplaySource:
    """The replay source of a ROS 2 bag (options ``bag``): without a goal, given or in the
    bag, the planner is off (a warning says so). A bag's messages say nothing of a rolling
    shutter: its cameras read as a global shutter unless ``row_period_us`` is given
    (:func:`~flylog.sources.inputs.given_row_period_ns`)."""
    source = BagSource(log, bag)
    row_period_ns = (
        0.0
        if row_period_us is None
        else given_row_period_ns(row_period_us, source.rig, where=str(log))
    )
    start = source.start or Pose2D(0.0, 0.0, 0.0)
    goal = goal or source.goal
    if goal is None:
        msg = (
            f"{log} gives no goal: replaying the engine only (flies and the table), the "
            f"planner off (a goal given to replay turns it on)"
        )
        warnings.warn(msg, PlannerOffWarning, stacklevel=2)
    inputs = ReplayInputs(
        rig=source.rig,
        frame_period_ns=round(1e9 / source.rig.frame_rate),
        start=start,
        goal=goal or (start.x, start.y),
        start_ns=source.bag.start_ns,
        end_ns=source.bag.end_ns,
        has_sonar=bool(source.roles.sonars),
        has_planner=goal is not None,
        row_period_ns=row_period_ns,
    )
    return ReplaySource(inputs, source.records(), goal is not None, lambda: source.unpaired)
