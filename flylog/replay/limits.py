"""The closed loop's bounds, checked before a closed-loop simulation starts: the planner's
rates against the scene's camera, its snapshots and grids against the limits."""

from __future__ import annotations

from flylog.replay.config import ReplayConfig
from flylog.replay.estimate import check_sampling_rates, replay_estimate
from flylog.scene.load import Scene
from flylog.sim.run import SimulationOptions, effective_scene, simulation_duration


def check_closed_loop(config: ReplayConfig, scene: Scene, options: SimulationOptions) -> None:
    """Raise ConfigError for a rate above what the camera gives, LimitError for a closed
    loop whose planner outputs or memory would exceed ``options.limits``."""
    rig = effective_scene(scene, options).spec.camera
    check_sampling_rates(config, rig.frame_rate, source=f"the scene {scene.source}")
    replay_estimate(config, rig, simulation_duration(scene, options)).check(options.limits)
