"""The fly engine's configuration: one frozen dataclass, every default written once."""

from __future__ import annotations

import enum
from dataclasses import dataclass

from flylog.config import param
from flylog.errors import ConfigError


class Backend(enum.Enum):
    """Which implementation of the hot kernels the engine runs (results are identical)."""

    NUMBA = "numba"
    NUMPY = "numpy"


class Gradient(enum.Enum):
    """What G, the fitness numerator, measures of the left image's 3×3 Sobel."""

    NORM = "norm"  # sqrt of the gradient norm, sqrt((Σ_c gx² + gy²)^½) (paper §2.1.1)
    # sqrt((Σ_c gx²)^½): the horizontal derivative alone, the only one a horizontal disparity
    # is measured along (a horizontal edge matches at every depth: the aperture problem).
    HORIZONTAL = "horizontal"


class Photometric(enum.Enum):
    """What the engine does to a stereo pair before scoring flies on it
    (flylog.fly.photometric)."""

    NONE = "none"  # the images as they come (the paper's)
    # both images smoothed by a Gaussian that grows with their noise, and the right image's
    # grey-level mean and standard deviation matched to the left's
    MATCHED = "matched"


class Similarity(enum.Enum):
    """How the fitness compares the fly's two projections (flylog.fly.fitness_terms)."""

    ZSSD = "zssd"  # zero-mean SSD (paper §2.1.1): removes an offset between the cameras
    ZNCC = "zncc"  # zero-mean normalised cross-correlation: removes a gain and an offset
    # zero-mean SSD with the right patch scaled to the left one's contrast, 2·varL·(1 − ZNCC):
    # removes a gain and an offset of the right camera
    GAIN_ZSSD = "gain_zssd"
    # 1 − ZNCC weighted by the left patch's contrast σL, 2·4·σL·(1 − ZNCC): removes a gain and
    # an offset of the right camera
    CONTRAST_ZNCC = "contrast_zncc"
    SAD = "sad"  # sum of absolute differences, (Σ|d|)²/(n·C): removes nothing

    @property
    def gain_invariant(self) -> bool:
        """Whether a gain of the right camera leaves the measure unchanged."""
        return self in (Similarity.ZNCC, Similarity.GAIN_ZSSD, Similarity.CONTRAST_ZNCC)


