"""Stereo pairs per second at 640×480 (render + sonar), against the 15 Hz real-time rate."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from flylog.geometry import Pose2D
from flylog.scene import load_scene
from flylog.sim.render import Renderer
from flylog.sim.sonar import sonar_ranges

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
REAL_TIME_HZ = 15.0
FRAMES = 60


def _pairs_per_second(name: str) -> tuple[float, float]:
    scene = load_scene(FIXTURES / f"{name}.toml")
    renderer = Renderer(scene, scene.spec.camera)
    rng = np.random.default_rng(0)
    start = scene.start_pose
    # Poses along the start heading, turning slowly: a view that changes like a drive.
    poses = [
        Pose2D(start.x + 0.05 * k * math.cos(start.theta), start.y, start.theta - 0.01 * k)
        for k in range(FRAMES)
    ]
    renderer.render(poses[0])  # warm-up: compile or load the cached kernel
    t0 = time.perf_counter()
    for pose in poses:
        renderer.render(pose)
        sonar_ranges(scene, scene.spec.sonar, pose, rng)
    full = FRAMES / (time.perf_counter() - t0)
    t0 = time.perf_counter()
    for pose in poses:
        renderer.render_depth(pose)
    depth_only = FRAMES / (time.perf_counter() - t0)
    return full, depth_only


def run(out_dir: Path) -> list[dict]:
    figures = []
    for name in ("corridor", "clutter"):
        full, depth_only = _pairs_per_second(name)
        figures.append(
            {
                "name": f"render+sonar {name} 640x480",
                "value": full,
                "unit": "pairs/s",
                "reference": f"{REAL_TIME_HZ:g} Hz real time",
                "ratio": full / REAL_TIME_HZ,
                "note": f"{FRAMES} frames after warm-up",
            }
        )
        figures.append(
            {
                "name": f"render_depth {name} 640x480",
                "value": depth_only,
                "unit": "frames/s",
                "note": "left depth + ids only (metrics ground truth)",
            }
        )
    return figures
