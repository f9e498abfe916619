"""Telling a ROS 2 bag from a flylog log by its first bytes (MCAP header profile), without
importing the ROS 2 machinery: every command that takes a log asks."""

from __future__ import annotations

import os
from pathlib import Path

from mcap.reader import SeekingReader

from flylog.io.inputs import open_input

ROS2_PROFILE = "ros2"
ROS1_MAGIC = b"#ROSBAG"
MCAP_MAGIC = b"\x89MCAP"


def is_bag(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a ROS 2 bag (a rosbag2 directory, or an MCAP file with the
    ``ros2`` profile) rather than a flylog log; a ROS 1 bag counts (to be refused by name)."""
    path = Path(path)
    if path.is_dir():
        return True
    try:
        with open_input(path, "the log") as fh:
            head = fh.read(len(ROS1_MAGIC))
            if head == ROS1_MAGIC:
                return True
            if not head.startswith(MCAP_MAGIC):
                return False
            fh.seek(0)
            return SeekingReader(fh).get_header().profile == ROS2_PROFILE
    except Exception:  # unreadable: the flylog reader names the problem
        return False
