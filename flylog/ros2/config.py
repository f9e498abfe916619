"""How a ROS 2 bag is read for replay: topic roles, stereo pairing, sonar cycles."""

from __future__ import annotations

from dataclasses import dataclass

from flylog.config import param


@dataclass(frozen=True)
class BagOptions:
    topics: tuple[str, ...] = param(
        (),
        help="role=topic overrides of the topic discovery (roles left, right, odom, sonar; "
        "sonar=/r0,/r1 names several)",
    )
    pair_tolerance: float = param(
        0.5,
        help="left and right images pair when their stamps are at most this many frame "
        "periods apart (nearest stamp; 0.5 pairs every image of two cameras running at the "
        "same rate, however out of phase)",
        unit="frame periods",
        min=0.0,
        max=1.0,
    )
    sonar_window: float = param(
        0.05,
        help="Range readings stamped within this time of a cycle's first reading form one "
        "sonar cycle (half the period of a 10 Hz ring)",
        unit="s",
        min=0.0,
    )
