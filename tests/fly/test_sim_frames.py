"""What the simulator's frames must satisfy (flylog.sim.render, fixture scenes)."""

import math
from pathlib import Path

import numpy as np
import pytest

render = pytest.importorskip(
    "flylog.sim.render", reason="flylog.sim.render (the simulator's renderer) is missing"
)
scene_load = pytest.importorskip("flylog.scene.load", reason="flylog.scene.load is missing")
sim_sonar = pytest.importorskip("flylog.sim.sonar", reason="flylog.sim.sonar is missing")

from flylog.fly import EngineConfig, FlyEngine  # noqa: E402
from flylog.fly.config import Gradient  # noqa: E402
from flylog.geometry import Pose2D, compose, relative  # noqa: E402
from flylog.sensors import SonarReading, StereoPair  # noqa: E402
from tests.fly.analytic import on_surface_share  # noqa: E402

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"


def _scene(name):
    path = SCENES / f"{name}.toml"
    if not path.exists():
        pytest.skip(f"fixture scene {path} is missing")
    scene = scene_load.load_scene(path)
    return scene, render.Renderer(scene, scene.spec.camera)


def _pair(frame, stamp=0):
    return StereoPair(stamp, frame.left, frame.right)


@pytest.mark.parametrize("name", ["corridor", "turn", "near-obstacle", "clutter"])
def test_convergence_on_simulator_frame(name):
    # Measured (seed 1, 50 generations of 5000 flies, 640×480): corridor 0.93, turn 0.91,
    # near-obstacle 0.91, clutter 0.91; flies on the sky count as misses.
    scene, renderer = _scene(name)
    rig = scene.spec.camera
    frame = renderer.render(scene.start_pose)
    engine = FlyEngine(EngineConfig(flies=5000), rig, np.random.default_rng(1))
    engine.set_images(_pair(frame))
    for _ in range(50):
        engine.step()
    pop = engine.population
    assert on_surface_share(pop.xyz, pop.fitness, frame.depth.astype(float), rig) >= 0.85


def test_proprioception_on_the_turn_scene():
    scene, renderer = _scene("turn")
    rig = scene.spec.camera
    poses = [compose(scene.start_pose, Pose2D(0.0, 0.0, -math.radians(i))) for i in range(6)]
    frames = [renderer.render(p) for p in poses]
    # Measured with the textured sky, 5 seeds × 6 and 11 frames: proprioception wins every
    # time, by 0.015–0.040 of the flies above the median fitness (mean ≈ 0.025). The paper's
    # claim, with the paper's fitness (the norm gradient): with the default horizontal one,
    # this measure favours the flies left in place (seeds 0–2: 0.865–0.899 with
    # proprioception, 0.943–0.949 without; see docs/performance.md's known gaps).
    gaps = []
    for seed in range(3):
        share = {}
        for on in (True, False):
            engine = FlyEngine(
                EngineConfig(flies=5000, proprioception=on, gradient=Gradient.NORM),
                rig,
                np.random.default_rng(seed),
            )
            engine.set_images(_pair(frames[0]))
            for _ in range(20):
                engine.step()
            shares = []
            for i in range(1, len(poses)):
                engine.apply_motion(relative(poses[i - 1], poses[i]))
                engine.set_images(_pair(frames[i], i))
                engine.step()
                pop = engine.population
                depth = frames[i].depth.astype(float)
                shares.append(on_surface_share(pop.xyz, pop.fitness, depth, rig))
            share[on] = np.mean(shares)
        assert share[True] > share[False], (seed, share)
        gaps.append(share[True] - share[False])
    assert np.mean(gaps) > 0.015, gaps


def test_sonar_fusion_on_the_near_obstacle_scene():
    scene, renderer = _scene("near-obstacle")
    rig = scene.spec.camera
    post = scene.obstacles[0]
    (cx, cy), radius = post.center, post.radius
    frame = renderer.render(scene.start_pose)
    sonar = scene.spec.sonar
    ranges = sim_sonar.true_sonar_ranges(scene, sonar, scene.start_pose)
    assert np.isfinite(ranges).sum() >= 1
    reading = SonarReading(0, ranges, sonar.mounts(), math.radians(sonar.cone_deg), sonar.max_range)
    totals = {True: 0, False: 0}
    for seed in range(4):
        found = {}
        for fuse in (True, False):
            cfg = EngineConfig(flies=5000, sonar_fitness=fuse, sonar_immigration=fuse)
            engine = FlyEngine(cfg, rig, np.random.default_rng(seed))
            engine.set_images(_pair(frame))
            engine.set_sonar(reading)
            for _ in range(6):
                engine.step()
            xyz = engine.population.xyz
            near = np.hypot(xyz[:, 0] - cx, xyz[:, 1] - cy) < radius + 0.05
            found[fuse] = int((near & (xyz[:, 2] < post.height + 0.05)).sum())
            totals[fuse] += found[fuse]
        assert found[True] > found[False], (seed, found)
    assert totals[True] > 1.3 * totals[False]
