"""A scene as the TOML text of a scene file (the format of :mod:`flylog.scene.load`),
holding only what differs from a scene file's defaults that generated worlds set: the
name, duration and seed, the ground, the light, the obstacles, the robot, the
``[generated]`` table and the ``[camera_defects]`` fields that differ from their defaults."""

from __future__ import annotations

import dataclasses
import numbers
from typing import Any

from flylog.scene.spec import ObstacleConfig, ObstacleKind, SceneSpec, TextureConfig
from flylog.sim.camera_defects import CameraDefects


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, numbers.Integral):
        return repr(int(v))
    if isinstance(v, numbers.Real):  # numpy's floats too (their repr is not TOML)
        return repr(float(v))
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (tuple, list)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_value(x)}" for k, x in v.items()) + " }"
    msg = f"no TOML form for {v!r}"
    raise TypeError(msg)


def _texture(t: TextureConfig) -> dict[str, Any]:
    return {"color": list(t.color), "feature_size": t.feature_size, "contrast": t.contrast}


def _obstacle(ob: ObstacleConfig) -> list[str]:
    lines = ["[[obstacles]]", f"kind = {_value(ob.kind.value)}"]
    if ob.kind is ObstacleKind.WALL:
        fields: dict[str, Any] = {"start": ob.start, "end": ob.end, "thickness": ob.thickness}
    elif ob.kind is ObstacleKind.BOX:
        fields = {"center": ob.center, "size": ob.size, "yaw_deg": ob.yaw_deg}
    else:
        fields = {"center": ob.center, "radius": ob.radius}
    fields |= {"height": ob.height, "texture": _texture(ob.texture)}
    lines += [f"{k} = {_value(v)}" for k, v in fields.items()]
    return lines


def scene_text(spec: SceneSpec, header: str = "") -> str:
    """The scene file's text; ``header``: comment lines put first."""
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    lines += [f"name = {_value(spec.name)}", f"seed = {spec.seed}"]
    if spec.duration is not None:
        lines.append(f"duration = {_value(spec.duration)}")
    lines += ["", "[ground.texture]"]
    lines += [f"{k} = {_value(v)}" for k, v in _texture(spec.ground.texture).items()]
    light = spec.lighting
    lines += ["", "[lighting]"]
    lines += [
        f"{k} = {_value(getattr(light, k))}" for k in ("azimuth_deg", "elevation_deg", "ambient")
    ]
    robot = spec.robot
    lines += ["", "[robot]"]
    lines += [
        f"start = {_value(robot.start)}",
        f"goal = {_value(robot.goal)}",
        f"radius = {_value(robot.radius)}",
    ]
    if spec.generated is not None:
        g = spec.generated
        lines += ["", "[generated]", f"family = {_value(g.family)}", f"seed = {g.seed}"]
        lines.append(f"reachable = {_value(g.reachable)}")
        for k in ("optimal_path_m", "narrowest_gap_m"):
            if getattr(g, k) is not None:
                lines.append(f"{k} = {_value(getattr(g, k))}")
        lines += [
            f"difficulty = {_value(g.difficulty)}",
            f"check_radius = {_value(g.check_radius)}",
        ]
    if spec.camera_defects != CameraDefects():
        lines += ["", "[camera_defects]"]
        lines += [
            f"{f.name} = {_value(getattr(spec.camera_defects, f.name))}"
            for f in dataclasses.fields(CameraDefects)
            if getattr(spec.camera_defects, f.name) != f.default
        ]
    for ob in spec.obstacles:
        lines += ["", *_obstacle(ob)]
    return "\n".join(lines) + "\n"
