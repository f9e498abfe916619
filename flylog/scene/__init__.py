"""Scenes: the scene file format (see :mod:`flylog.scene.load`), obstacles and geometry queries."""

from flylog.scene.footprints import Footprints, compile_footprints, distance_to_footprints
from flylog.scene.load import Scene, distance_to_obstacles, load_scene, parse_scene
from flylog.scene.spec import (
    ClutterConfig,
    DriveConfig,
    GroundConfig,
    LightingConfig,
    ObstacleConfig,
    ObstacleKind,
    RobotConfig,
    SceneSpec,
    TextureConfig,
    VelocityCommand,
)

__all__ = [
    "ClutterConfig",
    "DriveConfig",
    "Footprints",
    "GroundConfig",
    "LightingConfig",
    "ObstacleConfig",
    "ObstacleKind",
    "RobotConfig",
    "Scene",
    "SceneSpec",
    "TextureConfig",
    "VelocityCommand",
    "compile_footprints",
    "distance_to_footprints",
    "distance_to_obstacles",
    "load_scene",
    "parse_scene",
]
