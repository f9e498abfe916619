"""Time of ``flylog metrics`` against the duration of the data it scores.

A 10 s corridor log at 640×480 and a run file with a 5000-fly snapshot per camera frame
(15 Hz; half the flies on the true surface, half random) stand in for a replay output
until replay exists. The issue asks metrics to take under a tenth of replay's time; replay
is not faster than real time, so the ratio to the log duration bounds that ratio from above.
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from flylog.geometry import Pose2D
from flylog.io import LogWriter, contract, encode
from flylog.metrics.score import score_run
from flylog.metrics.trajectory import interpolate_poses
from flylog.metrics.truth import read_truth
from flylog.scene import load_scene
from flylog.sim.render import Renderer
from flylog.sim.run import SimulationOptions, simulate

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
DURATION = 10.0
FLIES = 5000


def _write_run(log: Path, run: Path) -> int:
    truth = read_truth(log)
    renderer = Renderer(truth.scene, truth.rig)
    rng = np.random.default_rng(0)
    period = round(1e9 / truth.rig.frame_rate)
    times = range(0, round(DURATION * 1e9) + 1, period)
    with LogWriter(run) as out:
        out.add_metadata(
            "flylog.replay",
            {"config": json.dumps({"obstacles": {"quantile": 0.5, "ground_margin": 0.05}})},
        )
        for t in times:
            pose = interpolate_poses(truth.true, np.array([t]))[0]
            depth, _ = renderer.render_depth(Pose2D(*pose))
            v, u = np.nonzero(np.isfinite(depth))
            pick = rng.integers(0, len(u), FLIES // 2)
            on = truth.rig.backproject(u[pick], v[pick], depth[v[pick], u[pick]])
            rand = rng.uniform([0.5, -3, 0], [8, 3, 1.5], (FLIES - len(on), 3))
            xyz = np.concatenate([on, rand]).astype(np.float32)
            fitness = rng.uniform(0, 1, FLIES).astype(np.float32)
            out.write(contract.FLIES, t, encode.point_cloud(xyz, fitness, t, "base_link"))
    return len(times)


def run(out_dir: Path) -> list[dict]:
    log, run_file = out_dir / "metrics-log.mcap", out_dir / "metrics-run.mcap"
    scene = load_scene(FIXTURES / "corridor.toml")
    simulate(scene, log, SimulationOptions(duration=DURATION))
    snapshots = _write_run(log, run_file)
    figures = []
    for attempt in (1, 2):
        t0 = time.perf_counter()
        result = score_run(run_file, log)
        wall = time.perf_counter() - t0
        figures.append(
            {
                "name": f"flylog metrics, corridor 640x480, run {attempt}",
                "value": wall,
                "unit": "s",
                "reference": f"{DURATION:g} s of log",
                "ratio": wall / DURATION,
                "note": f"{snapshots} snapshots of {FLIES} flies; "
                f"precision {result.summary['precision']:.2f}",
            }
        )
    truth = read_truth(log)
    t0 = time.perf_counter()
    read_truth(log)
    figures.append(
        {"name": "read truth (scene, poses) of the log", "value": time.perf_counter() - t0,
         "unit": "s", "note": f"{log.stat().st_size / 2**20:.0f} MiB log"}
    )  # fmt: skip
    for w, h in ((640, 480), (160, 120)):
        rig = dataclasses.replace(
            truth.rig, width=w, height=h, focal_px=truth.rig.focal_px * w / 640
        )
        renderer = Renderer(truth.scene, rig)
        renderer.render_depth(Pose2D())
        t0 = time.perf_counter()
        for k in range(50):
            renderer.render_depth(Pose2D(0.1 * k, 0.0, 0.0))
        figures.append(
            {"name": f"render_depth {w}x{h}", "value": (time.perf_counter() - t0) / 50 * 1e3,
             "unit": "ms"}
        )  # fmt: skip
    return figures