@dataclass(frozen=True)
class EngineConfig:
    """The fly algorithm (paper §2.1, §2.2, §3.2, §3.4); each feature can be switched off."""

    flies: int = param(5000, help="population size", min=16, max=10_000_000)
    d_min: float = param(0.5, help="nearest depth searched (initialisation)", unit="m", min=0.01)
    d_max: float = param(20.0, help="farthest depth searched (initialisation)", unit="m")
    window: int = param(
        7, help="side of the square fitness neighbourhood (odd)", unit="px", min=3, max=31
    )
    gradient: Gradient = param(
        Gradient.HORIZONTAL,
        help="fitness numerator G: sqrt of the Sobel gradient norm (norm, the paper's) or of "
        "|gx| alone (horizontal: G = 0 on horizontal edges, which carry no disparity)",
    )
    photometric: Photometric = param(
        Photometric.MATCHED,
        help="before scoring flies on a pair: matched (smooth both images by a Gaussian of "
        "σ = 0.5·(noise − 1) px, at most 2 px, the noise estimated in the images, then match "
        "the right image's mean and standard deviation to the left's) or none (the images as "
        "they come, the paper's). The motorcycle pair with zssd as it is / right 25 % "
        "brighter / noise σ 8 / both: matched 0.995 / 0.996 / 0.966 / 0.948, none 0.980 / "
        "0.699 / 0.486 / 0.217 (docs/engine.md)",
    )
    similarity: Similarity = param(
        Similarity.ZSSD,
        help="how the two projections are compared: zssd (zero-mean SSD, the paper's), "
        "zncc (zero-mean normalised cross-correlation, G / (guard + 32·(1 − ZNCC)) per "
        "pixel and channel), gain_zssd (zero-mean SSD with the right patch scaled to the "
        "left one's contrast σL, 2·σL²·(1 − ZNCC)), contrast_zncc (8·σL·(1 − ZNCC)) or sad "
        "(sum of absolute differences, (Σ|d|)²/(n·C), no vector kernel); zncc, gain_zssd and "
        "contrast_zncc are unchanged by a gain and an offset of the right camera. At equal "
        "compute with SGBM, sub-pixel, on the real motorcycle pair with the right image 25 % "
        "brighter and noise σ 5, the better half of the flies within 2 px: contrast_zncc "
        "0.97, zncc 0.95, gain_zssd 0.87, zssd 0.36; on the simulated corridor at 320×240 "
        "F 0.88, 0.80, 0.88, 0.88: docs/engine.md",
    )
    subpixel: bool = param(
        True,
        help="sample the right window at the fly's exact right projection (linear "
        "interpolation along the row, 1/256 px steps) instead of the nearest pixel: corridor "
        "at 320×240 and equal compute per frame F 0.88 against 0.69 (SGBM 0.80), the "
        "motorcycle pair at SGBM's wall time 0.99 of the better half within 2 px against "
        "0.97 (docs/engine.md)",
    )
    guard: float = param(
        1.0,
        help="added to the zero-mean SSD per pixel and channel, so a perfect match stays finite",
        unit="grey level²",
        min=1e-6,
    )
    elite_fraction: float = param(
        0.5, help="fraction of the population kept by elitist selection", min=0.01, max=0.99
    )
    sharing: bool = param(True, help="2-D sharing in the left image")
    sharing_coefficient: float = param(
        0.1,
        help="K: fitness lowered by K·n·(median fitness), n = neighbours within R px",
        min=0.0,
    )
    mutation_scale: float = param(
        1.0, help="σ of the image-position mutation, in units of the sharing radius R", min=0.0
    )
    disparity_mutation_scale: float = param(
        0.5, help="σ of the disparity (inverse-depth) mutation, in units of R", min=0.0
    )
    crossover2: bool = param(True, help="two-parent barycentric crossover")
    crossover2_rate: float = param(
        0.1, help="share of offspring made by two-parent crossover", min=0.0, max=1.0
    )
    crossover3: bool = param(True, help="three-parent barycentric crossover")
    crossover3_rate: float = param(
        0.1, help="share of offspring made by three-parent crossover", min=0.0, max=1.0
    )
    immigration_fraction: float = param(
        0.02,
        help="fraction of the population replaced by random flies each generation",
        min=0.0,
        max=0.5,
    )
    sonar_fitness: bool = param(True, help="multiply the fitness of sonar-confirmed flies")
    sonar_bonus: float = param(
        0.5, help="B: a fly matching a fired sonar has fitness × (1 + B)", min=0.0
    )
    sonar_tolerance: float = param(
        0.1, help="how far a fly's distance may be from the sonar range", unit="m", min=0.0
    )
    sonar_immigration: bool = param(True, help="place some immigrants on fired sonars' arcs")
    sonar_immigration_fraction: float = param(
        0.5, help="share of the immigrants placed on sonar arcs", min=0.0, max=1.0
    )
    scouting: bool = param(
        True,
        help="while turning, place some immigrants where new content enters the view, each at "
        "the best of scout_candidates depths (flylog.fly.scouts; not the paper's: on turn it "
        "takes the median detection latency from 1.5 to 1.0 frame period; closed loop reached "
        "the goal on 2/5 corridor seeds with it, 3/5 without, no collision with it)",
    )
    scout_fraction: float = param(
        0.5,
        help="share of the uniform immigrants (those the sonar does not place) that scout "
        "while turning",
        min=0.0,
        max=1.0,
    )
    scout_candidates: int = param(
        16, help="K: depths tried per scout, each a fitness evaluation", min=1, max=256
    )
    scout_strip_frames: int = param(
        2,
        help="the scouted strip is what the turn of this many image intervals brought in",
        unit="frames",
        min=1,
        max=100,
    )
    scout_min_shift: float = param(
        0.5,
        help="scout only while the turn moves the image edge at least this much per frame "
        "(over the strip's frames)",
        unit="px",
        min=0.0,
    )
    proprioception: bool = param(True, help="move the flies by the inverse odometry increment")
    backend: Backend = param(Backend.NUMBA, help="kernel implementation (numba or numpy)")

    def __post_init__(self) -> None:
        if self.window % 2 != 1:
            msg = f"window must be odd, got {self.window}"
            raise ConfigError(msg)
        if not self.d_min < self.d_max:
            msg = f"d_min ({self.d_min} m) must be below d_max ({self.d_max} m)"
            raise ConfigError(msg)
        if self.crossover2_rate + self.crossover3_rate > 1.0:
            msg = "crossover2_rate + crossover3_rate must not exceed 1"
            raise ConfigError(msg)

    @property
    def survivors(self) -> int:
        """How many flies elitist selection keeps."""
        return max(1, min(self.flies - 1, round(self.elite_fraction * self.flies)))

    @property
    def max_evaluations(self) -> int:
        """The most fitness evaluations one generation can make: every fly (new images make
        all stale), the newcomers, and K candidates for each immigrant that may scout."""
        return self.flies + self.max_later_evaluations

    @property
    def max_later_evaluations(self) -> int:
        """The most fitness evaluations a generation that follows another on the same
        images can make: no fly is stale then, only the newcomers and the scouts'
        candidates are scored."""
        scouts = self.immigrants * self.scout_candidates if self.scouting else 0
        return (self.flies - self.survivors) + scouts

    @property
    def immigrants(self) -> int:
        """How many random flies enter each generation."""
        return min(self.flies - self.survivors, round(self.immigration_fraction * self.flies))
