"""Imported datasets: flies against SGBM on the Middlebury 2014 Motorcycle pair (the
quarter-size pair scikit-image ships, 741×500, with its ground truth), at equal compute
time, and the speed of ``flylog import`` for each format.

Equal compute: G generations of the default fly engine (5000 flies) on the pair cost about
what one SgbmEngine.step (3-way, 64 disparities, block 5, grey) costs, both measured here on
that pair (the method of bench_baseline). Both replays then charge the virtual clock what
this machine spent. Scores: ``flylog metrics`` against the ground-truth disparity
(flylog.metrics.image_truth); "SGBM at the flies' pixels" looks up SGBM's dense map at the
rounded left pixel of every scored fly. Import speed is pairs per second, with reading the
pair's two PNGs as the reference.
"""

from __future__ import annotations

import dataclasses
import shutil
import statistics
import time
import warnings
from pathlib import Path

import cv2
import numpy as np
import skimage.data

from flylog.baseline import SgbmConfig
from flylog.baseline.sgbm import SgbmEngine, disparity_px, grey_levels, stereo_matcher
from flylog.datasets.run import import_dataset
from flylog.fly import EngineConfig, FlyEngine
from flylog.geometry import Pose2D
from flylog.io import contract
from flylog.io.reader import open_log
from flylog.metrics.config import MetricsConfig
from flylog.metrics.image_truth import read_disparity_truth, score_pixels, truth_at
from flylog.metrics.result import run_facts
from flylog.metrics.score import score_run
from flylog.replay.config import ReplayConfig, Stereo
from flylog.replay.run import replay
from flylog.sensors import StereoPair
from flylog.sources.inputs import log_rig
from tests.datasets.layouts import (
    write_euroc,
    write_kitti_multiview,
    write_kitti_sequence,
    write_kitti_stereo,
)
from tests.datasets.test_motorcycle import write_motorcycle

REPEATS = 7
IMPORT_PAIRS = 8


def _times(fn, repeats: int = REPEATS) -> list[float]:
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def _fly_frame_times(pair: StereoPair, rig, generations: int) -> tuple[list[float], int]:
    engine = FlyEngine(EngineConfig(), rig, np.random.default_rng(0))
    engine.set_images(pair)
    for _ in range(10):
        engine.step()
    evals = 0

    def frame() -> None:
        nonlocal evals
        engine.set_images(pair)
        evals = sum(engine.step().evaluations for _ in range(generations))

    return _times(frame), evals


def _sgbm_at_flies(run: Path, log: Path) -> dict[str, float]:
    """SGBM's dense map (default [sgbm]) looked up at the scored flies' rounded pixels."""
    reader = open_log(log)
    rig = log_rig(reader, mounted=False)
    truth = read_disparity_truth(reader).images[0]
    pair = next(reader.stereo_pairs())
    dense = disparity_px(
        stereo_matcher(SgbmConfig()), grey_levels(pair.left), grey_levels(pair.right)
    )
    rule = dataclasses.replace(
        run_facts(open_log(run), MetricsConfig()).rule, ground_margin=-np.inf
    )
    cloud = [m.value for m in open_log(run).messages([contract.FLIES])][-1]
    xyz = cloud.xyz[rule.mask(cloud.xyz, cloud.fitness, cloud.age, cloud.distinct)]
    u, _, v, depth = rig.project(xyz.astype(np.float64))
    inside = (depth > 0) & (np.rint(u) >= 0) & (np.rint(u) <= rig.width - 1)
    inside &= (np.rint(v) >= 0) & (np.rint(v) <= rig.height - 1)
    u, v = u[inside], v[inside]
    known = np.isfinite(truth_at(truth, u, v))
    ru, rv = np.rint(u[known]).astype(int), np.rint(v[known]).astype(int)
    d = dense[rv, ru].astype(np.float64)
    matched = d >= 0
    score = score_pixels(
        ru[matched],
        rv[matched],
        d[matched],
        rig.depth_of_disparity(d[matched]),
        truth,
        rig,
        MetricsConfig(),
    )
    return {
        "bad2": float(np.mean(score.disparity_errors > 2.0)),
        "matched": float(matched.mean()),
        "pixels": float(known.sum()),
    }


