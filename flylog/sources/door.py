"""The one door to an input: its format (a flylog log, an imported dataset's log, a ROS 2
bag) is decided here, once, and the :class:`Input` it opens gives what each command takes
from it: the replay source (``flylog replay``), the ground truth (``flylog metrics``), the
trajectories (``flylog export --tum``) and whether it is scored against truth images."""

from __future__ import annotations

import enum
import os
from dataclasses import dataclass
from pathlib import Path

from flylog.errors import LogError
from flylog.io import contract, open_log
from flylog.io.reader import LogReader
from flylog.ros2.config import BagOptions
from flylog.ros2.detect import is_bag
from flylog.sources.bag import bag_trajectories, bag_truth
from flylog.sources.stream import ReplaySource, bag_source, log_source
from flylog.sources.trajectory import Trajectory
from flylog.sources.truth import SCENE_ATTACHMENT, LogTruth, log_trajectories, log_truth

IMAGE_TRUTH = (contract.TRUTH_DISPARITY, contract.TRUTH_DEPTH)


class InputFormat(enum.Enum):
    """What an input file is."""

    LOG = "flylog log"  # simulated, or a run file
    DATASET = "imported dataset"  # a flylog log that ``flylog import`` wrote
    BAG = "ROS 2 bag"


@dataclass(frozen=True)
class Input:
    """An input whose format is known; its flylog log opened once (None for a bag)."""

    path: Path
    format: InputFormat
    reader: LogReader | None

    def replay_source(
        self,
        *,
        goal: tuple[float, float] | None,
        bag: BagOptions | None = None,
        row_period_us: float | None = None,
    ) -> ReplaySource:
        """The inputs and the paired record stream replay runs on; a flylog log must give
        a goal (in its metadata or ``goal``), a bag's planner is off without one. The
        cameras' row period is ``row_period_us`` when given, whatever the input; else a
        log's flylog.shutter record's, 0 (a global shutter) without one."""
        if self.reader is None:
            return bag_source(
                self.path, goal=goal, bag=bag or BagOptions(), row_period_us=row_period_us
            )
        return log_source(self.reader, goal=goal, row_period_us=row_period_us)

    def truth(self) -> LogTruth:
        """Scene, rig and the true and odometric trajectories (LogError naming what is
        missing)."""
        return bag_truth(self.path) if self.reader is None else log_truth(self.reader)

    def trajectories(self) -> dict[str, Trajectory]:
        """name (true, odom, planned) → trajectory, for those the input holds."""
        if self.reader is None:
            return bag_trajectories(self.path)
        return log_trajectories(self.reader)

    def image_truth(self) -> bool:
        """The input carries ground-truth disparity or depth images and no scene to render.
        An imported dataset's log without them (a KITTI odometry or EuRoC sequence: true
        poses only) cannot be scored: :class:`LogError` saying what it holds. A ROS 2 bag
        carries no such images."""
        if self.reader is None:
            return False
        topics = self.reader.topics()
        images = any(t in topics for t in IMAGE_TRUTH)
        if not images and self.format is InputFormat.DATASET:
            held = ", ".join(f"{t} ({topics[t].count})" for t in sorted(topics))
            msg = (
                f"{self.path} is an imported dataset's log without {contract.TRUTH_DISPARITY} "
                f"or {contract.TRUTH_DEPTH}; it holds {held}. flylog metrics scores imported "
                "logs against ground-truth disparity or depth images only (the run's "
                f"trajectory is scored on simulated logs, whose {contract.ODOM} and scene an "
                "imported log lacks)"
            )
            raise LogError(msg)
        attachments = self.reader.attachments()
        return images and not any(a.name == SCENE_ATTACHMENT for a in attachments)


def input_at(path: str | os.PathLike[str]) -> Input:
    """The input at ``path``: a ROS 2 bag (a rosbag2 directory or an MCAP file of the
    ``ros2`` profile), else a flylog log, opened (LogError when it cannot be read)."""
    if is_bag(path):
        return Input(Path(path), InputFormat.BAG, None)
    reader = open_log(path)
    dataset = contract.DATASET_METADATA in reader.metadata()
    return Input(Path(path), InputFormat.DATASET if dataset else InputFormat.LOG, reader)


def read_truth(path: str | os.PathLike[str]) -> LogTruth:
    """The ground truth of the input at ``path``: :meth:`Input.truth`."""
    return input_at(path).truth()
