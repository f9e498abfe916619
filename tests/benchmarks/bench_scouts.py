"""Scouting immigrants' cost while turning: generations per second and fitness evaluations
per generation (what the replay's virtual clock charges), scouting on versus off.

The turn scene at 320×240 (the latency experiment's), 5000 flies, the robot turning right
1° per frame; each frame: odometry, new images, 20 generations. On and off are interleaved
in the same process, best of 5.
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import numpy as np

from flylog.fly import EngineConfig, FlyEngine
from flylog.geometry import Pose2D, StereoRig, compose
from flylog.sensors import StereoPair

SCENE = Path(__file__).resolve().parents[2] / "fixtures" / "scenes" / "turn.toml"
FRAMES, GENERATIONS = 6, 20
YAW = -math.radians(1.0)


def _frames(rig: StereoRig) -> list[StereoPair]:
    from flylog.scene.load import load_scene
    from flylog.sim.render import Renderer

    scene = load_scene(SCENE)
    renderer = Renderer(scene, rig)
    pose, out = scene.start_pose, []
    for i in range(FRAMES):
        frame = renderer.render(pose)
        out.append(StereoPair(i, frame.left, frame.right))
        pose = compose(pose, Pose2D(0.0, 0.0, YAW))
    return out


def _run(config: EngineConfig, rig: StereoRig, frames: list[StereoPair]) -> tuple[float, int]:
    """(seconds, evaluations) of FRAMES × GENERATIONS generations."""
    engine = FlyEngine(config, rig, np.random.default_rng(0))
    evaluations = 0
    t0 = time.perf_counter()
    for pair in frames:
        engine.apply_motion(Pose2D(0.0, 0.0, YAW))
        engine.set_images(pair)
        for _ in range(GENERATIONS):
            evaluations += engine.step().evaluations
    return time.perf_counter() - t0, evaluations


def run(out_dir: Path) -> list[dict]:
    rig = StereoRig(width=320, height=240, focal_px=250.0)
    frames = _frames(rig)
    on = EngineConfig(scouting=True)
    off = dataclasses.replace(on, scouting=False)
    _run(on, rig, frames[:2])  # compile
    best = {"on": math.inf, "off": math.inf}
    evals = {}
    for _ in range(5):
        for name, config in (("off", off), ("on", on)):
            seconds, evals[name] = _run(config, rig, frames)
            best[name] = min(best[name], seconds)
    n = FRAMES * GENERATIONS
    note = f"{on.flies} flies, turn scene 320×240, 1°/frame, best of 5"
    return [
        {
            "name": "generations per second, scouting on",
            "value": n / best["on"],
            "unit": "generations/s",
            "reference": "scouting off",
            "ratio": best["off"] / best["on"],
            "note": note,
        },
        {
            "name": "fitness evaluations per generation, scouting on",
            "value": evals["on"] / n,
            "unit": "evaluations",
            "reference": "scouting off",
            "ratio": evals["on"] / evals["off"],
            "note": "what the virtual clock charges",
        },
    ]