def _motorcycle_figures(out_dir: Path) -> list[dict]:
    root = out_dir / "bench_datasets_middlebury"
    shutil.rmtree(root, ignore_errors=True)
    write_motorcycle(root / "Motorcycle")
    (log,) = import_dataset("middlebury", root, out_dir / "bench_datasets_motorcycle.mcap")
    reader = open_log(log.path)
    rig = log_rig(reader, mounted=False)
    pair = next(reader.stereo_pairs())
    engine = SgbmEngine(SgbmConfig(), rig, points=EngineConfig().flies)
    engine.set_images(pair)
    engine.step()
    step = _times(engine.step)
    sgbm_s = statistics.median(step)
    one, _ = _fly_frame_times(pair, rig, 1)
    eleven, _ = _fly_frame_times(pair, rig, 11)
    first, later = min(one), max(1e-6, (min(eleven) - min(one)) / 10)
    generations = max(1, round(1 + (min(step) - first) / later))
    fly, evals = _fly_frame_times(pair, rig, generations)
    fly_s = statistics.median(fly)
    configs = {
        "flies": ReplayConfig(generations_per_frame=generations, evals_per_second=evals / fly_s),
        "sgbm": ReplayConfig(
            stereo=Stereo.SGBM, sgbm=dataclasses.replace(SgbmConfig(), seconds_per_frame=sgbm_s)
        ),
    }
    s = {}
    runs = {}
    for name, config in configs.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            runs[name] = replay(log.path, out_dir / f"bench_datasets_{name}.mcap", config)
        s[name] = score_run(runs[name].output, log.path).summary
    at = _sgbm_at_flies(runs["flies"].output, log.path)
    f, g = s["flies"], s["sgbm"]
    sgbm_wall = runs["sgbm"].wall_seconds
    note = f"Motorcycle 741x500, flies {generations} generations vs 1 SGBM step, equal wall time"
    return [
        {
            "name": "SgbmEngine.step motorcycle (median)",
            "value": sgbm_s * 1e3,
            "unit": "ms",
            "note": f"min {min(step) * 1e3:.1f}, max {max(step) * 1e3:.1f} over {REPEATS}",
        },
        {
            "name": "fly frame at equal compute (median)",
            "value": fly_s * 1e3,
            "unit": "ms",
            "reference": "SgbmEngine.step",
            "ratio": fly_s / sgbm_s,
            "note": f"5000 flies, {generations} generations, {evals} evaluations",
        },
        {
            "name": "bad2 flies taken",
            "value": f["bad2"],
            "unit": "",
            "reference": "sgbm points",
            "ratio": f["bad2"] / g["bad2"] if g["bad2"] else float("nan"),
            "note": f"{f['scored_points']} flies scored; {note}",
        },
        {
            "name": "bad2 SGBM at the flies' pixels",
            "value": at["bad2"],
            "unit": "",
            "note": f"{at['pixels']:.0f} pixels, SGBM matched {at['matched']:.1%} of them",
        },
        {
            "name": "bad2 SGBM points",
            "value": g["bad2"],
            "unit": "",
            "note": f"{g['scored_points']} points scored",
        },
        {
            "name": "bad2 SGBM dense, all ground-truth pixels",
            "value": g["sgbm_dense_bad2"],
            "unit": "",
            "note": f"matched {g['sgbm_dense_density']:.1%} of the truth pixels",
        },
        {
            "name": "coverage flies",
            "value": f["coverage"],
            "unit": "",
            "reference": "sgbm points",
            "ratio": f["coverage"] / g["coverage"] if g["coverage"] else float("nan"),
            "note": f"sgbm points {g['coverage']:.3f}",
        },
        {
            "name": "median disparity error flies",
            "value": f["disparity_error_median_px"],
            "unit": "px",
            "note": f"sgbm points {g['disparity_error_median_px']:.3f} px",
        },
        {
            "name": "replay wall time flies",
            "value": runs["flies"].wall_seconds,
            "unit": "s",
            "reference": "sgbm replay",
            "ratio": runs["flies"].wall_seconds / sgbm_wall,
            "note": f"sgbm {runs['sgbm'].wall_seconds:.2f} s (log decoding and writing included)",
        },
    ]


def _import_speed(out_dir: Path) -> list[dict]:
    left, right, disparity = skimage.data.stereo_motorcycle()
    root = out_dir / "bench_datasets_import"
    shutil.rmtree(root, ignore_errors=True)
    root.mkdir()
    mid = root / "middlebury"
    for k in range(IMPORT_PAIRS):
        write_motorcycle(mid / f"scene{k}")
    rig = log_rig(open_log(out_dir / "bench_datasets_motorcycle.mcap"), mounted=False)
    rig = dataclasses.replace(rig, doffs=0.0)  # KITTI and the rectified EuRoC pair: doffs 0
    write_kitti_stereo(root / "kitti", rig, [(left, right, disparity)] * IMPORT_PAIRS)
    views = [(6 + k, left, right) for k in range(IMPORT_PAIRS)]  # frames 06 … 13
    write_kitti_multiview(root / "multiview", rig, [views], [disparity])
    stamps = [round(k * 1e9 / 10) for k in range(IMPORT_PAIRS)]
    frames = [(t, left, right) for t in stamps]
    write_kitti_sequence(
        root / "odometry", rig, frames, [Pose2D(0.1 * k, 0, 0) for k in range(IMPORT_PAIRS)]
    )
    write_euroc(
        root / "euroc",
        dataclasses.replace(rig, mount_height=0.0),
        frames,
        [(t, Pose2D(0.1 * k, 0, 0)) for k, t in enumerate(stamps)],
    )
    png = min(
        _times(
            lambda: (
                cv2.imread(str(mid / "scene0" / "im0.png")),
                cv2.imread(str(mid / "scene0" / "im1.png")),
            ),
            5,
        )
    )
    figures = []
    for name, layout, path in (
        ("middlebury", "middlebury", mid),
        ("kitti stereo", "kitti", root / "kitti"),
        ("kitti multiview", "kitti", root / "multiview"),
        ("kitti odometry", "kitti", root / "odometry"),
        ("euroc", "euroc", root / "euroc"),
    ):
        out = root / f"{name.replace(' ', '_')}_out"
        multiview = name.endswith("multiview")

        def once(layout=layout, path=path, out=out, multiview=multiview) -> None:
            if out.is_dir():
                shutil.rmtree(out)
            out.unlink(missing_ok=True)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                import_dataset(layout, path, out, multiview=multiview)

        best = min(_times(once, 3))
        pairs_s = IMPORT_PAIRS / best
        figures.append(
            {
                "name": f"import {name}",
                "value": pairs_s,
                "unit": "pairs/s",
                "reference": "reading the pair's 2 PNGs",
                "ratio": best / IMPORT_PAIRS / png,
                "note": f"{IMPORT_PAIRS} pairs of 741x500 (best of 3); ratio: time a pair / PNGs",
            }
        )
    return figures


def run(out_dir: Path) -> list[dict]:
    return _motorcycle_figures(out_dir) + _import_speed(out_dir)
