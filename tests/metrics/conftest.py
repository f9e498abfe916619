from __future__ import annotations

from pathlib import Path

import pytest

from flylog.scene import load_scene, parse_scene
from flylog.sim.run import SimulationOptions, simulate
from flylog.sources import read_truth
from flylog.sources.truth import LogTruth

from .helpers import FIXTURES

# Straight at 1 m/s through a thin box at x = 1 (robot radius 0.3): one collision, goal
# (1.5, 0) reached; the cylinder ahead and the wall stay in view.
COLLISION_SCENE = """
name = "collide"
duration = 2.0
[[obstacles]]
kind = "box"
center = [1.0, 0.0]
size = [0.2, 0.2]
height = 0.3
[[obstacles]]
kind = "wall"
start = [4.0, -3.0]
end = [4.0, 3.0]
height = 1.5
[robot]
goal = [1.5, 0.0]
[odometry]
linear_noise = 0.0
angular_noise = 0.0
angular_noise_floor_deg = 0.0
[drive]
commands = [{ t_start = 0.0, v = 1.0, w_deg = 0.0 }]
"""


@pytest.fixture(scope="session")
def sensor_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """near-obstacle.toml, 1.5 s at 160×120 (the metadata's rig is not the scene's)."""
    path = tmp_path_factory.mktemp("logs") / "near.mcap"
    scene = load_scene(FIXTURES / "near-obstacle.toml")
    simulate(scene, path, SimulationOptions(duration=1.5, resolution=(160, 120), seed=3))
    return path


@pytest.fixture(scope="session")
def truth(sensor_log: Path) -> LogTruth:
    return read_truth(sensor_log)


@pytest.fixture(scope="session")
def collision_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("logs") / "collide.mcap"
    scene = parse_scene(COLLISION_SCENE, "collide")
    simulate(scene, path, SimulationOptions(resolution=(64, 48)))
    return path
