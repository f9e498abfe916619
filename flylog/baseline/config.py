"""The conventional stereo baseline's configuration: one frozen dataclass, every default once.

Kept apart from :mod:`flylog.baseline.sgbm` so that loading a replay configuration does not
import OpenCV.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from flylog.config import param
from flylog.errors import ConfigError


class SgbmMode(enum.Enum):
    """OpenCV's StereoSGBM modes (``cv2.STEREO_SGBM_MODE_*``)."""

    SGBM = "sgbm"  # 5 aggregation directions
    SGBM_3WAY = "sgbm-3way"  # 3 directions, the fastest
    HH = "hh"  # full 8-direction two-pass dynamic programming (memory: W·H·disparities)
    HH4 = "hh4"  # 4 directions


@dataclass(frozen=True)
class SgbmConfig:
    """OpenCV StereoSGBM on complete frames, and how its result becomes an obstacle cloud."""

    num_disparities: int = param(
        64,
        help="disparity search range (a multiple of 16), from 0 (from ⌊−doffs⌋ for a rig "
        "with doffs < 0); the nearest depth seen is about focal·baseline / "
        "(num_disparities + max(doffs, 0)) (0.94 m at 640×480 with the scenes' 500 px, "
        "0.12 m rig, doffs 0), and the leftmost columns of the left image, as many as the "
        "search's largest disparity, get no disparity",
        unit="px",
        min=16,
        max=1024,
    )
    block_size: int = param(5, help="side of the matched block (odd)", unit="px", min=1, max=31)
    p1_factor: int = param(
        8,
        help="P1 (penalty of a ±1 px disparity change) = p1_factor · channels · block_size², "
        "OpenCV's suggested scaling",
        min=0,
    )
    p2_factor: int = param(
        32,
        help="P2 (penalty of a larger disparity change) = p2_factor · channels · block_size²; "
        "must exceed p1_factor",
        min=1,
    )
    uniqueness_ratio: int = param(
        10,
        help="the best matching cost must beat the second best by this margin, else the "
        "pixel has no disparity",
        unit="%",
        min=0,
        max=100,
    )
    speckle_window_size: int = param(
        100,
        help="disparity blobs smaller than this are removed as speckle (0: no filtering)",
        unit="px",
        min=0,
    )
    speckle_range: int = param(
        2, help="largest disparity variation inside one blob", unit="px", min=0, max=64
    )
    disp12_max_diff: int = param(
        1,
        help="left-right consistency check: largest difference between the left and the "
        "right disparity maps (-1: no check)",
        unit="px",
        min=-1,
    )
    pre_filter_cap: int = param(
        63, help="clip of the x-derivative prefilter", unit="grey levels", min=1, max=63
    )
    mode: SgbmMode = param(SgbmMode.SGBM_3WAY, help="aggregation: sgbm, sgbm-3way, hh or hh4")
    grey: bool = param(
        True,
        help="match grey levels (RGB → grey first): measured 1.5× faster than RGB at "
        "640×480 with the same depth accuracy on the simulator's frames",
    )
    max_depth: float = param(
        20.0,
        help="farthest depth kept (the textured sky matches at disparity ≈ 0: infinitely far)",
        unit="m",
        min=0.1,
    )
    seconds_per_frame: float = param(
        0.027,
        help="virtual time one frame costs replay's clock (a configured number so runs stay "
        "deterministic): a whole SgbmEngine.step on 640×480 with these defaults, measured on "
        "the 2-core reference machine by tests/benchmarks/bench_baseline.py (median 27.3 ms "
        "over 15 frames, 26.6–31.2; StereoSGBM.compute alone 19.4 ms); scale it with "
        "W·H·num_disparities for other sizes",
        unit="s",
        min=1e-6,
    )

    def __post_init__(self) -> None:
        if self.num_disparities % 16 != 0:
            msg = f"num_disparities must be a multiple of 16, got {self.num_disparities}"
            raise ConfigError(msg)
        if self.block_size % 2 != 1:
            msg = f"block_size must be odd, got {self.block_size}"
            raise ConfigError(msg)
        if self.p2_factor <= self.p1_factor:
            msg = f"p2_factor ({self.p2_factor}) must exceed p1_factor ({self.p1_factor})"
            raise ConfigError(msg)

    @property
    def cost_ns(self) -> int:
        """The virtual time of one frame, ns (at least 1)."""
        return max(1, round(self.seconds_per_frame * 1e9))
