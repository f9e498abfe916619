"""What replay reads, whatever the input: a flylog log or a ROS 2 bag, as the same
ReplayInputs and the same stream of paired sensor records."""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

from flylog.geometry import Pose2D
from flylog.io.pairing import pair_stereo
from flylog.io.reader import open_log
from flylog.io.records import LogMessage
from flylog.replay.inputs import SENSOR_TOPICS, ReplayInputs, replay_inputs
from flylog.ros2 import is_bag
from flylog.ros2.config import BagOptions

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


def open_source(
    log: Path, *, goal: tuple[float, float] | None, bag: BagOptions | None = None
) -> ReplaySource:
    """The replay source of ``log``: a ROS 2 bag if it is one (options ``bag``), else a
    flylog log (which must give a goal, in its metadata or ``goal``)."""
    if not is_bag(log):
        reader = open_log(log)
        inputs = replay_inputs(reader, goal=goal)
        stream = pair_stereo(reader.messages(SENSOR_TOPICS, read_ahead=READ_AHEAD_MESSAGES))
        return ReplaySource(inputs, stream, inputs.has_planner, lambda: 0)
    from flylog.ros2.source import BagSource

    source = BagSource(log, bag or BagOptions())
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
    )
    return ReplaySource(inputs, source.records(), goal is not None, lambda: source.unpaired)
