"""The SGBM baseline (``flylog replay --engine sgbm``): its wall time per 640×480 frame, and
``flylog metrics`` precision / recall of flies versus SGBM on the same corridor log at equal
compute time per frame.

Equal compute: the fly engine runs G generations per frame, G chosen so that its wall time
per frame (set_images + G steps, 5000 flies) is about SgbmEngine.step's, both measured in
this run on the same 640×480 frame. Both replays then charge the virtual clock what this
machine spent: the flies at the measured evaluations per wall second, SGBM its measured
seconds per frame. The flies run per-frame (an image is available at its stamp), SGBM sync
(one frame period later, the conventional pipeline). Figures are noisy on a shared 2-core
machine: run twice and compare.
"""

from __future__ import annotations

import dataclasses
import statistics
import time
from pathlib import Path

import cv2
import numpy as np

from flylog.baseline import SgbmConfig
from flylog.baseline.sgbm import SgbmEngine, grey_levels, stereo_matcher
from flylog.fly import EngineConfig, FlyEngine
from flylog.metrics.score import score_run
from flylog.replay.config import ReplayConfig, Stereo
from flylog.replay.run import replay
from flylog.scene.load import load_scene
from flylog.sensors import StereoPair
from flylog.sim.render import Renderer
from flylog.sim.run import SimulationOptions, simulate

SCENE = Path(__file__).resolve().parents[2] / "fixtures" / "scenes" / "corridor.toml"
LOG_SECONDS = 10.0
REPEATS = 15


def _frame() -> tuple[StereoPair, object]:
    scene = load_scene(SCENE)
    rig = scene.spec.camera  # 640×480
    frame = Renderer(scene, rig).render(scene.start_pose)
    return StereoPair(0, frame.left, frame.right), rig


def _times(fn, repeats: int = REPEATS) -> list[float]:
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def _fly_frame_times(pair: StereoPair, rig, generations: int) -> tuple[list[float], int]:
    """Wall times of one frame (set_images + ``generations`` steps) and its evaluations."""
    engine = FlyEngine(EngineConfig(), rig, np.random.default_rng(0))
    engine.set_images(pair)
    for _ in range(10):  # compile and converge a little
        engine.step()
    evals = 0

    def frame() -> None:
        nonlocal evals
        engine.set_images(pair)
        evals = sum(engine.step().evaluations for _ in range(generations))

    return _times(frame), evals


def _wall_figures() -> tuple[list[dict], float, int, float]:
    pair, rig = _frame()
    engine = SgbmEngine(SgbmConfig(), rig, points=EngineConfig().flies)
    engine.set_images(pair)
    engine.step()
    step = _times(engine.step)
    grey_l, grey_r = grey_levels(pair.left), grey_levels(pair.right)
    matcher = stereo_matcher(SgbmConfig())
    compute = _times(lambda: matcher.compute(grey_l, grey_r))
    sgbm_s = statistics.median(step)
    # Generations per frame for equal wall time, from the fastest repeats (the least
    # disturbed by the other processes): a frame's first step re-scores every fly.
    one, _ = _fly_frame_times(pair, rig, 1)
    eleven, _ = _fly_frame_times(pair, rig, 11)
    first, later = min(one), max(1e-6, (min(eleven) - min(one)) / 10)
    generations = max(1, round(1 + (min(step) - first) / later))
    fly, evals = _fly_frame_times(pair, rig, generations)
    fly_s = statistics.median(fly)
    figures = [
        {
            "name": "SgbmEngine.step 640x480 (median)",
            "value": sgbm_s * 1e3,
            "unit": "ms",
            "note": f"min {min(step) * 1e3:.1f} ms, max {max(step) * 1e3:.1f} ms over {REPEATS}; "
            f"64 disparities, block 5, 3-way, grey; cv2 threads {cv2.getNumThreads()}",
        },
        {
            "name": "StereoSGBM.compute alone 640x480 (median)",
            "value": statistics.median(compute) * 1e3,
            "unit": "ms",
            "reference": "SgbmEngine.step",
            "ratio": statistics.median(compute) / sgbm_s,
            "note": "the rest: RGB→grey, texture confidence, sampling, back-projection",
        },
        {
            "name": "fly engine frame at equal compute (median)",
            "value": fly_s * 1e3,
            "unit": "ms",
            "reference": "SgbmEngine.step",
            "ratio": fly_s / sgbm_s,
            "note": f"5000 flies, {generations} generations/frame, {evals} evaluations/frame "
            f"({evals / fly_s / 1e6:.2f} M evaluations/s wall); min {min(fly) * 1e3:.1f} ms; "
            f"fastest first step {first * 1e3:.1f} ms, each further {later * 1e3:.1f} ms",
        },
    ]
    return figures, sgbm_s, generations, evals / fly_s


def _log(out_dir: Path) -> Path:
    path = out_dir / f"bench_baseline_corridor_{LOG_SECONDS:g}s.mcap"
    if not path.exists():
        simulate(load_scene(SCENE), path, SimulationOptions(duration=LOG_SECONDS))
    return path


def _metrics_figures(out_dir: Path, sgbm_s: float, generations: int, evals_per_s: float):
    log = _log(out_dir)
    runs = {
        "flies": ReplayConfig(generations_per_frame=generations, evals_per_second=evals_per_s),
        "sgbm": ReplayConfig(
            stereo=Stereo.SGBM, sgbm=dataclasses.replace(SgbmConfig(), seconds_per_frame=sgbm_s)
        ),
    }
    results = {}
    for name, config in runs.items():
        run = replay(log, out_dir / f"bench_baseline_{name}.mcap", config)
        summary = score_run(run.output, log).summary
        results[name] = (run, summary)
    figures = []
    fs, ss = results["flies"][1], results["sgbm"][1]
    for key, unit in (
        ("precision", ""),
        ("recall", ""),
        ("f_score", ""),
        ("median_depth_error", "relative"),
    ):
        figures.append(
            {
                "name": f"{key} flies, corridor {LOG_SECONDS:g} s 640x480",
                "value": fs[key],
                "unit": unit,
                "reference": f"sgbm {ss[key]:.3f}",
                "ratio": fs[key] / ss[key] if ss[key] else float("nan"),
                "note": f"flies {generations} generations/frame vs sgbm, equal wall time/frame",
            }
        )
    for name, (run, _) in results.items():
        figures.append(
            {
                "name": f"replay wall time {name}",
                "value": run.wall_seconds / run.frames * 1e3,
                "unit": "ms per frame",
                "note": f"{run.frames} frames, {run.generations} steps, "
                f"{run.wall_seconds:.1f} s for {run.log_duration:g} s of log (decoding, "
                "planner and writing included)",
            }
        )
    return figures


def run(out_dir: Path) -> list[dict]:
    figures, sgbm_s, generations, evals_per_s = _wall_figures()
    return figures + _metrics_figures(out_dir, sgbm_s, generations, evals_per_s)
