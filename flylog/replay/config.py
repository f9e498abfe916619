"""The whole configuration of a replay (and of the closed loop): one TOML file, every default
written once. Top-level fields, then the ``[engine]``, ``[sgbm]``, ``[planner]``,
``[obstacles]`` and ``[heading]`` tables."""

from __future__ import annotations

import enum
from dataclasses import dataclass
from pathlib import Path

from flylog.baseline.config import SgbmConfig
from flylog.config import from_mapping, param, read_toml
from flylog.errors import ConfigError
from flylog.fly.config import EngineConfig
from flylog.fly.heading import HeadingConfig
from flylog.fly.obstacles import ObstacleFlies
from flylog.planner.config import PlannerConfig
from flylog.replay.clock import Mode


class Stereo(enum.Enum):
    """Which stereo engine feeds the planner and the ``/flies`` topic."""

    FLIES = "flies"  # the fly algorithm ([engine])
    SGBM = "sgbm"  # conventional OpenCV StereoSGBM on complete frames ([sgbm])


# The largest compute budget: 270 x the 3.7 M evaluations/s of the reference machine; above
# it, generations cost a nanosecond or less of log time and a replay never ends.
MAX_EVALS_PER_SECOND = 1e9


@dataclass(frozen=True)
class ReplayConfig:
    stereo: Stereo = param(
        Stereo.FLIES,
        help="flies: the fly algorithm ([engine]); sgbm: the conventional pipeline, OpenCV "
        "StereoSGBM ([sgbm]) on complete frames, frame-synchronous (sync mode, one step per "
        "frame costing sgbm.seconds_per_frame), no sonar fusion, engine.flies points per "
        "frame",
    )
    seed: int = param(0, help="seed of the engine's random generator", min=0)
    generations_per_frame: int = param(
        0,
        help="0: asynchronous, generations back to back on the newest data; N > 0: exactly N "
        "generations per stereo pair (the paper's experiments use 1)",
        min=0,
        max=10_000,
    )
    sync: bool = param(
        False,
        help="conventional pipeline (paper Table 1): only complete frames, results published "
        "when processing ends; runs generations_per_frame (at least 1) per frame (implied "
        "by stereo = sgbm)",
    )
    evals_per_second: float = param(
        3.7e6,
        help="virtual compute budget: each generation costs its fitness evaluations / this. "
        "3.7 M/s is what the engine achieves on the 2-core reference machine, all operators "
        "included (measured 3.71-3.88 M/s in replay's rhythm), the same machine that "
        "sgbm.seconds_per_frame describes, so flies and SGBM are compared at equal compute "
        "(about 80 generations of 5000 flies per 15 Hz frame)",
        unit="evaluations/s",
        min=1.0,
        max=MAX_EVALS_PER_SECOND,
    )
    snapshot_rate: float = param(
        5.0,
        help="how often flies, potential and path are written (at most 10 x the camera's "
        "frame rate)",
        unit="Hz",
        min=0.01,
        max=10_000.0,
    )
    overlay_flies: int = param(
        1000, help="best flies drawn on the left image in each snapshot", min=0, max=10_000_000
    )
    engine: EngineConfig = param(EngineConfig(), help="the fly engine")
    sgbm: SgbmConfig = param(SgbmConfig(), help="the conventional stereo baseline")
    planner: PlannerConfig = param(PlannerConfig(), help="the harmonic planner")
    obstacles: ObstacleFlies = param(ObstacleFlies(), help="obstacle flies")
    heading: HeadingConfig = param(
        HeadingConfig(), help="the visual heading correction of the odometry"
    )

    def __post_init__(self) -> None:
        if self.stereo is Stereo.SGBM and self.generations_per_frame > 1:
            msg = (
                "stereo = sgbm processes each frame once: generations_per_frame must be 0 or "
                f"1, got {self.generations_per_frame}"
            )
            raise ConfigError(msg)

    @property
    def mode(self) -> Mode:
        if self.sync or self.stereo is Stereo.SGBM:
            return Mode.SYNC
        return Mode.PER_FRAME if self.generations_per_frame > 0 else Mode.ASYNC

    @property
    def generations_per_cycle(self) -> int:
        """Generations per frame in the frame-driven modes (sync runs at least one)."""
        return max(1, self.generations_per_frame)

    def generation_cost_ns(self, evaluations: int) -> int:
        """Virtual time of one generation (of one frame for sgbm), ns: the fly engine's
        evaluations / evals_per_second, SGBM's fixed sgbm.seconds_per_frame."""
        if self.stereo is Stereo.SGBM:
            return self.sgbm.cost_ns
        return round(evaluations * 1e9 / self.evals_per_second)


def load_replay_config(path: Path) -> ReplayConfig:
    return from_mapping(ReplayConfig, read_toml(path), source=str(path))
