"""The photometric matching's cost (flylog.fly.photometric), against the engine's fitness
evaluations in the same run: the charge per pixel the replay's clock uses
(:data:`~flylog.fly.photometric.EVALUATIONS_PER_PIXEL`) must not be below what it measures.

A pair of the bundled `corridor` rendered through the realistic camera model (noise, gain,
blur: the matching smooths it), at 320×240 and 640×480; the best of 20 calls of
:func:`~flylog.fly.photometric.matched`, and the engine's evaluations per second in replay's
rhythm (5000 flies, a new pair every 10 generations, the matching off so it is not counted
twice), the best of 3, in the same process."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from flylog.fly import EngineConfig, FlyEngine
from flylog.fly.config import Photometric
from flylog.fly.photometric import EVALUATIONS_PER_PIXEL, matched
from flylog.geometry import StereoRig
from flylog.scene.bundled import resolve_scene
from flylog.scene.load import load_scene
from flylog.sensors import StereoPair
from flylog.sim.camera_defects import CameraDefects


def _realistic_pair(width: int, height: int) -> tuple[StereoPair, StereoRig]:
    """The first pair of the bundled corridor at the start pose, the realistic cameras'."""
    from flylog.sim.camera import CameraModel
    from flylog.sim.render import Renderer

    scene = load_scene(resolve_scene("corridor"))
    rig = scene.spec.camera.resized(width, height)
    defects = CameraDefects(ideal=False)
    rendered = Renderer(scene, rig).render(scene.start_pose)
    model = CameraModel(defects, rig, seed=0, period_s=1.0 / rig.frame_rate)
    left, right = model.pair(0, [(rendered.left, rendered.right)])
    return StereoPair(0, left, right), rig


def _best(fn, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _evaluations_per_second(pair: StereoPair, rig: StereoRig) -> float:
    config = EngineConfig(flies=5000, photometric=Photometric.NONE)
    engine = FlyEngine(config, rig, np.random.default_rng(0))
    pairs = [StereoPair(i, pair.left, pair.right) for i in range(10)]
    engine.set_images(pairs[0])
    engine.steps(20)

    def rhythm() -> int:
        done = 0
        for p in pairs:
            engine.set_images(p)
            done += sum(s.evaluations for s in engine.steps(10))
        return done

    evaluations = rhythm()
    return evaluations / _best(rhythm, 3)


def run(out_dir: Path) -> list[dict]:
    figures = []
    for width, height in ((320, 240), (640, 480)):
        pair, rig = _realistic_pair(width, height)
        seconds = _best(lambda p=pair: matched(p.left, p.right), 20)
        rate = _evaluations_per_second(pair, rig)
        per_pixel = seconds * rate / (width * height)
        figures.append(
            {
                "name": f"photometric matching, {width}×{height}, in fitness evaluations a pixel",
                "value": per_pixel,
                "unit": "evaluations/px",
                "reference": "the clock's charge, EVALUATIONS_PER_PIXEL",
                "ratio": per_pixel / EVALUATIONS_PER_PIXEL,
                "note": f"{seconds * 1e3:.2f} ms a pair; the engine's {rate / 1e6:.2f} M "
                "evaluations/s in replay's rhythm, same run",
            }
        )
    return figures


if __name__ == "__main__":
    for fig in run(Path("bench-out")):
        print(fig)
