"""The stereo engine behind the replay pipeline: the fly engine, or the SGBM baseline with
the same interface (``stereo = "sgbm"``), so the planner and the outputs are the same."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from flylog.fly.config import Photometric
from flylog.fly.engine import FlyEngine, GenerationStats
from flylog.fly.photometric import charged_evaluations
from flylog.fly.population import Population
from flylog.geometry import Pose2D, StereoRig
from flylog.replay.config import ReplayConfig, Stereo
from flylog.sensors import SonarReading, StereoPair


class StereoEngine(Protocol):
    """What the pipeline needs of an engine (FlyEngine and SgbmEngine implement it)."""

    def set_images(self, pair: StereoPair) -> StereoPair:
        """Work on ``pair`` (with its ``readout``, the robot's motion over a rolling
        shutter's readout, for an engine that places points at their rows' times); returns
        it as the engine matches it."""
        ...

    def set_sonar(self, reading: SonarReading) -> None: ...

    def apply_motion(self, increment: Pose2D) -> None: ...

    def step(self) -> GenerationStats: ...

    def steps(self, count: int) -> list[GenerationStats]: ...

    @property
    def population(self) -> Population: ...


def stereo_engine(config: ReplayConfig, rig: StereoRig) -> StereoEngine:
    """The engine ``config.stereo`` names; SGBM samples as many points as there are flies."""
    if config.stereo is Stereo.SGBM:
        from flylog.baseline.sgbm import SgbmEngine  # OpenCV only when asked for

        return SgbmEngine(config.sgbm, rig, points=config.engine.flies)
    return FlyEngine(config.engine, rig, np.random.default_rng(config.seed))


def photometric_evaluations(config: ReplayConfig, rig: StereoRig) -> int:
    """The evaluations each stereo pair's photometric matching is charged (0: SGBM, or
    ``engine.photometric = "none"``)."""
    if config.stereo is Stereo.SGBM or config.engine.photometric is Photometric.NONE:
        return 0
    return charged_evaluations(rig.width, rig.height)
