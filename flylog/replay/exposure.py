"""A cheap look at whether the two cameras of a log differ in exposure.

A similarity measure that is not gain-invariant (``zssd``, ``sad``), on images as they come
(``engine.photometric = "none"``), loses flies on their surfaces when the right camera's
gain differs from the left's: on the Middlebury motorcycle pair (5000 flies, 50 generations,
seeds 0 and 1) zssd's better half within 2 px is 0.980 as it is, 0.955 with the right image
10 % brighter, 0.932 at 15 % and 0.874 at 20 %.
:class:`ExposureWatch` compares the two images' contrasts, the standard deviation of their
grey levels on a sparse grid of pixels (every 8th row and column: 1200 pixels at 320×240),
a gain's measure that an offset between the cameras leaves alone; on that pair it reads
1.002, 1.049, 1.093, 1.133 and 1.170 for gains 1, 1.05, 1.1, 1.15 and 1.2. The median of
the last :data:`WINDOW` pairs it looks at (one in :data:`EVERY`; at the replay's end,
of those it looked at) beyond :data:`MAX_RATIO` either way raises one
:class:`ExposureWarning` for the replay.
"""

from __future__ import annotations

import math
import warnings
from collections import deque

import numpy as np

from flylog.fly.config import EngineConfig, Photometric

EVERY = 10  # look at one stereo pair in this many
WINDOW = 5  # the warning's ratio is the median of this many looks
STEP_PX = 8  # the grid's spacing, rows and columns
# A contrast ratio beyond this (or below its inverse) warns: zssd loses 0.025 of its
# motorcycle share at a gain of 1.1.
MAX_RATIO = 1.1


class ExposureWarning(UserWarning):
    """The two cameras differ in exposure and the measure is not gain-invariant."""


def contrast(image: np.ndarray) -> float:
    """The standard deviation of the grey levels (channels averaged) on the sparse grid."""
    grid = np.asarray(image[::STEP_PX, ::STEP_PX], dtype=np.float32)
    if grid.ndim == 3:
        grid = grid.mean(axis=2)
    return float(grid.std())


class ExposureWatch:
    """Looks at stereo pairs as a replay reads them and warns once (``look`` is a no-op for
    photometric matching or a gain-invariant measure, or once it has warned)."""

    def __init__(self, engine: EngineConfig, source: str) -> None:
        self.similarity = engine.similarity
        self.source = source
        self.done = engine.similarity.gain_invariant or engine.photometric is not Photometric.NONE
        self._seen = 0
        self._ratios: deque[float] = deque(maxlen=WINDOW)

    def look(self, left: np.ndarray, right: np.ndarray) -> None:
        if self.done:
            return
        self._seen += 1
        if (self._seen - 1) % EVERY:
            return
        cl, cr = contrast(left), contrast(right)
        if cl <= 0.0 or cr <= 0.0:
            return
        self._ratios.append(cr / cl)
        if len(self._ratios) == WINDOW:
            self._judge()

    def finish(self) -> None:
        """At the replay's end: judge the pairs looked at, if fewer than a window."""
        if not self.done and self._ratios:
            self._judge()

    def _judge(self) -> None:
        ratio = float(np.median(self._ratios))
        if abs(math.log(ratio)) > math.log(MAX_RATIO):
            self.done = True
            side = "higher" if ratio > 1.0 else "lower"
            msg = (
                f"{self.source}: the right camera's contrast is {abs(ratio - 1.0):.0%} {side} "
                f"than the left's (ratio {ratio:.2f}, the median of {len(self._ratios)} "
                f"pairs), and engine.similarity = {self.similarity.value} on images as they "
                'come (engine.photometric = "none") is not gain-invariant; '
                'engine.photometric = "matched" (the default) matches the cameras '
                "(docs/engine.md)"
            )
            warnings.warn(msg, ExposureWarning, stacklevel=3)
