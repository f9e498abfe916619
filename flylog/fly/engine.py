"""The fly engine: a persistent population evolved on the newest images, sonar and odometry.

Usable without any log: feed it :class:`~flylog.sensors.StereoPair`,
:class:`~flylog.sensors.SonarReading` and odometry increments, call :meth:`FlyEngine.step`.
One generation (paper §2): evaluate the flies whose images changed, fuse sonar, share,
select the best fraction, refill with offspring and immigrants, evaluate the newcomers.

The engine holds the data (:class:`~flylog.fly.state.EngineState`); a back-end makes the
generations (:class:`EngineBackend`): :class:`~flylog.fly.numba_backend.NumbaBackend`,
compiled, or :class:`~flylog.fly.numpy_backend.NumpyBackend`, the numpy references. Both make
the same population from the same seed.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from flylog.errors import FlylogError
from flylog.fly.config import Backend, EngineConfig
from flylog.fly.numba_backend import NumbaBackend
from flylog.fly.numpy_backend import NumpyBackend
from flylog.fly.population import Population
from flylog.fly.state import MOVED, EngineState
from flylog.fly.stats import GenerationStats
from flylog.geometry import Pose2D, StereoRig
from flylog.sensors import SonarReading, StereoPair


class EngineBackend(Protocol):
    """What makes the engine's generations."""

    def steps(self, count: int) -> list[GenerationStats]:
        """``count`` generations on the state's newest data (count ≥ 1, images set)."""
        ...

    def move(self, increment: Pose2D) -> None:
        """Every fly moved by the inverse of the robot's motion ``increment``."""
        ...


class FlyEngine:
    """The fly algorithm over a stereo rig, with sonar and odometry fusion."""

    def __init__(self, config: EngineConfig, rig: StereoRig, rng: np.random.Generator) -> None:
        self.config = config
        self.rig = rig
        self._state = EngineState(config, rig, rng)
        self._backend: EngineBackend = (
            NumbaBackend(self._state)
            if config.backend is Backend.NUMBA
            else NumpyBackend(self._state)
        )

    # --- inputs -----------------------------------------------------------------------------

    def set_images(self, pair: StereoPair) -> StereoPair:
        """Work on this pair from now on; every fly's vision fitness becomes stale. Returns
        the pair as the flies are scored on it (``photometric``: matched, or ``pair``)."""
        self._state.set_images(pair)
        assert self._state.pair is not None
        return self._state.pair

    def set_sonar(self, reading: SonarReading) -> None:
        """Use this sonar reading (in base_link) for fusion until the next one."""
        self._state.set_sonar(reading)

    def apply_motion(self, increment: Pose2D) -> None:
        """Proprioception: move every fly by the inverse of the robot's motion ``increment``
        (``relative(prev_odom, new_odom)``). Does nothing when proprioception is off.

        A moved fly is the same point of the world, and its vision fitness was measured on
        images taken before the motion: it stays valid until those images are replaced
        (scoring the moved fly on the same old images would mix two poses). Only the sonar
        term, which depends on where the fly is now relative to the cones, is recomputed."""
        self._state.scouts.turned(increment.theta)  # scouting reads the turn either way
        if not self.config.proprioception:
            return
        self._backend.move(increment)
        self._state.fused_with = MOVED

    # --- outputs ----------------------------------------------------------------------------

    @property
    def population(self) -> Population:
        """A read-only snapshot of the population, valid at any time."""
        return self._state.pop.copy(readonly=True)

    @property
    def sharing_radius(self) -> float:
        return self._state.radius

    @property
    def generation(self) -> int:
        return self._state.generation

    # --- generations ------------------------------------------------------------------------

    def step(self) -> GenerationStats:
        """One generation on the newest data."""
        return self.steps(1)[0]

    def steps(self, count: int) -> list[GenerationStats]:
        """``count`` generations on the newest data, as ``count`` calls of :meth:`step` make
        them (same population, same statistics), in one compiled call with the numba
        back-end (:func:`~flylog.fly.generation.generations_kernel`). For a caller that
        gives the engine nothing and reads nothing between them (replay, between two
        ticks)."""
        if count < 1:
            return []
        if self._state.left is None:
            msg = "the fly engine has no images yet: call set_images() before step()"
            raise FlylogError(msg)
        return self._backend.steps(count)
