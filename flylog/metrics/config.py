"""What ``flylog metrics`` may be told: thresholds of the definitions in ``flylog.metrics``."""

from __future__ import annotations

from dataclasses import dataclass

from flylog.config import param


@dataclass(frozen=True)
class MetricsConfig:
    """Thresholds of the fly, obstacle and trajectory metrics (see ``flylog.metrics``)."""

    tau: float = param(
        0.05,
        help="a fly is on a surface if its depth is within tau x the true depth",
        min=0.0,
        max=1.0,
    )
    cell_px: int = param(
        16, help="side of the square image cells recall is counted in", unit="px", min=1
    )
    cell_obstacle_share: float = param(
        0.5,
        help="a cell is visible obstacle if more than this share of its pixels see one",
        min=0.0,
        max=1.0,
    )
    min_visible_pixels: int = param(
        200, help="an obstacle is visible once it covers this many pixels", unit="px", min=1
    )
    min_detecting_flies: int = param(
        5, help="an obstacle is detected once this many obstacle flies lie on it", min=1
    )
    truth_width: int = param(
        160,
        help="the true view is rendered in k x k pixel blocks (the ray through each block's "
        "centre), k the largest divisor of the image's width and height that leaves it at "
        "least this wide: 640x480 in 4 x 4 blocks (1/16 of the rays); at or above the "
        "image's width, every pixel",
        unit="px",
        min=1,
    )
    rpe_delta: float = param(1.0, help="time step of the relative pose error", unit="s", min=0.001)
    goal_tolerance: float = param(
        0.2, help="the goal is reached within this distance of it", unit="m", min=0.0
    )
    max_time_gap: float = param(
        0.1,
        help="a snapshot farther than this from the true trajectory's ends is an error",
        unit="s",
        min=0.0,
    )
