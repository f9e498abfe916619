"""A small log holding every topic of the contract, with the values that went into it."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from flylog.geometry import Pose2D, StereoRig
from flylog.io import BoxShape, CylinderShape, LogWriter, contract, encode
from flylog.io.contract import CommandStatus
from flylog.sensors import SonarConfig, SonarReading

RIG = StereoRig(width=24, height=16, focal_px=20.0, baseline=0.12)
SONAR = SonarConfig()
MS = 1_000_000


@dataclass
class Sample:
    """What was written: topic → list of (log time, input values)."""

    path: Path
    written: dict[str, list[tuple[int, Any]]] = field(default_factory=dict)

    def add(self, topic: str, t: int, value: Any) -> None:
        self.written.setdefault(topic, []).append((t, value))

    @property
    def count(self) -> int:
        return sum(len(v) for v in self.written.values())


def images(rng: np.random.Generator, t_index: int) -> tuple[np.ndarray, np.ndarray]:
    left = rng.integers(0, 256, (RIG.height, RIG.width, 3), dtype=np.uint8)
    right = np.roll(left, -t_index - 1, axis=1)
    return left, right


def write_sample(path: Path, *, frames: int = 6, compression: str = "zstd", **kw: Any) -> Sample:
    """Write ``frames`` stereo pairs at 15 Hz with odometry at 45 Hz, sonar at 5 Hz, every
    output topic once a frame, an attachment and metadata."""
    rng = np.random.default_rng(7)
    sample = Sample(path)
    with LogWriter(path, compression=compression, **kw) as log:
        log.attach("scene.toml", b"[scene]\nname = 'test'\n", "application/toml")
        log.add_metadata("run", {"seed": "7", "scene": "test"})
        for side in ("left", "right"):
            topic = contract.CALIBRATION_TOPICS[side]
            log.write(topic, 0, encode.camera_calibration(RIG, side, 0))
            sample.add(topic, 0, side)
        statics = encode.static_transforms(RIG, SONAR)
        log.write(contract.TF, 0, encode.frame_transforms(statics, 0))
        sample.add(contract.TF, 0, statics)
        shapes = [
            BoxShape("box0", (2.0, 0.5, 0.25), (0.4, 0.3, 0.5), 0.3, (1.0, 0.0, 0.0, 1.0)),
            CylinderShape("cyl0", (3.0, -1.0, 0.5), 0.25, 1.0, (0.0, 0.5, 1.0, 0.8)),
        ]
        log.write(contract.TRUTH_SCENE, 0, encode.scene_update(shapes, 0, contract.ODOM_FRAME))
        sample.add(contract.TRUTH_SCENE, 0, shapes)
        period = round(1e9 / 15)
        for k in range(frames):
            t = k * period
            for j in range(3):  # odometry at three times the frame rate
                to = t + j * period // 3
                theta = math.remainder(0.4 * k + j, math.tau)
                pose = Pose2D(0.01 * k + 0.003 * j, -0.02 * k, theta)
                log.write(contract.ODOM, to, encode.pose_in_frame(pose, to, contract.ODOM_FRAME))
                sample.add(contract.ODOM, to, pose)
                moving = [encode.odom_transform(pose)]
                log.write(contract.TF, to, encode.frame_transforms(moving, to))
                sample.add(contract.TF, to, moving)
            left, right = images(rng, k)
            log.write(contract.LEFT_IMAGE, t, encode.raw_image(left, t, "camera_left"))
            log.write(contract.RIGHT_IMAGE, t, encode.raw_image(right, t, "camera_right"))
            sample.add(contract.LEFT_IMAGE, t, left)
            sample.add(contract.RIGHT_IMAGE, t, right)
            disparity = rng.uniform(0, 40, (RIG.height, RIG.width)).astype(np.float32)
            disparity[0, :3] = np.nan
            log.write(
                contract.TRUTH_DISPARITY, t, encode.disparity_image(disparity, t, "camera_left")
            )
            sample.add(contract.TRUTH_DISPARITY, t, disparity)
            depth = np.float32(6.0) / (disparity + np.float32(1.0))
            log.write(contract.TRUTH_DEPTH, t, encode.disparity_image(depth, t, "camera_left"))
            sample.add(contract.TRUTH_DEPTH, t, depth)
            truth = Pose2D(0.011 * k, -0.019 * k, 0.41 * k)
            log.write(contract.TRUTH_POSE, t, encode.pose_in_frame(truth, t, contract.ODOM_FRAME))
            sample.add(contract.TRUTH_POSE, t, truth)
            if k % 3 == 0:
                ranges = rng.uniform(0.1, 3.0, 6)
                ranges[[1, 4]] = np.nan
                reading = SonarReading(t, ranges, SONAR.mounts(), math.radians(15), 3.0)
                log.write(contract.SONAR, t, encode.sonar_ranges(reading, min_range=0.05))
                sample.add(contract.SONAR, t, reading)
            xyz = rng.normal(size=(50, 3)).astype(np.float32)
            fit = rng.uniform(0, 5, 50).astype(np.float32)
            log.write(contract.FLIES, t, encode.point_cloud(xyz, fit, t, contract.BASE_FRAME))
            sample.add(contract.FLIES, t, (xyz, fit))
            uv = rng.uniform(0, 20, (50, 2))
            colours = rng.uniform(0, 1, (50, 4))
            log.write(contract.FLIES_OVERLAY, t, encode.image_annotations(uv, colours, t))
            sample.add(contract.FLIES_OVERLAY, t, (uv, colours))
            values = rng.uniform(0, 1, (5, 7)).astype(np.float32)
            origin = Pose2D(-1.0, -2.0, 0.25)
            log.write(
                contract.PLANNER_POTENTIAL,
                t,
                encode.grid(values, origin, 0.1, t, contract.ODOM_FRAME),
            )
            sample.add(contract.PLANNER_POTENTIAL, t, (values, origin, 0.1))
            detected = rng.uniform(0, 1, (5, 7)) < 0.2
            inflated = detected | (rng.uniform(0, 1, (5, 7)) < 0.3)
            occupancy = encode.occupancy_grid(detected, inflated, origin, 0.1, t, "odom")
            log.write(contract.PLANNER_MAP, t, occupancy)
            sample.add(contract.PLANNER_MAP, t, (detected, inflated))
            path_xyt = np.column_stack([np.linspace(0, 1, 4), np.zeros(4), np.linspace(0, 1, 4)])
            log.write(
                contract.PLANNER_PATH, t, encode.poses_in_frame(path_xyt, t, contract.ODOM_FRAME)
            )
            sample.add(contract.PLANNER_PATH, t, path_xyt)
            cmd = encode.command(0.2, -0.1 * k, CommandStatus.DRIVING, t)
            log.write(contract.PLANNER_COMMAND, t, cmd)
            sample.add(contract.PLANNER_COMMAND, t, (0.2, -0.1 * k, "driving"))
    return sample


@pytest.fixture(scope="module")
def sample_log(tmp_path_factory: pytest.TempPathFactory) -> Sample:
    return write_sample(tmp_path_factory.mktemp("io") / "sample.mcap")
